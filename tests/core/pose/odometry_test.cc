#include "core/pose/odometry.h"

#include <gtest/gtest.h>

namespace sweepscan {
namespace {

TEST(OdometryTest, StraightLine) {
  WheelOdometry odo(0.15);
  odo.Reset(TimeFromSeconds(0), {1, 2, M_PI / 4});
  for (int i = 1; i <= 500; ++i) odo.Add({TimeFromSeconds(i * 0.02), 0.2, 0.2});
  // 10 s at 0.2 m/s along 45 deg.
  EXPECT_NEAR(odo.pose().x, 1 + 2 * std::cos(M_PI / 4), 1e-9);
  EXPECT_NEAR(odo.pose().y, 2 + 2 * std::sin(M_PI / 4), 1e-9);
  EXPECT_NEAR(odo.pose().yaw, M_PI / 4, 1e-12);
}

TEST(OdometryTest, CircleClosesOnItself) {
  // Radius R = v / w = 0.83 m, one full turn; midpoint integration at 50 Hz.
  const double d = 0.15, v = 0.2, w = v / 0.83;
  double l, r;
  WheelsFromTwist({v, w}, d, &l, &r);
  WheelOdometry odo(d);
  odo.Reset(TimeFromSeconds(0), {0, 0, 0});
  const double period = 2 * M_PI / w;
  const int n = static_cast<int>(std::round(period * 50));
  for (int i = 1; i <= n; ++i) odo.Add({TimeFromSeconds(i * period / n), l, r});
  EXPECT_NEAR(odo.pose().x, 0.0, 1e-6);
  EXPECT_NEAR(odo.pose().y, 0.0, 1e-6);
  EXPECT_NEAR(WrapAngle(odo.pose().yaw), 0.0, 1e-9);
  // Quarter of the way: at (R, R) heading 90 deg.
  WheelOdometry quarter(d);
  quarter.Reset(TimeFromSeconds(0), {0, 0, 0});
  for (int i = 1; i <= n / 4; ++i) quarter.Add({TimeFromSeconds(i * period / n), l, r});
  const double turned = w * (n / 4) * period / n;
  EXPECT_NEAR(quarter.pose().x, 0.83 * std::sin(turned), 1e-6);
  EXPECT_NEAR(quarter.pose().y, 0.83 * (1 - std::cos(turned)), 1e-6);
}

TEST(OdometryTest, MidpointMatchesExactArcClosely) {
  const Pose2d p{0, 0, 0.3};
  const Twist2d t{0.5, 1.0};
  const Pose2d a = IntegrateMidpoint(p, t, 0.02), b = IntegrateExact(p, t, 0.02);
  // Midpoint error is O(w^2 dt^3 v): here about 1e-7 m.
  EXPECT_NEAR(a.x, b.x, 1e-6);
  EXPECT_NEAR(a.y, b.y, 1e-6);
  EXPECT_DOUBLE_EQ(a.yaw, b.yaw);
}

TEST(OdometryTest, IgnoresNonIncreasingTime) {
  WheelOdometry odo(0.15);
  odo.Reset(TimeFromSeconds(1), {});
  odo.Add({TimeFromSeconds(1), 1, 1});
  odo.Add({TimeFromSeconds(0.5), 1, 1});
  EXPECT_EQ(odo.pose().x, 0.0);
}

}  // namespace
}  // namespace sweepscan
