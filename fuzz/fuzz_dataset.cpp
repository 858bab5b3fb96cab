// libFuzzer harness: the CIFAR-10 and MNIST loaders on arbitrary file contents.
// Input layout: byte 0 selects the loader (even: CIFAR-10, odd: MNIST).
//   CIFAR-10: bytes 1.. are the .bin file; load_cifar10(file, 0, -1).
//   MNIST:    bytes 1-2 are n (little endian); the next min(n, rest) bytes are the images
//             file, the remainder the labels file (either may be gzip or plain idx).
// Expected outcome for bad input: xbarsim::InputError. Anything else is a finding.
#include <cstddef>
#include <cstdint>

#include "fuzz/fuzz_util.h"
#include "sw/common/errors.h"
#include "sw/nn/dataset.h"

namespace {

void check(const xbarsim::Dataset& d) {
  // Documented contract: count x (C*H*W) pixels, one label per image.
  XBARSIM_FUZZ_CHECK(d.shape.c >= 1 && d.shape.h >= 1 && d.shape.w >= 1);
  XBARSIM_FUZZ_CHECK(d.pixels.size() == static_cast<size_t>(d.count()) * static_cast<size_t>(d.shape.size()));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const std::string a = xbarsim_fuzz::temp_path("ds_a"), b = xbarsim_fuzz::temp_path("ds_b");
  try {
    if (data[0] % 2 == 0) {
      xbarsim_fuzz::write_file(a, data + 1, size - 1);
      check(xbarsim::load_cifar10(a, 0, -1));
    } else {
      if (size < 3) return 0;
      const size_t rest = size - 3;
      size_t n = static_cast<size_t>(data[1]) | (static_cast<size_t>(data[2]) << 8);
      if (n > rest) n = rest;
      xbarsim_fuzz::write_file(a, data + 3, n);
      xbarsim_fuzz::write_file(b, data + 3 + n, rest - n);
      check(xbarsim::load_mnist(a, b));
    }
  } catch (const xbarsim::InputError&) {
  }
  return 0;
}
