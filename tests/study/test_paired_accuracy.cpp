// The paired software-vs-crossbar comparison of eval, against hand-computed counts and the
// Agresti-Min interval worked out by hand.
#include <gtest/gtest.h>

#include <cmath>

#include "sw/study/eval_study.h"

using namespace xbarsim;

TEST(PairedAccuracy, CountsOnlyTheDiscordantImages) {
  //                       image: 0  1  2  3  4  5
  const std::vector<char> sw = {1, 1, 0, 0, 1, 1};
  const std::vector<char> xb = {1, 0, 1, 0, 0, 1};
  const PairedAccuracy p = paired_accuracy(sw, xb);
  EXPECT_EQ(p.images, 6);
  EXPECT_EQ(p.only_software, 2);  // images 1 and 4
  EXPECT_EQ(p.only_crossbar, 1);  // image 2
  EXPECT_DOUBLE_EQ(p.drop(), 1.0 / 6.0);
  EXPECT_THROW(paired_accuracy(sw, {1, 0}), std::logic_error);
}

TEST(PairedAccuracy, IntervalIsAgrestiMinByHand) {
  // 100 images, 5 only software correct, 1 only crossbar: with 0.5 added to each cell,
  // n = 102, b = 5.5, c = 1.5: d = 4 / 102 = 0.0392157,
  // SE = sqrt(7 - 16 / 102) / 102 = sqrt(6.843137) / 102 = 0.0256466, half width 1.96 SE = 0.0502664.
  PairedAccuracy p;
  p.images = 100;
  p.only_software = 5;
  p.only_crossbar = 1;
  const auto ci = p.drop_ci95();
  EXPECT_NEAR(ci.first, 0.0392157 - 0.0502664, 1e-6);
  EXPECT_NEAR(ci.second, 0.0392157 + 0.0502664, 1e-6);
  EXPECT_DOUBLE_EQ(p.drop(), 0.04);
}

TEST(PairedAccuracy, NoDisagreementStillLeavesAnInterval) {
  // 300 images classified alike: the drop is 0, but 300 images cannot exclude a small one.
  PairedAccuracy p;
  p.images = 300;
  const auto ci = p.drop_ci95();
  EXPECT_NEAR(ci.first, -1.96 * 1.0 / 302, 1e-4);  // SE = sqrt(1 - 0) / 302
  EXPECT_NEAR(ci.second, 1.96 * 1.0 / 302, 1e-4);
  EXPECT_GT(ci.second, 0.006);
  EXPECT_LT(ci.second, 0.007);
  // More images narrow it.
  p.images = 10000;
  EXPECT_LT(p.drop_ci95().second, 2e-4);
}
