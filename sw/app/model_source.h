#pragma once
/// --model / --preset handling shared by the commands that take a network.
#include "sw/common/cli_args.h"
#include "sw/common/config.h"
#include "sw/nn/dataset.h"  // find_model_file
#include "sw/nn/model.h"

namespace xbarsim {

/// The ONNX file given as --model (as a path, or a name in the models directory), or the
/// built-in --preset; --input-size H,W overrides an ONNX model's input size.
Model model_from_args(const CliArgs& args, const ConfigTree& cfg);

}  // namespace xbarsim
