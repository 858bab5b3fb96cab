#pragma once
// Writing .npy and .npz files as NumPy does (numpy.save, numpy.savez stored,
// numpy.savez_compressed deflated), for the tests of the dataset readers.
#include <zlib.h>

#include <cstdint>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

namespace npz_writer {

/// A .npy file: format 1.0, C order, little-endian.
inline std::string npy(const std::string& descr, const std::string& shape, const std::string& data) {
  std::string header = "{'descr': '" + descr + "', 'fortran_order': False, 'shape': " + shape + ", }";
  while ((10 + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  std::string out = "\x93NUMPY";
  out += '\x01';
  out += '\x00';
  out += static_cast<char>(header.size() & 0xFF);
  out += static_cast<char>(header.size() >> 8);
  return out + header + data;
}

inline void put16(std::string& s, uint32_t v) {
  s += static_cast<char>(v & 0xFF);
  s += static_cast<char>((v >> 8) & 0xFF);
}
inline void put32(std::string& s, uint32_t v) {
  put16(s, v & 0xFFFF);
  put16(s, v >> 16);
}

/// A zip of `files` (name, bytes), stored or deflated, as Python's zipfile writes it.
inline void write_zip(const std::string& path, const std::vector<std::pair<std::string, std::string>>& files, bool deflated) {
  std::string zip, dir;
  for (const auto& [name, raw] : files) {
    std::string body = raw;
    if (deflated) {
      z_stream s{};
      deflateInit2(&s, Z_DEFAULT_COMPRESSION, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY);
      body.resize(deflateBound(&s, raw.size()));
      s.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(raw.data()));
      s.avail_in = static_cast<uInt>(raw.size());
      s.next_out = reinterpret_cast<Bytef*>(body.data());
      s.avail_out = static_cast<uInt>(body.size());
      ::deflate(&s, Z_FINISH);
      body.resize(s.total_out);
      deflateEnd(&s);
    }
    const uint32_t crc = static_cast<uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(raw.data()), raw.size()));
    const uint32_t at = static_cast<uint32_t>(zip.size());
    auto common = [&](std::string& h) {
      put16(h, 20);  // version needed
      put16(h, 0);   // flags
      put16(h, deflated ? 8 : 0);
      put16(h, 0);  // time
      put16(h, 0);  // date
      put32(h, crc);
      put32(h, static_cast<uint32_t>(body.size()));
      put32(h, static_cast<uint32_t>(raw.size()));
      put16(h, static_cast<uint32_t>(name.size()));
      put16(h, 0);  // extra
    };
    put32(zip, 0x04034b50);
    common(zip);
    zip += name + body;
    put32(dir, 0x02014b50);
    put16(dir, 20);  // version made by
    common(dir);
    put16(dir, 0);  // comment
    put16(dir, 0);  // disk
    put16(dir, 0);  // internal attributes
    put32(dir, 0);  // external attributes
    put32(dir, at);
    dir += name;
  }
  const uint32_t dir_at = static_cast<uint32_t>(zip.size());
  zip += dir;
  put32(zip, 0x06054b50);
  put16(zip, 0);
  put16(zip, 0);
  put16(zip, static_cast<uint32_t>(files.size()));
  put16(zip, static_cast<uint32_t>(files.size()));
  put32(zip, static_cast<uint32_t>(dir.size()));
  put32(zip, dir_at);
  put16(zip, 0);
  std::ofstream(path, std::ios::binary) << zip;
}

inline std::string bytes_of(const void* p, size_t n) { return std::string(static_cast<const char*>(p), n); }

}  // namespace npz_writer
