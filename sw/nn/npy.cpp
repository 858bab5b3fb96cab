#include "sw/nn/npy.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
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

/// A user's array file, mapped read-only: only a regular file (a FIFO would block for ever, a
/// device such as /dev/zero never ends, also behind a symbolic link), registered as read.
class MappedFile {
 public:
  MappedFile(const std::string& path, const std::string& role) {
    struct stat st;
    if (stat(path.c_str(), &st) != 0)
      throw InputError("cannot open " + role + " '" + path + "': " + std::strerror(errno));
    if (!S_ISREG(st.st_mode))
      throw InputError(role + " '" + path + "' is not a regular file (" +
                       (S_ISDIR(st.st_mode)    ? "a directory"
                        : S_ISFIFO(st.st_mode) ? "a FIFO"
                        : S_ISSOCK(st.st_mode) ? "a socket"
                                               : "a device") +
                       "): give a file written by numpy.save/savez");
    open_as_input(path, role);
    fd_ = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) throw InputError("cannot open " + role + " '" + path + "': " + std::strerror(errno));
    if (fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {  // replaced since the stat above
      close(fd_);
      throw InputError(role + " '" + path + "' is not a regular file");
    }
    size_ = static_cast<size_t>(st.st_size);
    if (size_ == 0) return;
    void* p = mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd_, 0);
    if (p == MAP_FAILED) {
      close(fd_);
      throw InputError("cannot read " + role + " '" + path + "': " + std::strerror(errno));
    }
    data_ = static_cast<const uint8_t*>(p);
  }
  ~MappedFile() {
    if (data_) munmap(const_cast<uint8_t*>(data_), size_);
    close(fd_);
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  const uint8_t* data() const { return data_; }
  size_t size() const { return size_; }

 private:
  int fd_ = -1;
  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
};

/// The most bytes one array may take in memory: half the machine's physical memory (a file that
/// asks for more is refused with its size instead of running the machine out of memory).
size_t memory_bound() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page <= 0) return size_t{8} << 30;
  return static_cast<size_t>(pages) / 2 * static_cast<size_t>(page);
}

std::string gib(double bytes) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f GiB", bytes / (1u << 30));
  return b;
}

NpyArray parse_npy_bytes(const uint8_t* b, size_t size, const std::string& origin);

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
  return parse_npy_bytes(b.data(), b.size(), origin);
}

namespace {

NpyArray parse_npy_bytes(const uint8_t* data, size_t size, const std::string& origin) {
  struct View {  // the few calls of a vector the parser makes, on mapped bytes
    const uint8_t* p;
    size_t n;
    size_t size() const { return n; }
    const uint8_t* data() const { return p; }
    uint8_t operator[](size_t k) const { return p[k]; }
  } b{data, size};
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
  if (bytes > memory_bound())
    throw InputError(origin + ": its shape " + shape + " takes " + gib(static_cast<double>(bytes)) +
                     ", more than half of this machine's memory");
  a.data.assign(b.data() + at, b.data() + at + bytes);
  return a;
}

}  // namespace

NpyArray read_npy(const std::string& path) {
  const MappedFile f(path, "the array");
  return parse_npy_bytes(f.data(), f.size(), "'" + path + "'");
}

std::map<std::string, NpyArray> read_npz(const std::string& path, const std::vector<std::string>& names) {
  const MappedFile file(path, "the dataset");
  struct View {
    const uint8_t* p;
    size_t n;
    size_t size() const { return n; }
    const uint8_t* data() const { return p; }
    const uint8_t* begin() const { return p; }
  } z{file.data(), file.size()};
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
    // Entries nobody asked for are neither inflated nor parsed (an unused array of strings, or
    // one that inflates to gigabytes, costs nothing).
    if (std::find(names.begin(), names.end(), name) == names.end()) continue;
    const std::string origin = what + ", array '" + name + "'";
    if (method == 0) {
      arrays[name] = parse_npy_bytes(z.data() + data_at, csize, origin);
      continue;
    }
    std::vector<uint8_t> bytes;
    if (method == 8) {  // deflate (numpy.savez_compressed)
      if (usize > static_cast<uint64_t>(csize) * 1032 + 1024)  // past deflate's largest ratio: a corrupt size
        throw InputError(origin + ": corrupt compressed size");
      if (usize > memory_bound())
        throw InputError(origin + " inflates to " + gib(usize) + ", more than half of this machine's memory");
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
    arrays[name] = parse_npy_bytes(bytes.data(), bytes.size(), origin);
  }
  return arrays;
}

}  // namespace xbarsim
