#include "sw/common/quantity_text.h"

#include <cmath>
#include <cstdio>

namespace xbarsim {

std::string count_text(long long n, const std::string& noun) {
  return std::to_string(n) + " " + noun + (n == 1 ? "" : "s");
}

std::string compact_number(double v, int digits) {
  if (std::isnan(v)) return "n/a";
  char b[48];
  const double a = std::abs(v);
  if (a >= 1e4 && a < 1e15) {
    static const char* const kPrefix[] = {"", " k", " M", " G", " T"};
    int e = static_cast<int>(std::floor(std::log10(a) / 3));
    // 999,950 is "1 M", not "1000 k": the prefix of the value as it will be rounded.
    if (a / std::pow(1e3, e) >= std::pow(10.0, 3) - 0.5 * std::pow(10.0, 3 - digits) && e < 4) ++e;
    std::snprintf(b, sizeof b, "%.*g%s", digits, v / std::pow(1e3, e), kPrefix[e]);
    return b;
  }
  std::snprintf(b, sizeof b, "%.*g", digits, v);
  return b;
}

}  // namespace xbarsim
