// Lidar-only structure from motion on the wheeled scanner (core/sfm/
// wheeled.h): the vertical X4's scans of the simulated lab, against the
// simulation's ground truth and the EKF. Bounds are a little above what
// seeds 1-3 give (docs/results.md, "Lidar-only SfM: the wheeled scanner").
#include "core/sfm/wheeled.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>

#include "core/scenario/scenario.h"
#include "core/sfm/rig_scenario.h"
#include "hardware/station/recording.h"

namespace sweepscan::sfm {
namespace {

struct Outcome {
  hardware::Recording in;
  WheeledSfmResult sfm;
  WheeledErrors prior, refined;
};

Outcome RunScenario(const std::string& file, uint64_t seed, PoseSource prior_source) {
  Outcome run;
  sim::SimConfig config;
  const Status ls = LoadScenario(std::string(SWEEPSCAN_SOURCE_DIR) + "/resources/scenarios/" + file, &config);
  EXPECT_TRUE(ls.ok()) << ls.message();
  config.seed = seed;
  hardware::SimulateRecording(config, &run.in);
  WheeledSfmOptions options;
  options.motion = WheeledMotionPrior(prior_source);
  const Status s = WheeledSfmFromLog(run.in.log, run.in.geometry, MountingError(), run.in.start, prior_source,
                                     SequenceInit(), options, &run.sfm);
  EXPECT_TRUE(s.ok()) << s.message();
  if (!s.ok()) return run;
  const std::vector<double>& t = run.sfm.sequence.frame_times_s;
  run.prior = EvaluateWheeled(t, run.sfm.prior, run.in.truth_poses);
  run.refined = EvaluateWheeled(t, run.sfm.sequence.poses, run.in.truth_poses);
  std::printf("%s seed %llu, prior %s: %zu scans, %zu planes\n", file.c_str(), static_cast<unsigned long long>(seed),
              PoseSourceName(prior_source), t.size(), run.sfm.sequence.planes.size());
  for (const auto& [name, e] : {std::pair<const char*, const WheeledErrors&>{"prior", run.prior},
                                std::pair<const char*, const WheeledErrors&>{"sfm", run.refined}}) {
    std::printf("  %-5s along %.4f (final %.4f) m, lateral %.4f m, height %.4f m, heading %.3f deg, tilt %.3f deg\n",
                name, e.along_mean_m, e.along_final_m, e.lateral_mean_m, e.height_mean_m, e.heading_mean_deg,
                e.tilt_mean_deg);
  }
  return run;
}

// The lab drive (resources/scenarios/lab.json) recorded through the bytes.
void SimulateLab(hardware::Recording* in) {
  sim::SimConfig config;
  ASSERT_TRUE(LoadScenario(std::string(SWEEPSCAN_SOURCE_DIR) + "/resources/scenarios/lab.json", &config).ok());
  hardware::SimulateRecording(config, in);
}

// The planes found are true faces of the lab (within 2 deg and 5 cm) and
// include the floor, the ceiling and both long walls.
void ExpectTruePlanes(const WheeledSfmResult& r, const sim::Scene& scene) {
  const std::vector<sim::TruthPlane> faces = sim::ScenePlanes(scene);
  int room_faces = 0;
  for (const FoundPlane& fp : r.sequence.planes) {
    bool matched = false;
    for (const sim::TruthPlane& f : faces) {
      for (double sign : {1.0, -1.0}) {
        if (sign * fp.plane.normal.dot(f.normal) > std::cos(2.0 * M_PI / 180.0) &&
            std::abs(sign * fp.plane.d - f.d) < 0.05) {
          matched = true;
          if (f.label == "room/-z" || f.label == "room/+z" || f.label == "room/-y" || f.label == "room/+y") {
            ++room_faces;
          }
        }
      }
    }
    EXPECT_TRUE(matched) << "plane n = " << fp.plane.normal.transpose() << ", d = " << fp.plane.d;
  }
  EXPECT_GE(room_faces, 4);
}

// The lab drive (7 m along the room, a half turn, 2 m back) with
// the EKF as the prior: the SfM poses stay within a centimetre of the truth
// and of the EKF (which is already that good here: the planes cannot add
// what the drive does not let them see, the position along the walls).
TEST(WheeledSfmTest, LabDriveWithEkfPrior) {
  const Outcome run = RunScenario("lab.json", 1, PoseSource::kEkf);
  ASSERT_GT(run.refined.frames, 350);
  EXPECT_LT(run.refined.along_mean_m, 0.01);
  EXPECT_LT(run.refined.lateral_mean_m, 0.012);
  EXPECT_LT(run.refined.lateral_max_m, 0.025);
  EXPECT_LT(run.refined.height_mean_m, 0.002);
  EXPECT_LT(run.refined.heading_mean_deg, 0.2);
  EXPECT_LT(run.refined.tilt_mean_deg, 0.1);
  ExpectTruePlanes(run.sfm, run.in.scenario.scene);
  // The corrected buffer covers the prior's times and places every scan.
  EXPECT_GT(run.sfm.poses.size(), run.sfm.sequence.poses.size());
}

// The slipping-wheel loop (lab_slip: two circles, the encoders over-read
// by 30 % and 20 % for a few seconds): the EKF refuses the slipping yaw
// rate (the gyro) but keeps the distance the wheel claimed, 8 cm at the
// end. The walls, seen at every angle on a circle, pull the position back:
// the SfM's mean along-track and lateral errors are under half the EKF's,
// its final position error under a quarter. Its heading is not better
// (the lines hardly see yaw): within 0.3 deg mean.
TEST(WheeledSfmTest, SlipDriveWallsCorrectThePosition) {
  for (uint64_t seed : {1u, 2u}) {
    const Outcome run = RunScenario("lab_slip.json", seed, PoseSource::kEkf);
    ASSERT_GT(run.refined.frames, 400);
    EXPECT_GT(run.prior.along_final_m, 0.05) << "the slip no longer corrupts the EKF's distance";
    EXPECT_LT(run.refined.along_mean_m, 0.5 * run.prior.along_mean_m);
    EXPECT_LT(run.refined.lateral_mean_m, 0.5 * run.prior.lateral_mean_m);
    EXPECT_LT(run.refined.along_final_m + run.refined.lateral_final_m,
              0.25 * (run.prior.along_final_m + run.prior.lateral_final_m));
    EXPECT_LT(run.refined.heading_mean_deg, 0.3);
    EXPECT_LT(run.refined.height_mean_m, 0.003);
  }
}

// With the odometry prior the slip turns the heading by ~47 deg; the lines
// do not undo it (the heading error of each slipping scan exceeds the
// association gates, and the planes are then mapped in the drifted frame).
// The test pins what the SfM does not fix, so that a change which fixes it
// is noticed and documented.
TEST(WheeledSfmTest, SlipDriveOdometryHeadingIsNotRecovered) {
  const Outcome run = RunScenario("lab_slip.json", 1, PoseSource::kOdometry);
  EXPECT_GT(run.prior.heading_final_deg, 30.0);
  EXPECT_GT(run.refined.heading_final_deg, 0.5 * run.prior.heading_final_deg);
}

// With the truth as the prior the corrected poses stay at the truth: the
// cost's minimum is where it should be (deskew, line fits, planes).
TEST(WheeledSfmTest, TruthPriorStaysAtTheTruth) {
  hardware::Recording in;
  ASSERT_NO_FATAL_FAILURE(SimulateLab(&in));
  WheeledSfmResult r;
  const Status s = RunWheeledSfm(in.log.scans, BodyFromLidar(in.geometry, MountingError()), in.truth_poses,
                                 SequenceInit(), WheeledSfmOptions(), &r);
  ASSERT_TRUE(s.ok()) << s.message();
  const WheeledErrors e = EvaluateWheeled(r.sequence.frame_times_s, r.sequence.poses, in.truth_poses);
  EXPECT_LT(e.along_mean_m, 0.003);
  EXPECT_LT(e.lateral_mean_m, 0.002);
  EXPECT_LT(e.heading_mean_deg, 0.03);
  EXPECT_LT(e.tilt_mean_deg, 0.03);
}

// The desktop app's Cancel (SequenceOptions::cancel): set before the run,
// it stops at the first frame; set while the run is under way (from another
// thread, once the first frames are tracked), it stops within a frame or a
// refinement iteration. Either way the error is "cancelled" and no poses
// come back.
TEST(WheeledSfmTest, CancelStopsTheRun) {
  hardware::Recording in;
  ASSERT_NO_FATAL_FAILURE(SimulateLab(&in));
  const Rigid3d body_from_lidar = BodyFromLidar(in.geometry, MountingError());
  std::atomic<bool> cancel{true};
  WheeledSfmOptions options;
  options.sequence.cancel = &cancel;
  WheeledSfmResult r;
  Status s = RunWheeledSfm(in.log.scans, body_from_lidar, in.truth_poses, SequenceInit(), options, &r);
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(s.message(), "cancelled");
  EXPECT_TRUE(r.poses.empty());

  // Uncancelled, the same run places every scan (the check is not a no-op).
  cancel = false;
  WheeledSfmResult whole;
  ASSERT_TRUE(RunWheeledSfm(in.log.scans, body_from_lidar, in.truth_poses, SequenceInit(), options, &whole).ok());
  EXPECT_FALSE(whole.poses.empty());

  // Mid-run: cancelled from another thread shortly after the start.
  std::atomic<bool> started{false};
  std::thread canceller([&] {
    while (!started) std::this_thread::yield();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    cancel = true;
  });
  started = true;
  WheeledSfmResult part;
  s = RunWheeledSfm(in.log.scans, body_from_lidar, in.truth_poses, SequenceInit(), options, &part);
  canceller.join();
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(s.message(), "cancelled");
}

// Why a prior: one vertical scan of the lab sees planes of two normal
// directions (floor/ceiling, side walls), so the paper's initialisation by
// the minimal solver is degenerate, and its constant-velocity tracking
// (started at the true pose, on the true planes) cannot hold the position
// along the walls: it loses the room.
TEST(WheeledSfmTest, LidarOnlyTrackingIsNotEnough) {
  hardware::Recording in;
  ASSERT_NO_FATAL_FAILURE(SimulateLab(&in));
  const Rigid3d body_from_lidar = BodyFromLidar(in.geometry, MountingError());
  WheeledSfmOptions options;
  SequenceInit init;
  std::vector<std::string> chosen;
  ASSERT_TRUE(WheeledInitFromTruth(in.log.scans, in.truth_poses, body_from_lidar, in.scenario.scene,
                                   options.min_scan_samples, &init, &chosen)
                  .ok());
  // Without a prior: the minimal solver's initialisation is refused.
  const sim::RigRun rig_run{sim::RigScansFromLidarScans(in.log.scans), {}, {}, {}};
  std::vector<Scan> scans = ScansFromRigRun(rig_run);
  Rig rig;
  rig.rig_from_lidar = {body_from_lidar * sim::X4LidarFromScanPlane()};
  SequenceResult plain;
  const Status s = RunSequence(scans, rig, init, options.sequence, &plain);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("not determined"), std::string::npos) << s.message();
  // The prior only starts it (constant velocity, no prior terms).
  options.motion.predict = false;
  options.motion.constrain = false;
  WheeledSfmResult r;
  ASSERT_TRUE(RunWheeledSfm(in.log.scans, body_from_lidar, in.truth_poses, init, options, &r).ok());
  const WheeledErrors e = EvaluateWheeled(r.sequence.frame_times_s, r.sequence.poses, in.truth_poses);
  std::printf("lidar-only tracking: along %.3f m mean, final %.3f m; planes %s, %s, %s\n", e.along_mean_m,
              e.along_final_m, chosen[0].c_str(), chosen[1].c_str(), chosen[2].c_str());
  EXPECT_GT(e.along_mean_m, 1.0);
}

TEST(WheeledSfmTest, NoPlanesIsAClearError) {
  // Scans of a few scattered returns: no line of 0.5 m.
  PoseBuffer prior;
  std::vector<LidarScan> scans;
  for (int k = 0; k < 20; ++k) {
    prior.Add(TimeFromSeconds(0.1 * k), Rigid3d::Translation(Eigen::Vector3d(0.02 * k, 0, 0)));
    LidarScan s;
    s.index = static_cast<uint32_t>(k);
    for (int b = 0; b < 400; ++b) {
      LidarSample m;
      m.time = TimeFromSeconds(0.1 * k + 0.0002 * b);
      m.beam = static_cast<uint16_t>(b);
      m.theta = static_cast<float>(2.0 * M_PI * b / 400.0);
      m.range_m = 1.0f + static_cast<float>((b * 7919) % 97) * 0.02f;  // a scatter, no straight runs
      s.samples.push_back(m);
    }
    scans.push_back(s);
  }
  WheeledSfmResult r;
  const Status s = RunWheeledSfm(scans, Rigid3d::Identity(), prior, SequenceInit(), WheeledSfmOptions(), &r);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("no planes found"), std::string::npos) << s.message();
  EXPECT_EQ(s.message().find('\n'), std::string::npos);
}

}  // namespace
}  // namespace sweepscan::sfm
