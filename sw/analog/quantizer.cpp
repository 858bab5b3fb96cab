#include "sw/analog/quantizer.h"

namespace xbarsim {

int parse_bits(const ConfigTree& cfg, const std::string& key) {
  const std::string s = cfg.get_string(key);
  if (s == "none") return 0;
  return cfg.get_int32(key);
}

}  // namespace xbarsim
