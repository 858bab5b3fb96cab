#include "sw/analog/quantizer.h"

namespace xbarsim {

int parse_bits(const ConfigTree& cfg, const std::string& key) {
  const std::string s = cfg.get_string(key);
  if (s == "none") return 0;
  const long long b = cfg.get_int(key);
  if (b < 1 || b > 24)
    throw InputError("configuration key '" + key + "' must be 'none' or a bit count 1..24, got '" + s + "'");
  return static_cast<int>(b);
}

}  // namespace xbarsim
