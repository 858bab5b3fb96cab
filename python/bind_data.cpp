// xbarsim._core: the core's datasets as NumPy arrays (xbarsim.data reads CIFAR-10 with them, so
// Python trains on the images eval reads).
#include <cstring>

#include "python/bind.h"
#include "sw/nn/dataset.h"

namespace xbarsim::bindings {

void bind_data(py::module_& m) {
  m.def(
      "read_cifar10",
      [](const std::string& path) {
        const Dataset d = load_cifar10(path);
        const py::ssize_t n = d.count();
        py::array_t<uint8_t> images({n, py::ssize_t{d.shape.c}, py::ssize_t{d.shape.h}, py::ssize_t{d.shape.w}});
        std::memcpy(images.mutable_data(), d.pixels.data(), d.pixels.size());
        py::array_t<int64_t> labels(n);
        std::copy(d.labels.begin(), d.labels.end(), labels.mutable_data());
        return py::make_tuple(images, labels);
      },
      py::arg("path"),
      "(images uint8 N x 3 x 32 x 32, labels int64 N) of a CIFAR-10 binary file (1 label byte + 3 x 32 x 32 "
      "pixel bytes, channel-major, per record), read by eval's loader (load_cifar10); ValueError naming the "
      "file when it cannot be opened or is not such records");
}

}  // namespace xbarsim::bindings
