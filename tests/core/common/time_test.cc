#include "core/common/time.h"

#include <gtest/gtest.h>

namespace sweepscan {
namespace {

TEST(TimeTest, SecondsRoundTripAtNanosecondResolution) {
  EXPECT_EQ(FromSeconds(1.5).count(), 1'500'000'000);
  EXPECT_EQ(FromSeconds(-0.25).count(), -250'000'000);
  EXPECT_EQ(FromSeconds(1e-9).count(), 1);
  EXPECT_DOUBLE_EQ(ToSeconds(TimeFromSeconds(12.000000001)), 12.000000001);
  // A day of robot time still resolves single nanoseconds.
  const Time t = TimeFromNanoseconds(86'400'000'000'001LL);
  EXPECT_EQ(ToNanoseconds(t), 86'400'000'000'001LL);
  EXPECT_EQ((t - TimeFromNanoseconds(86'400'000'000'000LL)).count(), 1);
}

}  // namespace
}  // namespace sweepscan
