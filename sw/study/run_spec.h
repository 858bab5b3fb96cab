#pragma once
/// Every section of the configuration parsed into its typed spec at once: what a design
/// point is. Used to validate a configuration completely and to prove (in a test) that every
/// key of configs/default.yaml is read by some spec.
#include "sw/study/eval_study.h"
#include "sw/study/explore.h"
#include "sw/study/xbar_study.h"

namespace xbarsim {

struct RunSpec {
  EvalPoint design;                     ///< crossbar, solver, mapping, mitigation, conversion, calibration, converters,
                                        ///< noise, components, platform
  XbarStudySpec study;                  ///< study.*
  EvalSpec eval;                        ///< eval.*
  ExploreSpec explore;                  ///< explore.*
  Preprocessing preprocessing;          ///< preprocessing.* applied to the defaults (3 channels)
  uint64_t synthetic_seed = 0;          ///< data.synthetic_seed
  unsigned long long sweep_points = 1;  ///< limits.max_sweep_points checked
  std::string data_dir, models_dir;     ///< data.dir, data.models_dir ("" when none is found)
};

/// Parses and validates every section; InputError names the first bad key and value.
RunSpec parse_run_spec(const ConfigTree& cfg);

}  // namespace xbarsim
