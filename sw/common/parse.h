#pragma once
/// Checked text-to-number conversions shared by the configuration, CSV and ONNX readers:
/// the whole text must be the number, nothing may be lost to a narrowing cast.
#include <string>

namespace xbarsim {

/// The whole of `text` (surrounding blanks allowed) as a finite double: decimal or exponent
/// form; subnormal values (e.g. 1e-320) are accepted, overflow (1e400), inf and nan are not.
bool parse_finite_double(const std::string& text, double& out);

/// The whole of `text` (surrounding blanks allowed) as a base-10 integer that fits long long.
bool parse_int64(const std::string& text, long long& out);

/// A finite double or a fraction "a/b" of two (e.g. "1/255"); b must not be 0.
bool parse_finite_ratio(const std::string& text, double& out);

}  // namespace xbarsim
