#include "core/pose/pose_buffer.h"

#include <gtest/gtest.h>

namespace sweepscan {
namespace {

TEST(PoseBufferTest, InterpolatesTranslationAndRotation) {
  PoseBuffer b;
  b.Add(TimeFromSeconds(1.0), Rigid3d::FromPose(0, 0, 0, 0, 0, 0));
  b.Add(TimeFromSeconds(2.0), Rigid3d::FromPose(1, 2, 0, 0, 0, 0.2));
  Rigid3d p;
  ASSERT_TRUE(b.Lookup(TimeFromSeconds(1.25), &p));
  EXPECT_NEAR(p.translation().x(), 0.25, 1e-12);
  EXPECT_NEAR(p.translation().y(), 0.5, 1e-12);
  // nlerp lags slerp by O(angle^3): 3e-5 rad at a quarter of 0.2 rad.
  EXPECT_NEAR(YawFromQuaternion(p.rotation()), 0.05, 1e-4);
  ASSERT_TRUE(b.Lookup(TimeFromSeconds(2.0), &p));
  EXPECT_NEAR(p.translation().x(), 1.0, 1e-12);
  EXPECT_FALSE(b.Lookup(TimeFromSeconds(0.99), &p));
  EXPECT_FALSE(b.Lookup(TimeFromSeconds(2.01), &p));
}

TEST(PoseBufferTest, HintedLookupMatchesPlainLookup) {
  PoseBuffer b;
  for (int i = 0; i <= 1000; ++i) {
    b.Add(TimeFromSeconds(i * 0.01), Rigid3d::FromPose(i * 0.002, std::sin(i * 0.01), 0, 0, 0, i * 0.003));
  }
  size_t hint = 0;
  for (int k = 0; k < 5000; ++k) {
    const Time t = TimeFromSeconds(k * 0.002 + 0.0001);
    Rigid3d a, c;
    ASSERT_TRUE(b.LookupWithHint(t, &hint, &a));
    ASSERT_TRUE(b.Lookup(t, &c));
    EXPECT_TRUE(a.translation().isApprox(c.translation(), 1e-12));
  }
  // Going back in time with a stale hint still works.
  Rigid3d a;
  ASSERT_TRUE(b.LookupWithHint(TimeFromSeconds(0.5), &hint, &a));
  EXPECT_NEAR(a.translation().x(), 0.1, 1e-12);
}

TEST(PoseBufferTest, RejectsOutOfOrder) {
  PoseBuffer b;
  EXPECT_TRUE(b.Add(TimeFromSeconds(1), Rigid3d()));
  EXPECT_FALSE(b.Add(TimeFromSeconds(0.5), Rigid3d()));
  EXPECT_EQ(b.size(), 1u);
}

TEST(PoseBufferTest, NlerpCloseToSlerpForFilterSteps) {
  const Rigid3d a = Rigid3d::FromPose(0, 0, 0, 0.01, -0.02, 0.0);
  const Rigid3d b = Rigid3d::FromPose(0, 0, 0, 0.012, -0.018, 0.02);  // > 1 deg apart
  for (double s : {0.1, 0.37, 0.5, 0.9}) {
    const Eigen::Quaterniond n = PoseBuffer::InterpolateNlerp(a, b, s).rotation();
    const Eigen::Quaterniond sl = Interpolate(a, b, s).rotation();
    EXPECT_LT(n.angularDistance(sl), 1e-7);
  }
}

}  // namespace
}  // namespace sweepscan
