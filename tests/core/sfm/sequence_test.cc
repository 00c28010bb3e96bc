// The sequence pipeline (Choi et al. 2017, section 4) on simulated rigs with
// ground truth (core/sim/rig.h): tracking, plane discovery, refinement.
#include "core/sfm/sequence.h"

#include <gtest/gtest.h>

#include <cstdio>

#include "core/sfm/rig_scenario.h"
#include "core/sim/rig.h"

namespace sweepscan::sfm {
namespace {

struct Outcome {
  SequenceResult result;
  SequenceErrors tracked, refined;
};

Outcome RunScenario(const sim::RigSimConfig& config, bool give_planes, const SequenceOptions& options = {}) {
  const sim::RigRun run = sim::SimulateRig(config);
  SequenceInit init;
  std::vector<std::string> chosen;
  Outcome out;
  const Status si = InitFromTruth(run, config.scene, give_planes, options.lines, &init, &chosen);
  EXPECT_TRUE(si.ok()) << si.message();
  if (!si.ok()) return out;
  const Status s = RunSequence(ScansFromRigRun(run), RigFromRigRun(run), init, options, &out.result);
  EXPECT_TRUE(s.ok()) << s.message();
  if (!s.ok()) return out;
  out.tracked = EvaluateSequence(out.result.tracked, out.result.planes, out.result.gauge_first_pose, run, config.scene);
  out.refined = EvaluateSequence(out.result.poses, out.result.planes, out.result.gauge_first_pose, run, config.scene);
  const SequenceResult& r = out.result;
  std::printf("%s (init %s, %s, %s; %s): %zu frames, %d lines (%d assigned), %zu planes (%d match the truth, "
              "%d distinct true planes), p3l frames %d, weak %d\n",
              config.name.c_str(), chosen[0].c_str(), chosen[1].c_str(), chosen[2].c_str(),
              give_planes ? "planes given" : "first-pose gauge", r.poses.size(), r.lines_total, r.lines_assigned,
              r.planes.size(), out.refined.planes_matched, out.refined.truth_planes_found, r.frames_p3l, r.frames_weak);
  std::printf("  tracked: rot %.3f deg mean (%.3f max), trans %.4f m mean (%.4f max); tracking %.2f s\n",
              out.tracked.rot_mean_deg, out.tracked.rot_max_deg, out.tracked.trans_mean_m, out.tracked.trans_max_m,
              r.tracking_seconds);
  std::printf("  refined: rot %.3f deg mean (%.3f max), trans %.4f m mean (%.4f max); planes %.3f deg, %.4f m; "
              "refinement %.2f s, %d passes, %d iterations, %d lines\n",
              out.refined.rot_mean_deg, out.refined.rot_max_deg, out.refined.trans_mean_m, out.refined.trans_max_m,
              out.refined.plane_angle_mean_deg, out.refined.plane_offset_mean_m, r.refine.seconds, r.refine.passes,
              r.refine.iterations, r.refine.residual_blocks);
  std::printf("  planes found:");
  for (const std::string& l : out.refined.matched_labels) std::printf(" %s", l.c_str());
  std::printf("\n");
  return out;
}

// The small room: 650 frames of the two-lidar rig (1300 scans),
// the three initial planes given. After refinement the mean rotation error
// is at most 0.5 deg and the mean translation error at most 2 cm; every
// plane found is a true one (within 2 deg and 5 cm), and the room's six
// faces and the furniture fronts the lidars see are found.
TEST(SequenceTest, SmallRoomPlanesGiven) {
  const Outcome o = RunScenario(sim::SmallRoomRigScenario(), true);
  const SequenceResult& r = o.result;
  ASSERT_EQ(r.poses.size(), 650u);
  EXPECT_LE(o.refined.rot_mean_deg, 0.5);
  EXPECT_LE(o.refined.trans_mean_m, 0.02);
  EXPECT_LE(o.refined.rot_max_deg, 2.0);
  EXPECT_LE(o.refined.trans_max_m, 0.05);
  // Refinement does not make things worse than tracking.
  EXPECT_LE(o.refined.trans_mean_m, o.tracked.trans_mean_m + 1e-4);
  EXPECT_EQ(o.refined.planes_matched, static_cast<int>(r.planes.size()));
  EXPECT_EQ(o.refined.truth_planes_found, static_cast<int>(r.planes.size()));  // no duplicates
  EXPECT_GE(o.refined.truth_planes_found, 8);
  EXPECT_LT(o.refined.plane_offset_mean_m, 0.01);
  EXPECT_GT(r.lines_assigned, 0.9 * r.lines_total);
  // The three initial planes stay as given (the gauge).
  for (int j = 0; j < 3; ++j) EXPECT_TRUE(r.planes[j].initial);
}

// The same walk with no plane given: the three planes are fitted from two
// lines each in the first frame, the world is the first rig frame (the
// first pose is the gauge); errors after carrying the estimate into the
// truth's world by the true first pose.
TEST(SequenceTest, SmallRoomFirstPoseGauge) {
  // Four lidars (the default pair, and the pair tilted the other way), so
  // that the first frame sees each wall with two non-parallel lines (a
  // plane needs two to be fitted).
  sim::RigSimConfig config = sim::SmallRoomRigScenario();
  for (const sim::RigLidarSpec& l : sim::DefaultHandheldRig(-20.0)) config.lidars.push_back(l);
  const Outcome o = RunScenario(config, false);
  const SequenceResult& r = o.result;
  ASSERT_EQ(r.poses.size(), 650u);
  EXPECT_TRUE(r.gauge_first_pose);
  EXPECT_NEAR((r.poses[0].translation()).norm(), 0.0, 1e-12);
  EXPECT_LE(o.refined.rot_mean_deg, 0.5);
  EXPECT_LE(o.refined.trans_mean_m, 0.02);
  EXPECT_EQ(o.refined.planes_matched, static_cast<int>(r.planes.size()));
  EXPECT_GE(o.refined.truth_planes_found, 8);
}

// The stairwell walk of the issue: 1750 frames of two lidars, 3500 scans,
// up and down the flight twice. Treads and risers are parallel planes 17
// and 28 cm apart: association must tell them apart.
TEST(SequenceTest, Stairwell) {
  const Outcome o = RunScenario(sim::StairwellRigScenario(), true);
  const SequenceResult& r = o.result;
  ASSERT_EQ(r.poses.size(), 1750u);
  EXPECT_LE(o.refined.rot_mean_deg, 0.5);
  EXPECT_LE(o.refined.trans_mean_m, 0.02);
  EXPECT_GE(o.refined.planes_matched, static_cast<int>(0.9 * r.planes.size()));
  // The walls, ceiling, floor, landing and handrail; the 17 cm risers and
  // 28 cm treads give lines shorter than 0.5 m, or none (the lidars face up).
  EXPECT_GE(o.refined.truth_planes_found, 7);
}

// Eq. 38-39 on a hand-made line: a 1 m line along x at height 0.03 m above
// the floor z = 0 (n = (0, 0, -1), d = 0), tilted by 1 deg.
TEST(SequenceTest, AssociationGates) {
  LineObs l;
  l.centroid = {0.0, 0.0, 0.03};
  l.direction = Eigen::Vector3d(std::cos(M_PI / 180), 0.0, std::sin(M_PI / 180));
  l.half_length = 0.5;
  WorldPlane floor;
  floor.normal = {0, 0, -1};
  floor.d = 0.0;
  double dist, sin_angle;
  LinePlaneDistance(l, Rigid3d::Identity(), floor, &dist, &sin_angle);
  EXPECT_NEAR(dist, 0.03 + 0.5 * std::sin(M_PI / 180), 1e-12);
  EXPECT_NEAR(sin_angle, std::sin(M_PI / 180), 1e-12);
  // Lifting the rig by 0.1 m moves the line off the plane.
  LinePlaneDistance(l, Rigid3d::Translation({0, 0, 0.1}), floor, &dist, &sin_angle);
  EXPECT_NEAR(dist, 0.13 + 0.5 * std::sin(M_PI / 180), 1e-12);
}

// UpdatePose: lines on three perpendicular planes from a perturbed start
// converge to the true pose; with lines on two planes only, the translation
// along their common direction stays at the start (rank-deficient, eigenvalue 0).
TEST(SequenceTest, UpdatePoseFromLines) {
  const Rigid3d truth = Rigid3d::FromPose(1.0, 0.5, 1.2, 0.1, -0.05, 0.7);
  std::vector<WorldPlane> planes(3);
  planes[0].normal = {1, 0, 0};  planes[0].d = -3.0;   // wall x = 3
  planes[1].normal = {0, 1, 0};  planes[1].d = -2.5;   // wall y = 2.5
  planes[2].normal = {0, 0, 1};  planes[2].d = -2.6;   // ceiling z = 2.6
  std::vector<LineObs> lines;
  const Eigen::Vector3d dirs[3][2] = {{{0, 1, 0.3}, {0, -0.4, 1}}, {{1, 0, 0.5}, {0.2, 0, 1}}, {{1, 0.3, 0}, {-0.2, 1, 0}}};
  const Eigen::Vector3d points[3] = {{3, 0.5, 1.5}, {1.5, 2.5, 1.0}, {1.0, 1.0, 2.6}};
  for (int j = 0; j < 3; ++j) {
    for (int k = 0; k < 2; ++k) {
      LineObs l;
      l.plane = j;
      l.centroid = truth.inverse() * points[j];
      l.direction = truth.rotation().inverse() * dirs[j][k].normalized();
      l.sigma = 0.3;
      l.half_length = 0.5;
      l.count = 50;
      lines.push_back(l);
    }
  }
  std::vector<const LineObs*> all;
  for (const LineObs& l : lines) all.push_back(&l);
  Rigid3d pose = Rigid3d::FromPose(1.05, 0.45, 1.23, 0.12, -0.03, 0.72);
  SequenceOptions o;
  o.pose_iterations = 10;
  const double lambda = UpdatePose(all, planes, o, &pose);
  EXPECT_GT(lambda, 1e-3);
  EXPECT_NEAR((pose.translation() - truth.translation()).norm(), 0.0, 1e-9);
  EXPECT_NEAR(RotationAngle(pose.rotation().toRotationMatrix(), truth.rotation().toRotationMatrix()), 0.0, 1e-9);
  // Two planes (walls): z is not observed.
  std::vector<const LineObs*> walls(all.begin(), all.begin() + 4);
  Rigid3d start = Rigid3d::FromPose(1.05, 0.45, 1.5, 0.1, -0.05, 0.7);
  EXPECT_LT(UpdatePose(walls, planes, o, &start), 1e-6);
  EXPECT_NEAR(start.translation().z(), 1.5, 1e-3);
}

TEST(SequenceTest, InitIsChecked) {
  const sim::RigSimConfig config = sim::SmallRoomRigScenario(5);
  const sim::RigRun run = sim::SimulateRig(config);
  SequenceInit init;
  ASSERT_TRUE(InitFromTruth(run, config.scene, true, {}, &init, nullptr).ok());
  SequenceResult r;
  SequenceInit mixed = init;
  mixed.planes[1].known = false;
  EXPECT_FALSE(RunSequence(ScansFromRigRun(run), RigFromRigRun(run), mixed, {}, &r).ok());
  SequenceInit bad = init;
  bad.planes[0].lines[0].line = 99;
  const Status s = RunSequence(ScansFromRigRun(run), RigFromRigRun(run), bad, {}, &r);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("no line 99"), std::string::npos) << s.message();
  SequenceInit parallel = init;
  parallel.planes[1] = parallel.planes[0];
  EXPECT_FALSE(RunSequence(ScansFromRigRun(run), RigFromRigRun(run), parallel, {}, &r).ok());
  EXPECT_TRUE(RunSequence(ScansFromRigRun(run), RigFromRigRun(run), init, {}, &r).ok());
}

}  // namespace
}  // namespace sweepscan::sfm
