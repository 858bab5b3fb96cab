#include "sw/study/run_spec.h"

#include "sw/study/sweep.h"

namespace xbarsim {

RunSpec parse_run_spec(const ConfigTree& cfg) {
  RunSpec r;
  r.sweep_points = sweep_points(cfg).size();
  r.design = parse_eval_point(cfg);
  r.study = parse_xbar_study_spec(cfg);
  r.eval = parse_eval_spec(cfg);
  r.explore = parse_explore_spec(cfg);
  r.preprocessing.mean = {0.0};
  r.preprocessing.std = {1.0};
  apply_preprocessing_overrides(cfg, r.preprocessing, 3);
  r.synthetic_seed = static_cast<uint64_t>(cfg.get_int("data.synthetic_seed"));
  // The data may be absent (tests skip then); a configured directory must exist.
  const std::string dir = cfg.get_string("data.dir"), models = cfg.get_string("data.models_dir");
  if (!dir.empty()) r.data_dir = resolve_data_dir(cfg);
  if (!models.empty()) r.models_dir = resolve_models_dir(cfg);
  return r;
}

}  // namespace xbarsim
