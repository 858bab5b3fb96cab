#pragma once
/// Simulated time from nanoseconds, refused where SystemC cannot represent it. sc_time counts
/// time resolution units (1 ps) in 64 bits, so a run that passes 2^64 ps (about 213 days of
/// simulated time: a clock of 1e-11 MHz, or very many images) would wrap around silently and
/// report, e.g., a latency shorter than one layer's busy time. Every delay the modules annotate
/// and every wait of the platform is made here.
#include <cmath>
#include <systemc>

#include "sw/common/errors.h"

namespace xbarsim {

/// `ns` nanoseconds as an sc_time, for a delay that starts `after` the current simulated time
/// (the delay a transaction has annotated so far). Throws InputError when the simulated time
/// would pass what sc_time holds (or `ns` is negative or not a number).
inline sc_core::sc_time sim_delay(double ns, const sc_core::sc_time& after = sc_core::SC_ZERO_TIME) {
  constexpr double kLimitUnits = 1.8e19;  // just below 2^64 = 1.845e19, with room for rounding
  const double unit_ns = sc_core::sc_get_time_resolution().to_seconds() * 1e9;
  const double end =
      static_cast<double>(sc_core::sc_time_stamp().value()) + static_cast<double>(after.value()) + ns / unit_ns;
  if (!(ns >= 0) || !(end < kLimitUnits))
    throw InputError(
        "the simulated time would pass the 2^64 ps (about 213 days) that SystemC's sc_time can hold, after " +
        std::to_string(sc_core::sc_time_stamp().to_seconds() / 86400.0) +
        " simulated days: platform.clock_mhz is too slow for this run or platform.images too many (raise the "
        "clock or simulate fewer images)");
  return sc_core::sc_time(ns, sc_core::SC_NS);
}

/// A span of simulated time in nanoseconds (exact to the time resolution's rounding).
inline double to_ns(const sc_core::sc_time& t) {
  const double units_per_ns = std::round(1e-9 / sc_core::sc_get_time_resolution().to_seconds());
  return static_cast<double>(t.value()) / units_per_ns;
}

}  // namespace xbarsim
