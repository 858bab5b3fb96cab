#pragma once
/// Seeds of random streams. Every stream is derived from a configured seed and the index of
/// the item it serves (image, layer, crossbar), never from a thread id or the order in which
/// work is scheduled, so results are bit-identical on any number of threads.
#include <cstdint>
#include <initializer_list>

namespace xbarsim {

/// SplitMix64 finaliser: a well-mixed 64-bit value of `x`.
inline uint64_t mix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/// The seed of the stream for item `indices` (e.g. {layer, image}) under `seed`.
inline uint64_t derive_seed(uint64_t seed, std::initializer_list<uint64_t> indices) {
  uint64_t s = mix64(seed);
  for (uint64_t i : indices) s = mix64(s ^ mix64(i + 0x632BE59BD9B4E019ull));
  return s;
}

}  // namespace xbarsim
