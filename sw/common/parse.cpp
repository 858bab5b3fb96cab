#include "sw/common/parse.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace xbarsim {

namespace {
std::string trimmed(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t\r\n") - b + 1);
}
}  // namespace

bool parse_finite_double(const std::string& text, double& out) {
  const std::string s = trimmed(text);
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size() || !std::isfinite(v)) return false;
  // ERANGE on a finite result is underflow to a subnormal (or zero): a representable value.
  if (errno == ERANGE && std::abs(v) > 1.0) return false;
  out = v;
  return true;
}

bool parse_int64(const std::string& text, long long& out) {
  const std::string s = trimmed(text);
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (end != s.c_str() + s.size() || errno == ERANGE) return false;
  out = v;
  return true;
}

bool parse_finite_ratio(const std::string& text, double& out) {
  const auto slash = text.find('/');
  if (slash == std::string::npos) return parse_finite_double(text, out);
  double a = 0, b = 0;
  if (!parse_finite_double(text.substr(0, slash), a) || !parse_finite_double(text.substr(slash + 1), b) || b == 0)
    return false;
  const double v = a / b;
  if (!std::isfinite(v)) return false;
  out = v;
  return true;
}

}  // namespace xbarsim
