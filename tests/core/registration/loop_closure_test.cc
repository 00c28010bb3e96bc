// Loop closure on the office floor: a drive from room A along the corridor
// to room C's door and back into room A (resources/scenarios/building_loop.json's
// path), reconstructed from the wheels alone (metres of drift) and from the
// EKF (millimetres), closed by registering the room seen at the end to the
// room seen at the start. Truth: the simulated world's trajectory and scene.
#include "core/registration/loop_closure.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "core/cloud/reconstruct.h"
#include "core/sim/truth_eval.h"
#include "core/sim/world.h"
#include "tests/testing/worlds.h"

namespace sweepscan {
namespace {

sim::SimConfig LoopConfig() {
  sim::SimConfig c = testing::BuildingConfig('a', 14);
  c.name = "building_loop";
  const double turn = 2 * M_PI / 0.3, quarter = 0.5 * M_PI / 0.3, half = M_PI / 0.3;
  c.path = {{0.0, 0.0, 1.0},  {0.0, 0.3, turn},     {0.2, 0.0, 20.0}, {0.0, 0.3, quarter}, {0.2, 0.0, 50.0},
            {0.0, 0.3, half}, {0.2, 0.0, 50.0}, {0.0, -0.3, quarter}, {0.2, 0.0, 20.0}, {0.0, 0.3, turn}};
  return c;
}

struct EndError {
  double position_m, heading_deg;
};

EndError ErrorAtEnd(const PoseBuffer& poses, const PoseBuffer& truth) {
  const Time t = poses.latest();
  Rigid3d truth_pose;
  EXPECT_TRUE(truth.Lookup(t, &truth_pose));
  const Rigid3d d = truth_pose.inverse() * poses.pose(poses.size() - 1);
  return {d.translation().head<2>().norm(), Eigen::AngleAxisd(d.rotation()).angle() * 180.0 / M_PI};
}

class LoopClosureTest : public ::testing::TestWithParam<PoseSource> {};

TEST_P(LoopClosureTest, TheRoomSeenAgainRemovesTheLoopsDrift) {
  const sim::SimConfig config = LoopConfig();
  sim::SimWorld world(config);
  const SensorLog log = world.RunAll();
  const PoseBuffer truth = world.TruthPoses(1000.0);
  ReconstructionOptions options;
  options.pose.source = GetParam();
  options.pose.initial_pose = config.start;
  ReconstructionResult before;
  ASSERT_TRUE(Reconstruct(log, config.geometry, options, &truth, &before).ok());

  LoopClosure loop;
  LoopClosureOptions lo;
  if (GetParam() == PoseSource::kOdometry) lo.max_drift_fraction = 0.5;
  const Status s = FindLoop(before.points, before.poses, lo, &loop);
  ASSERT_TRUE(s.ok()) << s.message();
  ASSERT_TRUE(loop.found);
  // The windows are the two turns in place in room A: about 21 s each.
  EXPECT_NEAR(ToSeconds(loop.early_end - loop.early_begin), 22.0, 3.0);
  EXPECT_NEAR(ToSeconds(loop.late_end - loop.late_begin), 21.0, 3.0);

  const PoseBuffer corrected = CorrectPoses(before.poses, loop);
  options.pose.source = PoseSource::kSfm;  // given poses
  ReconstructionResult after;
  ASSERT_TRUE(Reconstruct(log, config.geometry, options, &corrected, &after).ok());

  const EndError e0 = ErrorAtEnd(before.poses, truth), e1 = ErrorAtEnd(corrected, truth);
  const sim::SurfaceErrorStats s0 = sim::SurfaceErrors(config.scene, before.points);
  const sim::SurfaceErrorStats s1 = sim::SurfaceErrors(config.scene, after.points);
  std::printf("%s: end %.1f mm %.3f deg -> %.1f mm %.3f deg; surfaces rms %.1f -> %.1f mm (%s, %zu / %zu points)\n",
              PoseSourceName(GetParam()), e0.position_m * 1000, e0.heading_deg, e1.position_m * 1000,
              e1.heading_deg, s0.rms * 1000, s1.rms * 1000, loop.method.c_str(), loop.early_points,
              loop.late_points);
  if (GetParam() == PoseSource::kOdometry) {
    // Wheels alone drift by decimetres to metres over the 200 s loop; the
    // loop's end comes back to within a few centimetres of the truth and the
    // cloud's surfaces close in.
    EXPECT_GT(e0.position_m, 0.2);
    EXPECT_LT(e1.position_m, 0.05);
    EXPECT_LT(e1.heading_deg, 0.5);
    EXPECT_LT(s1.rms, 0.5 * s0.rms);
  } else {
    // The EKF is already within millimetres (the HI219's heading does not
    // drift): closing the loop must not make it worse.
    EXPECT_LT(e1.position_m, std::max(0.01, 1.5 * e0.position_m));
    EXPECT_LT(s1.rms, 1.1 * s0.rms + 0.0005);
  }
}

// Drive a ends in room B, not in room A where it started: room B registers
// to room A 5.1 m away (they look alike), which no drift of the EKF
// explains: refused, not applied.
TEST(LoopClosureRefusalTest, ADriveEndingInAnotherRoomIsRefused) {
  const ReconstructionResult r =
      testing::SimulateAndReconstruct(testing::BuildingConfig('a'), PoseSource::kEkf, /*deskew=*/true);
  LoopClosure loop;
  const Status s = FindLoop(r.points, r.poses, LoopClosureOptions(), &loop);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("does not end in the room it started in"), std::string::npos) << s.message();
  // And a drive that never leaves (building_c's first second) has no loop.
  LoopClosure none;
  PoseBuffer still;
  still.Add(r.poses.time(0), r.poses.pose(0));
  still.Add(r.poses.time(1), r.poses.pose(0));
  ASSERT_TRUE(FindLoop(r.points, still, LoopClosureOptions(), &none).ok());
  EXPECT_FALSE(none.found);
}

INSTANTIATE_TEST_SUITE_P(PoseSources, LoopClosureTest,
                         ::testing::Values(PoseSource::kOdometry, PoseSource::kEkf),
                         [](const ::testing::TestParamInfo<PoseSource>& info) {
                           return std::string(PoseSourceName(info.param));
                         });

}  // namespace
}  // namespace sweepscan
