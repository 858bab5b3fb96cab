// A dataset a user writes from NumPy (numpy.savez / savez_compressed): the test writes the
// .npz itself (a zip of .npy files, stored or deflated) and reads it back.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "sw/common/errors.h"
#include "sw/nn/dataset.h"
#include "sw/nn/npy.h"

using namespace xbarsim;

namespace {

/// A .npy file: format 1.0, C order, little-endian.
std::string npy(const std::string& descr, const std::string& shape, const std::string& data) {
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

void put16(std::string& s, uint32_t v) {
  s += static_cast<char>(v & 0xFF);
  s += static_cast<char>((v >> 8) & 0xFF);
}
void put32(std::string& s, uint32_t v) {
  put16(s, v & 0xFFFF);
  put16(s, v >> 16);
}

/// A zip of `files` (name, bytes), stored or deflated, as Python's zipfile writes it.
void write_zip(const std::string& path, const std::vector<std::pair<std::string, std::string>>& files, bool deflated) {
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

std::string bytes_of(const void* p, size_t n) { return std::string(static_cast<const char*>(p), n); }

}  // namespace

TEST(NpzDataset, Uint8AndFloatImagesStoredOrCompressed) {
  const int n = 5, c = 3, h = 4, w = 4, per = c * h * w;
  std::vector<uint8_t> px(static_cast<size_t>(n) * per);
  for (size_t k = 0; k < px.size(); ++k) px[k] = static_cast<uint8_t>((k * 37) % 256);
  std::vector<float> fv(px.size());
  for (size_t k = 0; k < fv.size(); ++k) fv[k] = static_cast<float>(k) * 0.5f - 3.0f;
  const std::vector<int64_t> labels = {3, 1, 4, 1, 5};
  const std::string lab = npy("<i8", "(5,)", bytes_of(labels.data(), labels.size() * 8));
  for (bool deflate : {false, true}) {
    SCOPED_TRACE(deflate ? "savez_compressed" : "savez");
    const std::string p8 = ::testing::TempDir() + "xbarsim_u8.npz", pf = ::testing::TempDir() + "xbarsim_f4.npz";
    write_zip(p8, {{"images.npy", npy("|u1", "(5, 3, 4, 4)", bytes_of(px.data(), px.size()))}, {"labels.npy", lab}},
              deflate);
    write_zip(pf,
              {{"images.npy", npy("<f4", "(5, 3, 4, 4)", bytes_of(fv.data(), fv.size() * 4))},
               {"labels.npy", lab},
               {"calib_images.npy", npy("<f4", "(2, 3, 4, 4)", bytes_of(fv.data(), 2 * per * 4))}},
              deflate);
    ASSERT_TRUE(is_npz_dataset(p8));
    std::string note;
    const Dataset d = load_npz_dataset(p8, "test", 1, 3, &note);
    EXPECT_EQ(d.count(), 3);
    EXPECT_EQ(d.shape, (Shape{c, h, w}));
    EXPECT_EQ(d.labels, (std::vector<int>{1, 4, 1}));
    Preprocessing pre;
    pre.scale = 1.0 / 255;
    pre.mean = {0.1, 0.2, 0.3};
    pre.std = {0.5, 0.25, 2.0};
    std::vector<float> x(per);
    d.preprocess(0, pre, x.data());  // image 1 of the file
    for (int k = 0; k < per; ++k)
      EXPECT_FLOAT_EQ(x[k], static_cast<float>((px[per + k] / 255.0 - pre.mean[k / 16]) / pre.std[k / 16])) << k;
    // No calib_images: calibration on the test images, said.
    const Dataset cal = load_npz_dataset(p8, "calib", 0, 2, &note);
    EXPECT_EQ(cal.count(), 2);
    EXPECT_NE(note.find("no calib_images"), std::string::npos) << note;
    // Float values, and a calibration split of its own.
    const Dataset f = load_npz_dataset(pf, "test", 0, -1, nullptr);
    ASSERT_EQ(f.count(), 5);
    Preprocessing unit;
    unit.scale = 1;
    f.preprocess(4, unit, x.data());
    for (int k = 0; k < per; ++k) EXPECT_FLOAT_EQ(x[k], fv[4 * per + k]) << k;
    note.clear();
    EXPECT_EQ(load_npz_dataset(pf, "calib", 0, -1, &note).count(), 2);
    EXPECT_TRUE(note.empty()) << note;
  }
}

TEST(NpzDataset, BadFilesAreInputErrors) {
  const std::string p = ::testing::TempDir() + "xbarsim_bad.npz";
  const std::vector<float> v(4, 1.0f);
  // No labels; int16 images; Fortran order; a truncated array; not a zip at all.
  write_zip(p, {{"images.npy", npy("<f4", "(1, 2, 2)", bytes_of(v.data(), 16))}}, false);
  EXPECT_THROW(load_npz_dataset(p, "test", 0, -1, nullptr), InputError);
  const std::vector<int64_t> one = {0};
  const std::string lab = npy("<i8", "(1,)", bytes_of(one.data(), 8));
  write_zip(p, {{"images.npy", npy("<i2", "(1, 2, 2)", std::string(8, '\0'))}, {"labels.npy", lab}}, false);
  EXPECT_THROW(load_npz_dataset(p, "test", 0, -1, nullptr), InputError);
  std::string fortran = npy("<f4", "(1, 2, 2)", bytes_of(v.data(), 16));
  fortran.replace(fortran.find("False"), 5, "True ");
  write_zip(p, {{"images.npy", fortran}, {"labels.npy", lab}}, false);
  EXPECT_THROW(load_npz_dataset(p, "test", 0, -1, nullptr), InputError);
  write_zip(p, {{"images.npy", npy("<f4", "(1, 2, 2)", bytes_of(v.data(), 12))}, {"labels.npy", lab}}, false);
  EXPECT_THROW(load_npz_dataset(p, "test", 0, -1, nullptr), InputError);
  std::ofstream(p, std::ios::binary) << "this is not a zip archive at all, just text";
  EXPECT_THROW(load_npz_dataset(p, "test", 0, -1, nullptr), InputError);
}
