#include "sw/nn/npy.h"

#include <zlib.h>

#include <cstring>
#include <limits>

#include "sw/common/errors.h"
#include "sw/common/input_file.h"

namespace xbarsim {

namespace {

constexpr int64_t kMaxElements = int64_t{1} << 34;  ///< far beyond any dataset that fits in memory

uint32_t le32(const uint8_t* p) { return p[0] | p[1] << 8 | p[2] << 16 | static_cast<uint32_t>(p[3]) << 24; }
uint16_t le16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | p[1] << 8); }

/// The value of `key` in a Python dict literal such as {'descr': '<f4', 'fortran_order': False,
/// 'shape': (3, 4), }: the text from after "'key':" to the next top-level comma or brace.
std::string dict_value(const std::string& header, const std::string& key, const std::string& origin) {
  const std::string k = "'" + key + "'";
  size_t at = header.find(k);
  if (at == std::string::npos) throw InputError(origin + ": the header has no " + k);
  at = header.find(':', at + k.size());
  if (at == std::string::npos) throw InputError(origin + ": malformed header");
  int depth = 0;
  size_t end = at + 1;
  for (; end < header.size(); ++end) {
    const char c = header[end];
    if (c == '(') ++depth;
    if (c == ')') --depth;
    if (depth == 0 && (c == ',' || c == '}')) break;
  }
  std::string v = header.substr(at + 1, end - at - 1);
  const size_t b = v.find_first_not_of(" "), e = v.find_last_not_of(" ");
  return b == std::string::npos ? "" : v.substr(b, e - b + 1);
}

size_t item_size(const std::string& dtype) {
  if (dtype.size() < 2) return 0;
  const char kind = dtype[0];
  const std::string bytes = dtype.substr(1);
  if (kind != 'u' && kind != 'i' && kind != 'f' && kind != 'b') return 0;
  if (bytes == "1" || bytes == "2" || bytes == "4" || bytes == "8") {
    if (kind == 'f' && (bytes == "1" || bytes == "2")) return 0;
    if (kind == 'b' && bytes != "1") return 0;
    return static_cast<size_t>(bytes[0] - '0');
  }
  return 0;
}

}  // namespace

int64_t NpyArray::elements() const {
  int64_t n = 1;
  for (int64_t d : shape) n *= d;
  return n;
}

double NpyArray::at(int64_t k) const {
  const size_t size = item_size(dtype);
  const uint8_t* p = data.data() + static_cast<size_t>(k) * size;
  const char kind = dtype[0];
  auto bits = [&]() {
    uint64_t v = 0;
    for (size_t q = 0; q < size; ++q) v |= static_cast<uint64_t>(p[q]) << (8 * q);
    return v;
  };
  if (kind == 'f') {
    if (size == 4) {
      const uint32_t b = static_cast<uint32_t>(bits());
      float f;
      std::memcpy(&f, &b, 4);
      return f;
    }
    const uint64_t b = bits();
    double d;
    std::memcpy(&d, &b, 8);
    return d;
  }
  const uint64_t u = bits();
  if (kind == 'u' || kind == 'b') return static_cast<double>(u);
  const int shift = static_cast<int>(64 - 8 * size);  // sign-extend
  return static_cast<double>(static_cast<int64_t>(u << shift) >> shift);
}

NpyArray parse_npy(const std::vector<uint8_t>& b, const std::string& origin) {
  static const uint8_t kMagic[6] = {0x93, 'N', 'U', 'M', 'P', 'Y'};
  if (b.size() < 10 || std::memcmp(b.data(), kMagic, 6) != 0) throw InputError(origin + ": not a .npy array");
  const int major = b[6];
  size_t header_len, at;
  if (major == 1) {
    header_len = le16(b.data() + 8);
    at = 10;
  } else if (major == 2 || major == 3) {
    if (b.size() < 12) throw InputError(origin + ": truncated .npy header");
    header_len = le32(b.data() + 8);
    at = 12;
  } else {
    throw InputError(origin + ": .npy format version " + std::to_string(major) + " is not supported (1 to 3)");
  }
  if (header_len > b.size() - at) throw InputError(origin + ": truncated .npy header");
  const std::string header(reinterpret_cast<const char*>(b.data() + at), header_len);
  NpyArray a;
  std::string descr = dict_value(header, "descr", origin);
  if (descr.size() < 3 || (descr.front() != '\'' && descr.front() != '"'))
    throw InputError(origin + ": dtype " + descr + " is not a plain numeric type");
  descr = descr.substr(1, descr.size() - 2);
  const char order = descr.empty() ? '?' : descr[0];
  if (order == '>') throw InputError(origin + ": big-endian data (" + descr + ") is not supported: use '<' order");
  a.dtype = order == '<' || order == '|' || order == '=' ? descr.substr(1) : descr;
  if (!item_size(a.dtype))
    throw InputError(origin + ": dtype '" + descr + "' is not supported (uint8/16/32/64, int8/16/32/64, float32/64, bool)");
  if (dict_value(header, "fortran_order", origin) != "False")
    throw InputError(origin + ": Fortran-ordered arrays are not supported: save a C-ordered array");
  const std::string shape = dict_value(header, "shape", origin);
  if (shape.size() < 2 || shape.front() != '(' || shape.back() != ')') throw InputError(origin + ": malformed shape");
  int64_t n = 1;
  size_t q = 1;
  while (q < shape.size() - 1) {
    while (q < shape.size() - 1 && (shape[q] == ' ' || shape[q] == ',')) ++q;
    if (q >= shape.size() - 1) break;
    int64_t d = 0;
    bool digits = false;
    while (q < shape.size() - 1 && shape[q] >= '0' && shape[q] <= '9') {
      d = d * 10 + (shape[q++] - '0');
      digits = true;
      if (d > kMaxElements) throw InputError(origin + ": shape " + shape + " is too large");
    }
    if (!digits) throw InputError(origin + ": malformed shape " + shape);
    a.shape.push_back(d);
    n *= d;
    if (n > kMaxElements) throw InputError(origin + ": shape " + shape + " is too large");
  }
  const size_t bytes = static_cast<size_t>(n) * item_size(a.dtype);
  at += header_len;
  if (b.size() - at < bytes)
    throw InputError(origin + ": holds " + std::to_string(b.size() - at) + " bytes of data, its shape " + shape +
                     " needs " + std::to_string(bytes));
  a.data.assign(b.begin() + static_cast<std::ptrdiff_t>(at), b.begin() + static_cast<std::ptrdiff_t>(at + bytes));
  return a;
}

NpyArray read_npy(const std::string& path) {
  const std::string text = read_input_file(path, "the array", (size_t{1} << 34));
  return parse_npy(std::vector<uint8_t>(text.begin(), text.end()), "'" + path + "'");
}

std::map<std::string, NpyArray> read_npz(const std::string& path) {
  const std::string text = read_input_file(path, "the dataset", (size_t{1} << 34));
  const std::vector<uint8_t> z(text.begin(), text.end());
  const std::string what = "'" + path + "'";
  // The end of central directory record: the last 22+ bytes (a comment may follow it).
  if (z.size() < 22) throw InputError(what + " is not a .npz file (too short for a zip archive)");
  size_t eocd = std::string::npos;
  for (size_t k = z.size() - 22 + 1; k-- > 0 && z.size() - k <= 22 + 65535;)
    if (le32(z.data() + k) == 0x06054b50) {
      eocd = k;
      break;
    }
  if (eocd == std::string::npos) throw InputError(what + " is not a .npz file (no zip directory)");
  const uint16_t entries = le16(z.data() + eocd + 10);
  const uint32_t dir_size = le32(z.data() + eocd + 12), dir_at = le32(z.data() + eocd + 16);
  if (dir_at == 0xFFFFFFFFu || entries == 0xFFFF)
    throw InputError(what + ": a ZIP64 archive (over 4 GiB) is not supported");
  if (static_cast<size_t>(dir_at) + dir_size > eocd) throw InputError(what + ": corrupt zip directory");
  std::map<std::string, NpyArray> arrays;
  size_t p = dir_at;
  for (int e = 0; e < entries; ++e) {
    if (p + 46 > eocd || le32(z.data() + p) != 0x02014b50) throw InputError(what + ": corrupt zip directory");
    const uint16_t method = le16(z.data() + p + 10);
    const uint32_t csize = le32(z.data() + p + 20), usize = le32(z.data() + p + 24);
    const uint16_t name_len = le16(z.data() + p + 28), extra_len = le16(z.data() + p + 30),
                   comment_len = le16(z.data() + p + 32);
    const uint32_t local = le32(z.data() + p + 42);
    if (p + 46 + name_len > eocd) throw InputError(what + ": corrupt zip directory");
    std::string name(reinterpret_cast<const char*>(z.data() + p + 46), name_len);
    p += 46 + static_cast<size_t>(name_len) + extra_len + comment_len;
    if (static_cast<size_t>(local) + 30 > z.size() || le32(z.data() + local) != 0x04034b50)
      throw InputError(what + ": corrupt zip entry '" + name + "'");
    const size_t data_at =
        static_cast<size_t>(local) + 30 + le16(z.data() + local + 26) + le16(z.data() + local + 28);
    if (data_at > z.size() || csize > z.size() - data_at) throw InputError(what + ": truncated entry '" + name + "'");
    if (name.size() > 4 && name.compare(name.size() - 4, 4, ".npy") == 0) name.resize(name.size() - 4);
    const std::string origin = what + ", array '" + name + "'";
    std::vector<uint8_t> bytes;
    if (method == 0) {
      bytes.assign(z.begin() + static_cast<std::ptrdiff_t>(data_at),
                   z.begin() + static_cast<std::ptrdiff_t>(data_at + csize));
    } else if (method == 8) {  // deflate (numpy.savez_compressed)
      if (usize > static_cast<uint64_t>(csize) * 1032 + 1024)  // past deflate's largest ratio: a corrupt size
        throw InputError(origin + ": corrupt compressed size");
      bytes.resize(usize);
      z_stream s{};
      if (inflateInit2(&s, -MAX_WBITS) != Z_OK) throw InputError(origin + ": cannot start inflating");
      s.next_in = const_cast<Bytef*>(z.data() + data_at);
      s.avail_in = csize;
      s.next_out = bytes.data();
      s.avail_out = usize;
      const int rc = inflate(&s, Z_FINISH);
      inflateEnd(&s);
      if (rc != Z_STREAM_END || s.total_out != usize) throw InputError(origin + ": corrupt compressed data");
    } else {
      throw InputError(origin + ": zip compression method " + std::to_string(method) +
                       " is not supported (numpy.savez or numpy.savez_compressed)");
    }
    arrays[name] = parse_npy(bytes, origin);
  }
  return arrays;
}

}  // namespace xbarsim
