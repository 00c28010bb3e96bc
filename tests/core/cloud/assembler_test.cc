#include "core/cloud/assembler.h"

#include <gtest/gtest.h>

#include "core/sim/truth_eval.h"
#include "core/sim/world.h"
#include "tests/testing/worlds.h"

namespace sweepscan {
namespace {

// The lab drive without any noise at 0.2 m/s (it includes a half turn in
// place, where an un-deskewed scan smears most).
TEST(AssemblerTest, DeskewedNoiseFreePointsLieOnTheSurfaces) {
  sim::SimConfig c = testing::LabConfig();
  testing::MakeNoiseFree(&c);
  for (PoseSource source : {PoseSource::kTruth, PoseSource::kEkf}) {
    const ReconstructionResult r = testing::SimulateAndReconstruct(c, source, /*deskew=*/true);
    const sim::SurfaceErrorStats s = sim::SurfaceErrors(c.scene, r.points);
    std::printf("%s, deskew: max %.3f mm, p95 %.3f mm over %zu points\n", PoseSourceName(source),
                s.max * 1e3, s.p95 * 1e3, s.count);
    EXPECT_GT(s.count, 200000u);
    if (source == PoseSource::kTruth) {
      EXPECT_LT(s.max, 0.002);
    } else {
      // The EKF's constant-velocity model lags a step when a segment starts
      // or stops; a handful of points at those instants land a little off.
      EXPECT_LT(s.p95, 0.0005);
      EXPECT_LT(s.max, 0.010);
    }
  }
}

TEST(AssemblerTest, WithoutDeskewTheErrorIsMuchLarger) {
  sim::SimConfig c = testing::LabConfig();
  testing::MakeNoiseFree(&c);
  const ReconstructionResult with = testing::SimulateAndReconstruct(c, PoseSource::kTruth, true);
  const ReconstructionResult without = testing::SimulateAndReconstruct(c, PoseSource::kTruth, false);
  const sim::SurfaceErrorStats a = sim::SurfaceErrors(c.scene, with.points);
  const sim::SurfaceErrorStats b = sim::SurfaceErrors(c.scene, without.points);
  std::printf("no deskew: max %.1f mm, p95 %.1f mm, mean %.2f mm (deskew: mean %.4f mm)\n",
              b.max * 1e3, b.p95 * 1e3, b.mean * 1e3, a.mean * 1e3);
  // Driving straight, the skew slides points along walls parallel to the
  // travel (no error there) but the half turn smears the end walls.
  EXPECT_LT(a.max, 0.002);
  EXPECT_GT(b.max, 0.05);
  EXPECT_GT(b.mean, 0.0005);
  EXPECT_GT(b.mean, 20 * a.mean);
  for (const CloudPoint& p : without.points) ASSERT_EQ(p.flags & 1, 1);
}

TEST(AssemblerTest, CountsInvalidAndPoseless) {
  PoseBuffer poses;
  poses.Add(TimeFromSeconds(1.0), Rigid3d());
  poses.Add(TimeFromSeconds(2.0), Rigid3d::FromPose(1, 0, 0, 0, 0, 0));
  LidarScan scan;
  scan.index = 7;
  scan.samples = {{TimeFromSeconds(1.5), 2.0f, 0.0f, 0},     // straight up, at x = 0.5 + l1
                  {TimeFromSeconds(1.5), 0.0f, 0.5f, 1},     // no return
                  {TimeFromSeconds(1.5), 20.0f, 0.5f, 2},    // beyond max range
                  {TimeFromSeconds(2.5), 1.0f, 0.5f, 3}};    // after the last pose
  RobotGeometry g;
  Assembler a(AssemblyOptions(), BodyFromLidar(g, {}), PoseSource::kEkf);
  PointChunks out;
  a.AddScan(scan, poses, &out);
  out.Seal();
  const auto pts = out.Flatten();
  ASSERT_EQ(pts.size(), 1u);
  EXPECT_NEAR(pts[0].x, 0.5 + g.lidar_offset_x_m, 1e-6);
  EXPECT_NEAR(pts[0].z, g.lidar_height_m + 2.0, 1e-6);
  EXPECT_EQ(pts[0].scan, 7u);
  EXPECT_EQ(pts[0].beam, 0);
  EXPECT_EQ(a.stats().invalid_range, 2u);
  EXPECT_EQ(a.stats().no_pose, 1u);
}

}  // namespace
}  // namespace sweepscan
