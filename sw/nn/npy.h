#pragma once
/// NumPy's array files: .npy (format 1.0-3.0, C order, little-endian) and .npz (a zip of .npy
/// files, as numpy.savez writes them stored and numpy.savez_compressed deflated). Read only;
/// every malformed or unsupported file is an InputError naming the file and the array.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace xbarsim {

struct NpyArray {
  std::string dtype;            ///< NumPy's descr without the byte order: u1, i1, i4, i8, f4, f8, ...
  std::vector<int64_t> shape;   ///< C order
  std::vector<uint8_t> data;    ///< the elements, little-endian
  int64_t elements() const;
  /// Element k as a double (any of the numeric dtypes above).
  double at(int64_t k) const;
  bool is_integer() const { return !dtype.empty() && (dtype[0] == 'u' || dtype[0] == 'i' || dtype[0] == 'b'); }
};

/// Parses the bytes of one .npy file; `origin` names it in errors.
NpyArray parse_npy(const std::vector<uint8_t>& bytes, const std::string& origin);

/// A .npy file.
NpyArray read_npy(const std::string& path);

/// The arrays `names` (without ".npy") of a .npz file, those it holds; its other entries are
/// skipped unread. Array files must be regular files (not a FIFO, a device, or a link to one);
/// an array that would take more than half the machine's memory is refused with its size.
std::map<std::string, NpyArray> read_npz(const std::string& path, const std::vector<std::string>& names);

}  // namespace xbarsim
