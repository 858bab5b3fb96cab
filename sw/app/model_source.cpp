#include "sw/app/model_source.h"

#include "sw/common/parse.h"
#include "sw/nn/dataset.h"
#include "sw/nn/presets.h"

namespace xbarsim {

namespace {
constexpr long long kMaxInputSide = 8192;  ///< --input-size: largest image height or width
}  // namespace

Model model_from_args(const CliArgs& args, const ConfigTree& cfg) {
  if (args.has("--model") == args.has("--preset")) throw InputError("give exactly one of --model and --preset");
  Shape in{0, 0, 0};
  if (args.has("--input-size")) {
    if (args.has("--preset")) throw InputError("--input-size applies to --model (presets have fixed inputs)");
    const std::string s = args.get("--input-size");
    const auto comma = s.find(',');
    long long h = 0, w = 0;
    if (comma == std::string::npos || !parse_int64(s.substr(0, comma), h) || !parse_int64(s.substr(comma + 1), w) ||
        h < 1 || w < 1 || h > kMaxInputSide || w > kMaxInputSide)
      throw InputError("--input-size expects H,W (integers in 1.." + std::to_string(kMaxInputSide) + "), got '" + s +
                       "'");
    in = {-1, static_cast<int>(h), static_cast<int>(w)};
  }
  if (args.has("--preset"))
    return make_preset(args.get("--preset"), static_cast<uint64_t>(cfg.get_int("data.synthetic_seed")));
  const std::string path = find_model_file(args.get("--model"), cfg);
  if (in.h > 0) {
    const Model probe = load_onnx_model(path);
    in.c = probe.input.c;
    return load_onnx_model(path, in);
  }
  return load_onnx_model(path);
}

}  // namespace xbarsim
