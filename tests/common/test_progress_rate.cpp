// The progress bar's rate and ETA (sw/common/progress_rate.h) on runs computed by hand.
#include <gtest/gtest.h>

#include "sw/common/progress_rate.h"

namespace xbarsim {
namespace {

// 60 s of programming before the first image, then 1 image per second, 100 images: at t = 70 s
// 10 images are done (the first at 61 s) and 90 are left, 90 s at 1 image/s. Counting from when
// the bar was made (10 images in 70 s) would say 630 s: 7x too long (issue 39, item 7).
TEST(RateMeter, SetupBeforeTheFirstItemIsNotCounted) {
  RateMeter m;
  for (int k = 1; k <= 10; ++k) m.observe(60.0 + k, k);
  EXPECT_DOUBLE_EQ(m.rate(), 1.0);
  EXPECT_DOUBLE_EQ(m.eta_s(100), 90.0);
}

// 400 of 1000 images reused from a journal at once, then 4 images per second: after 10 s
// 440 are done, 560 left: 140 s.
TEST(RateMeter, ItemsDoneBeforeTheFirstObservationAreNotARate) {
  RateMeter m;
  m.observe(5.0, 400);
  EXPECT_EQ(m.rate(), 0.0);  // nothing measured yet: no ETA
  EXPECT_LT(m.eta_s(1000), 0.0);
  m.observe(15.0, 440);
  EXPECT_DOUBLE_EQ(m.rate(), 4.0);
  EXPECT_DOUBLE_EQ(m.eta_s(1000), 140.0);
}

}  // namespace
}  // namespace xbarsim
