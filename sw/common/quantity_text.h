#pragma once
/// Numbers as every command and report prints them for a person (the CSV and JSON keep full
/// precision): counts with their noun, and compact values with a k/M/G/T prefix from 10^4 up.
#include <string>

namespace xbarsim {

/// "1 image", "0 images", "3 images" (the plural adds an "s").
std::string count_text(long long n, const std::string& noun);

/// A compact value in `digits` significant digits: "%.4g" below 10^4 ("4902", "17.39",
/// "0.0012"), from 10^4 up the same digits of thousands, millions, ... with their prefix
/// ("32.55 k", "1.5 M", "2.06 G"; never "3.255e+04"), and scientific notation only beyond
/// 10^15 and below 10^-4; "n/a" for NaN.
std::string compact_number(double v, int digits = 4);

}  // namespace xbarsim
