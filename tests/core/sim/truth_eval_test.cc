#include "core/sim/truth_eval.h"

#include <gtest/gtest.h>

#include <random>

namespace sweepscan::sim {
namespace {

CloudPoint At(double x, double y, double z, int64_t t_ns = 0) {
  CloudPoint p;
  p.x = static_cast<float>(x);
  p.y = static_cast<float>(y);
  p.z = static_cast<float>(z);
  p.time_ns = t_ns;
  return p;
}

// Points sampled on the faces of a room that is 1 % larger in x than the
// scene says: the measurement must report exactly that.
TEST(TruthEvalTest, MeasureRoomOnKnownBox) {
  const Scene scene({Box{"room", {5, 2.5, 1.25}, {10, 5, 2.5}, 0.0, true, 0.0}});
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<CloudPoint> pts;
  for (int i = 0; i < 20000; ++i) {
    const double a = u(rng), b = u(rng);
    pts.push_back(At(-0.05, 5 * a, 2.5 * b));
    pts.push_back(At(10.05, 5 * a, 2.5 * b));
    pts.push_back(At(10 * a, 0, 2.5 * b));
    pts.push_back(At(10 * a, 5, 2.5 * b));
    pts.push_back(At(10 * a, 5 * b, 0));
    pts.push_back(At(10 * a, 5 * b, 2.5));
  }
  const RoomMeasurement m = MeasureRoom(scene, "room", pts);
  ASSERT_TRUE(m.ok) << m.error;
  EXPECT_NEAR(m.measured.x(), 10.1, 1e-5);
  EXPECT_NEAR(m.relative_error.x(), 0.01, 1e-6);
  EXPECT_NEAR(m.measured.y(), 5.0, 1e-5);
  EXPECT_NEAR(m.measured.z(), 2.5, 1e-5);
  EXPECT_FALSE(MeasureRoom(scene, "kitchen", pts).ok);
}

TEST(TruthEvalTest, PassesSplitByTimeGap) {
  const Scene scene({Box{"target", {5, 0.15, 1.2}, {0.6, 0.02, 0.6}, 0.0, false, 0.0}});
  std::vector<CloudPoint> pts;
  for (int i = 0; i < 30; ++i) {
    for (int k = 0; k < 30; ++k) {
      // Pass 1 on the front face; pass 2 the same but 3 cm further out (a ghost).
      pts.push_back(At(4.71 + 0.02 * i, 0.16, 0.91 + 0.02 * k, 1'000'000'000LL + i * 1000));
      pts.push_back(At(4.71 + 0.02 * i, 0.19, 0.91 + 0.02 * k, 9'000'000'000LL + i * 1000));
    }
  }
  const PassDisagreement d = MeasureTargetPasses(scene, "target", pts);
  ASSERT_TRUE(d.ok) << d.error;
  EXPECT_EQ(d.passes, 2u);
  EXPECT_NEAR(d.plane_offset_m, 0.03, 1e-5);
  EXPECT_NEAR(d.plane_angle_rad, 0.0, 1e-6);
}

TEST(TruthEvalTest, SurfaceErrors) {
  const Scene scene({Box{"room", {0, 0, 1}, {4, 4, 2}, 0.0, true, 0.0}});
  const SurfaceErrorStats s = SurfaceErrors(scene, {At(0, 0, 0.01), At(0, 0, 1.97)});
  EXPECT_NEAR(s.max, 0.03, 1e-6);
  EXPECT_NEAR(s.mean, 0.02, 1e-6);
}

}  // namespace
}  // namespace sweepscan::sim
