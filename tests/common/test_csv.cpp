#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "sw/common/csv.h"
#include "sw/common/errors.h"

using namespace xbarsim;

namespace {
std::string write_tmp(const std::string& text) {
  char name[] = "/tmp/xbarsim_csv_XXXXXX";
  const int fd = mkstemp(name);
  EXPECT_GE(fd, 0);
  FILE* f = fdopen(fd, "w");
  fputs(text.c_str(), f);
  fclose(f);
  return name;
}
}  // namespace

TEST(Csv, ReadsRectangularTable) {
  const auto p = write_tmp("# comment\n1, 2.5,3e-3\n\n4,5,6\r\n");
  const auto m = read_csv_matrix(p);
  ASSERT_EQ(m.rows(), 2);
  ASSERT_EQ(m.cols(), 3);
  EXPECT_DOUBLE_EQ(m(0, 2), 3e-3);
  EXPECT_DOUBLE_EQ(m(1, 0), 4);
  std::remove(p.c_str());
}

TEST(Csv, RejectsBadCellsWithPosition) {
  const auto p = write_tmp("1,2\n3,x\n");
  try {
    read_csv_matrix(p);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(":2: column 2"), std::string::npos) << e.what();
  }
  std::remove(p.c_str());
}

TEST(Csv, RejectsRaggedEmptyAndMissing) {
  const auto a = write_tmp("1,2\n3\n");
  EXPECT_THROW(read_csv_matrix(a), InputError);
  const auto b = write_tmp("\n# only comments\n");
  EXPECT_THROW(read_csv_matrix(b), InputError);
  EXPECT_THROW(read_csv_matrix("/nonexistent.csv"), InputError);
  const auto c = write_tmp("1,,2\n");
  EXPECT_THROW(read_csv_matrix(c), InputError);
  const auto d = write_tmp("1,nan\n");
  EXPECT_THROW(read_csv_matrix(d), InputError);
  for (auto& p : {a, b, c, d}) std::remove(p.c_str());
}

TEST(Csv, RoundTripIsExact) {
  Eigen::MatrixXd m(2, 2);
  m << 1.0 / 3.0, -2e-7, 6.02214076e23, 0.1;
  const std::string p = "/tmp/xbarsim_csv_roundtrip.csv";
  write_csv_matrix(p, m);
  EXPECT_EQ(read_csv_matrix(p), m);
  std::remove(p.c_str());
}
