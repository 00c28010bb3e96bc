#include "core/sim/truth_eval.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

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

// Streamed in pieces, the measurements are those of the whole cloud; p95
// is the exact order statistic (nth_element, computed here) to half a
// bin, whether it falls in the micrometre bins or the millimetre ones.
TEST(TruthEvalTest, AccumulatedInPiecesIsTheWholeClouds) {
  const Scene scene({Box{"room", {5, 2.5, 1.25}, {10, 5, 2.5}, 0.0, true, 0.0},
                     Box{"target", {5, 0.15, 1.2}, {0.6, 0.02, 0.6}, 0.0, false, 0.0}});
  for (const double spread : {0.004, 1.5}) {  // p95 below 1 m, then above
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0, 1);
    std::normal_distribution<double> noise(0, spread);
    std::vector<CloudPoint> pts;
    for (int i = 0; i < 30000; ++i) {
      const double a = u(rng), b = u(rng);
      // 1 ms apart, and 10 s between two halves: the target's two passes,
      // the second 3 cm off the board.
      const bool second = i >= 15000;
      const int64_t t = i * 1'000'000LL + (second ? 10'000'000'000LL : 0);
      pts.push_back(At(10 * a, 0.0 + noise(rng) * 0.01, 2.5 * b, t));
      pts.push_back(At(10 * a, 5 * b, 0.0 + noise(rng), t));
      pts.push_back(At(10.0 + noise(rng) * 0.01, 5 * a, 2.5 * b, t));
      if (i % 10 == 0) pts.push_back(At(4.75 + 0.5 * a, second ? 0.19 : 0.16, 0.95 + 0.5 * b, t));
    }
    SurfaceErrorAccumulator surface(scene);
    RoomAccumulator room(scene, "room");
    TargetPassAccumulator target(scene, "target");
    for (size_t i = 0; i < pts.size(); i += 4099) {
      const size_t n = std::min<size_t>(4099, pts.size() - i);
      surface.Add(pts.data() + i, n);
      room.Add(pts.data() + i, n);
      target.Add(pts.data() + i, n);
    }
    const SurfaceErrorStats s = surface.Stats(), whole = SurfaceErrors(scene, pts);
    EXPECT_EQ(s.count, pts.size());
    EXPECT_EQ(s.mean, whole.mean);
    EXPECT_EQ(s.rms, whole.rms);
    EXPECT_EQ(s.p95, whole.p95);
    std::vector<double> d;
    for (const CloudPoint& p : pts) d.push_back(scene.DistanceToSurface({p.x, p.y, p.z}));
    const size_t k = static_cast<size_t>(0.95 * static_cast<double>(d.size() - 1));
    std::nth_element(d.begin(), d.begin() + k, d.end());
    EXPECT_NEAR(s.p95, d[k], d[k] < 1.0 ? 0.5e-6 : 0.5e-3) << spread;
    EXPECT_EQ(s.max, *std::max_element(d.begin(), d.end()));

    const RoomMeasurement r = room.Result(), rw = MeasureRoom(scene, "room", pts);
    EXPECT_EQ(r.ok, rw.ok);
    EXPECT_EQ(r.error, rw.error);
    for (int f = 0; f < 6 && r.ok; ++f) EXPECT_EQ(r.faces[f].count, rw.faces[f].count);
    const PassDisagreement p = target.Result(), pw = MeasureTargetPasses(scene, "target", pts);
    ASSERT_TRUE(p.ok) << p.error;
    EXPECT_EQ(p.passes, pw.passes);
    EXPECT_EQ(p.plane_offset_m, pw.plane_offset_m);
    if (spread < 1) {
      EXPECT_NEAR(p.plane_offset_m, 0.03, 1e-3);
    }
  }
}

}  // namespace
}  // namespace sweepscan::sim
