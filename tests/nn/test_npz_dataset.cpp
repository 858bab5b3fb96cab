// A dataset a user writes from NumPy (numpy.savez / savez_compressed): the test writes the
// .npz itself (a zip of .npy files, stored or deflated) and reads it back.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <future>
#include <zlib.h>

#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "sw/common/errors.h"
#include "sw/nn/dataset.h"
#include "sw/nn/npy.h"
#include "tests/npz_writer.h"

using namespace xbarsim;

using namespace npz_writer;

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

// Issue 38, item 10: only the arrays a split uses are read, and only from a regular file.
TEST(NpzDataset, UnusedEntriesAreNotRead) {
  const std::string p = ::testing::TempDir() + "xbarsim_unused.npz";
  const std::vector<uint8_t> px(2 * 3 * 2 * 2, 7);
  const std::vector<int64_t> labels = {1, 2};
  // An array of strings (dtype <U5) and an entry whose deflated data is garbage: read, either
  // made the whole file refused before.
  std::string strings = npy("<U5", "(2,)", std::string(40, 'a'));
  for (bool deflated : {false, true}) {
    write_zip(p,
              {{"images.npy", npy("|u1", "(2, 3, 2, 2)", bytes_of(px.data(), px.size()))},
               {"labels.npy", npy("<i8", "(2,)", bytes_of(labels.data(), 16))},
               {"names.npy", strings}},
              deflated);
    const Dataset d = load_npz_dataset(p, "test", 0, -1, nullptr);
    EXPECT_EQ(d.count(), 2);
    EXPECT_EQ(d.labels, (std::vector<int>{1, 2}));
  }
  // A deflated entry that does not inflate, unused: not inflated at all.
  write_zip(p,
            {{"images.npy", npy("|u1", "(2, 3, 2, 2)", bytes_of(px.data(), px.size()))},
             {"labels.npy", npy("<i8", "(2,)", bytes_of(labels.data(), 16))}},
            true);
  std::string zip;
  {
    std::ifstream in(p, std::ios::binary);
    zip.assign(std::istreambuf_iterator<char>(in), {});
  }
  // Corrupt the bytes of the labels' deflated data: the test split needs them (an error), a
  // calibration split with calib_images of its own does not.
  write_zip(p,
            {{"images.npy", npy("|u1", "(2, 3, 2, 2)", bytes_of(px.data(), px.size()))},
             {"calib_images.npy", npy("|u1", "(2, 3, 2, 2)", bytes_of(px.data(), px.size()))},
             {"labels.npy", npy("<i8", "(2,)", bytes_of(labels.data(), 16))}},
            true);
  {
    std::ifstream in(p, std::ios::binary);
    zip.assign(std::istreambuf_iterator<char>(in), {});
  }
  const size_t lab = zip.find("labels.npy");  // the local header's name; its data follows
  ASSERT_NE(lab, std::string::npos);
  for (size_t k = lab + 10; k < lab + 30; ++k) zip[k] = static_cast<char>(0xff);
  std::ofstream(p, std::ios::binary) << zip;
  EXPECT_THROW(load_npz_dataset(p, "test", 0, -1, nullptr), InputError);
  std::string note;
  EXPECT_EQ(load_npz_dataset(p, "calib", 0, -1, &note).count(), 2);
}

TEST(NpzDataset, OnlyRegularFiles) {
  const std::string dir = ::testing::TempDir() + "xbarsim_npz_special";
  std::system(("rm -rf '" + dir + "' && mkdir -p '" + dir + "'").c_str());
  // A link to /dev/zero read until memory ran out; now refused at once, naming the file.
  const std::string zero = dir + "/zero.npz";
  ASSERT_EQ(symlink("/dev/zero", zero.c_str()), 0);
  try {
    load_npz_dataset(zero, "test", 0, -1, nullptr);
    ADD_FAILURE() << "a link to /dev/zero was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("zero.npz' is not a regular file (a device)"), std::string::npos) << e.what();
  }
  // A FIFO blocked for ever in open(); if it still does, the test opens the writing end itself
  // after 10 s to unblock it (and fails).
  const std::string fifo = dir + "/x.npz";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0644), 0);
  auto done = std::async(std::launch::async, [&] {
    try {
      load_npz_dataset(fifo, "test", 0, -1, nullptr);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  });
  if (done.wait_for(std::chrono::seconds(10)) != std::future_status::ready) {
    ADD_FAILURE() << "reading a FIFO blocked";
    const int fd = open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    if (fd >= 0) close(fd);
  }
  EXPECT_NE(done.get().find("x.npz' is not a regular file (a FIFO)"), std::string::npos);
  std::system(("rm -rf '" + dir + "'").c_str());
}
