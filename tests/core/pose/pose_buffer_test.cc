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

// A pose added after a gap (PoseBuffer, after_gap): no time strictly inside
// the gap is interpolated, its two ends are; a hinted walk goes through it
// and carries on after it; without the mark the buffer answers as before.
TEST(PoseBufferTest, RefusesLookupsInsideAGap) {
  PoseBuffer b, plain;
  for (int i = 0; i <= 100; ++i) {
    const double t = i <= 50 ? i * 0.01 : 10.0 + i * 0.01;  // a hole (0.5, 10.51)
    const Rigid3d pose = Rigid3d::FromPose(t * 0.1, 0, 0, 0, 0, t * 0.01);
    b.Add(TimeFromSeconds(t), pose, /*after_gap=*/i == 51);
    plain.Add(TimeFromSeconds(t), pose);
  }
  EXPECT_EQ(b.gap_count(), 1u);
  EXPECT_EQ(plain.gap_count(), 0u);
  EXPECT_TRUE(b.AfterGap(51));
  EXPECT_FALSE(b.AfterGap(50));
  Rigid3d p;
  for (double t : {0.5001, 3.0, 10.0, 10.5099}) {
    EXPECT_FALSE(b.Lookup(TimeFromSeconds(t), &p)) << t;
    EXPECT_TRUE(b.InGap(TimeFromSeconds(t))) << t;
    EXPECT_TRUE(plain.Lookup(TimeFromSeconds(t), &p)) << t;
    size_t hint = 0, i = 0;
    double s = 0.0;
    EXPECT_FALSE(b.FindInterval(TimeFromSeconds(t), &hint, &i, &s));
  }
  for (double t : {0.0, 0.25, 0.5, 10.51, 10.6, 11.0}) {
    EXPECT_TRUE(b.Lookup(TimeFromSeconds(t), &p)) << t;
    EXPECT_FALSE(b.InGap(TimeFromSeconds(t))) << t;
    Rigid3d q;
    ASSERT_TRUE(plain.Lookup(TimeFromSeconds(t), &q));
    EXPECT_EQ(p.translation(), q.translation()) << t;
  }
  // Time-ordered queries through the gap: refused inside, answered after.
  size_t hint = 0;
  int refused = 0, answered = 0;
  for (int k = 0; k < 1200; ++k) {
    const double t = k * 0.01 + 0.0005;
    if (b.LookupWithHint(TimeFromSeconds(t), &hint, &p)) {
      ++answered;
      EXPECT_FALSE(t > 0.5 && t < 10.51) << t;
    } else {
      ++refused;
      EXPECT_TRUE((t > 0.5 && t < 10.51) || t > 11.0) << t;
    }
  }
  EXPECT_EQ(answered, 50 + 49);
  EXPECT_EQ(refused, 1200 - answered);
}

}  // namespace
}  // namespace sweepscan
