// Automatic calibration over many seeds, angle sets and both pose sources:
// each angle within the bound, and the reported 1-sigma honest
// (|error| / sigma stays small over the sweep). The cheaper companion of
// calibration_test: no refined corners, one solve per case.
//
// SWEEPSCAN_SWEEP_SEEDS=N widens the sweep (default 1 seed per angle set and
// pose source, 6 cases; docs/calibration.md reports a 6-seed run, 36 cases).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "core/calibration/calibration.h"
#include "core/cloud/reconstruct.h"
#include "core/pose/pose_estimator.h"
#include "core/scenario/scenario.h"
#include "core/sim/world.h"
#include "tests/testing/worlds.h"

namespace sweepscan {
namespace {

struct AngleSet {
  const char* name;
  MountingError truth;
};
const AngleSet kAngleSets[] = {
    {"paper", {-0.0058, 0.0126, 0.0355}},
    {"B", {0.0150, -0.0100, -0.0200}},
    {"C", {-0.0200, 0.0200, 0.0100}},
};

int SeedCount() {
  const char* e = std::getenv("SWEEPSCAN_SWEEP_SEEDS");
  return e != nullptr ? std::max(1, std::atoi(e)) : 1;
}

struct Outcome {
  Eigen::Vector3d error_mrad, sigma_mrad;
  bool ok = false;
};

Outcome RunCase(uint64_t seed, const MountingError& truth, PoseSource source) {
  sim::SimConfig config = testing::CircleConfig(seed);
  config.mounting_error = truth;
  sim::SimWorld world(config);
  const SensorLog log = world.RunAll();
  const PoseBuffer truth_poses = world.TruthPoses(1000.0);
  PoseBuffer poses = truth_poses;
  if (source != PoseSource::kTruth) {
    ReconstructionOptions options;
    options.pose.source = source;
    options.pose.initial_pose = config.start;
    options.pose.smooth = true;  // as `calibrate` does (EKF only)
    ReconstructionResult r;
    EXPECT_TRUE(Reconstruct(log, config.geometry, options, &truth_poses, &r).ok());
    poses = r.poses;
    // The EKF's own attitude error over the drive: a constant roll or pitch
    // error of the body is indistinguishable from gamma or beta.
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int n = 0;
    for (size_t i = 0; i < poses.size(); i += 10) {
      Rigid3d t;
      if (!truth_poses.Lookup(poses.time(i), &t)) continue;
      const Eigen::Quaterniond q = t.rotation().conjugate() * poses.pose(i).rotation();
      const Eigen::Vector3d aa = Eigen::AngleAxisd(q).angle() * Eigen::AngleAxisd(q).axis();
      sum += aa;
      ++n;
    }
    if (n > 0) {
      const Eigen::Vector3d m = 1e3 * sum / n;
      std::printf(
          "[sweep] ekf   seed %3llu mean attitude error (body x, y, z) %+.3f %+.3f %+.3f mrad\n",
          static_cast<unsigned long long>(seed), m.x(), m.y(), m.z());
    }
  }
  const SampleStore store(log, poses);
  CalibrationSummary s;
  AutoCalibrationOptions options;
  if (source == PoseSource::kTruth) {  // as the CLI does
    options.pose_heading_sigma_rad = options.pose_tilt_sigma_rad = 0.0;
  }
  const Status st = SolveAutomatic(store, config.geometry, {}, options, &s);
  Outcome out;
  out.ok = st.ok();
  EXPECT_TRUE(st.ok()) << st.message() << "\n" << s.FullReport();
  out.error_mrad = 1e3 * Eigen::Vector3d(s.angles.alpha - truth.alpha, s.angles.beta - truth.beta,
                                         s.angles.gamma - truth.gamma);
  out.sigma_mrad = 1e3 * s.sigma_rad;
  return out;
}

class AutomaticSweepTest : public ::testing::TestWithParam<PoseSource> {};

TEST_P(AutomaticSweepTest, EachAngleWithinHalfMradAndSigmaHonest) {
  const PoseSource source = GetParam();
  const int seeds = SeedCount();
  double worst = 0.0, worst_z = 0.0, sum_z2 = 0.0;
  int n = 0;
  for (int a = 0; a < 3; ++a) {
    for (int k = 0; k < seeds; ++k) {
      // Different seeds per angle set: 3 x seeds independent drives.
      const uint64_t seed = 10 + 100 * a + k;
      const Outcome o = RunCase(seed, kAngleSets[a].truth, source);
      if (!o.ok) continue;
      const Eigen::Vector3d z = o.error_mrad.cwiseQuotient(o.sigma_mrad);
      std::printf(
          "[sweep] %-5s seed %3llu angles %-5s err(mrad) %+7.3f %+7.3f %+7.3f  sigma %.3f %.3f "
          "%.3f  z %+5.2f %+5.2f %+5.2f\n",
          PoseSourceName(source), static_cast<unsigned long long>(seed), kAngleSets[a].name,
          o.error_mrad[0], o.error_mrad[1], o.error_mrad[2], o.sigma_mrad[0], o.sigma_mrad[1],
          o.sigma_mrad[2], z[0], z[1], z[2]);
      worst = std::max(worst, o.error_mrad.cwiseAbs().maxCoeff());
      worst_z = std::max(worst_z, z.cwiseAbs().maxCoeff());
      sum_z2 += z.squaredNorm();
      n += 3;
      // Truth poses: the 0.5 mrad. EKF poses (smoothed, as
      // `calibrate` takes them): what is left of the filter's heading error
      // adds to alpha (0.89 mrad at most on these three drives; over 120
      // drives 0.39 RMS and one in about 65 above 1 mrad, up to 1.14:
      // docs/results.md, "Robustness"; on the forward filter's poses this
      // bound was 2.5). The 3 sigma bound below is the other check.
      EXPECT_LT(o.error_mrad.cwiseAbs().maxCoeff(), source == PoseSource::kTruth ? 0.5 : 1.2)
          << "seed " << seed;
    }
  }
  const double rms_z = std::sqrt(sum_z2 / std::max(1, n));
  std::printf("[sweep] %s: worst error %.3f mrad, worst |error|/sigma %.2f, RMS error/sigma %.2f\n",
              PoseSourceName(source), worst, worst_z, rms_z);
  // Honest sigma: errors / sigma behave like N(0, 1) draws; with 6-18 of
  // them none should pass 4.
  EXPECT_LT(worst_z, 4.0);
}

INSTANTIATE_TEST_SUITE_P(PoseSources, AutomaticSweepTest,
                         ::testing::Values(PoseSource::kTruth, PoseSource::kEkf),
                         [](const auto& info) { return std::string(PoseSourceName(info.param)); });

}  // namespace
}  // namespace sweepscan

namespace sweepscan {
namespace {

// One drive of the honest-uncertainty sweeps: the lab circle (`turns` of
// it at 0.2 m/s) with sensor errors and mounting angles drawn from `seed`,
// calibrated automatically on EKF poses; the error (truth subtracted).
struct SweepDrive {
  Eigen::Vector3d error_rad, sigma_rad;
};
SweepDrive DrawnSensorErrorDrive(uint64_t seed, double turns) {
  std::mt19937_64 rng(seed);
  auto u = [&rng](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  sim::SimConfig config = testing::CircleConfig(seed);
  config.path = {CircleSegment(0.83, 0.2, turns, /*left=*/true)};
  const double max_angle = 2.0 * M_PI / 180.0;
  config.mounting_error = {u(-max_angle, max_angle), u(-max_angle, max_angle), u(-max_angle, max_angle)};
  config.imu.gyro_bias_rad_s = u(-0.002, 0.002);
  config.imu.gyro_noise_rad_s = u(0.001, 0.005);
  config.imu.tilt_noise_rad = u(0.1, 0.5) * M_PI / 180.0;
  config.lidar.range_noise_m = u(0.001, 0.003);
  config.lidar.range_noise_fraction = u(0.001, 0.004);
  config.lidar.range_offset_m = u(-0.005, 0.005);
  config.lidar.time_offset_s = u(-0.003, 0.003);
  config.odometry.scale_error_left = u(-0.01, 0.01);
  config.odometry.scale_error_right = u(-0.01, 0.01);
  // EKF poses smoothed over the drive, as `calibrate` uses them.
  sim::SimWorld world(config);
  const SensorLog log = world.RunAll();
  PoseEstimatorOptions pose;
  pose.initial_pose = config.start;
  pose.smooth = true;
  const PoseBuffer poses = EstimatePoses(log, pose, config.geometry).poses();
  CalibrationSummary s;
  const Status st =
      SolveAutomatic(SampleStore(log, poses), config.geometry, {}, AutoCalibrationOptions(), &s);
  EXPECT_TRUE(st.ok()) << "seed " << seed << ": " << st.message();
  const MountingError& t = config.mounting_error;
  SweepDrive d;
  d.error_rad = Eigen::Vector3d(s.angles.alpha - t.alpha, s.angles.beta - t.beta, s.angles.gamma - t.gamma);
  d.sigma_rad = s.sigma_rad;
  std::printf("[coverage] seed %llu, %.0f turn(s): err(mrad) %+7.3f %+7.3f %+7.3f  sigma %.3f %.3f %.3f\n",
              static_cast<unsigned long long>(seed), turns, 1e3 * d.error_rad[0], 1e3 * d.error_rad[1],
              1e3 * d.error_rad[2], 1e3 * d.sigma_rad[0], 1e3 * d.sigma_rad[1], 1e3 * d.sigma_rad[2]);
  return d;
}

// Issue 14's honest-uncertainty check: drives with sensor errors drawn
// across the HI219 and X4 data sheets (scripts/calibration-robustness.py
// draws the same ranges for its 30-drive table in docs/results.md) and
// mounting angles up to 2 deg; EKF poses; |error| <= 3 sigma for at least
// 95 % of the angles.
TEST(AutomaticSweepTest, SigmaCoversRandomSensorErrors) {
  constexpr int kDrives = 20;
  int inside = 0, count = 0;
  for (int drive = 0; drive < kDrives; ++drive) {
    const SweepDrive d = DrawnSensorErrorDrive(7000 + drive, 1.0);
    for (int k = 0; k < 3; ++k) {
      inside += std::abs(d.error_rad[k]) <= 3.0 * d.sigma_rad[k];
      ++count;
    }
  }
  std::printf("[coverage] %d of %d angles inside 3 sigma\n", inside, count);
  EXPECT_GE(inside, static_cast<int>(std::ceil(0.95 * count)));
}

// The in-process sweeps' summary over 12 drives (seeds 7100-7111) of the
// lab circle with `turns` turns: per-angle RMS and largest |error| (rad),
// and how many of the 36 errors are inside 3 sigma.
struct SweepAims {
  static constexpr int kDrives = 12;
  Eigen::Vector3d rms = Eigen::Vector3d::Zero(), worst = Eigen::Vector3d::Zero();
  int inside = 0;
};

SweepAims RunTwelveDrives(double turns) {
  SweepAims a;
  Eigen::Vector3d sq = Eigen::Vector3d::Zero();
  for (int drive = 0; drive < SweepAims::kDrives; ++drive) {
    const SweepDrive d = DrawnSensorErrorDrive(7100 + drive, turns);
    sq += d.error_rad.cwiseAbs2();
    a.worst = a.worst.cwiseMax(d.error_rad.cwiseAbs());
    for (int k = 0; k < 3; ++k) a.inside += std::abs(d.error_rad[k]) <= 3.0 * d.sigma_rad[k];
  }
  a.rms = (sq / SweepAims::kDrives).cwiseSqrt();
  std::printf("[aims] %.0f turns, %d drives: RMS (mrad) %.3f %.3f %.3f, max %.3f %.3f %.3f, %d of "
              "%d inside 3 sigma\n",
              turns, SweepAims::kDrives, 1e3 * a.rms[0], 1e3 * a.rms[1], 1e3 * a.rms[2],
              1e3 * a.worst[0], 1e3 * a.worst[1], 1e3 * a.worst[2], a.inside,
              3 * SweepAims::kDrives);
  return a;
}

// Two turns (the drive docs/calibration.md asked for before three), on 12
// more seeds with the same drawn sensor errors, on smoothed EKF poses:
// issue 14's aims are 0.5 mrad RMS and 1 mrad at most per angle. Here
// alpha 0.39 RMS, 0.79 at most; but about 1 drive in 60 passes 1 mrad on two
// turns (seed 7103 gave 1.12 with earlier code; docs/results.md,
// "Robustness"), so alpha's max is held to 1.2, and to its sigma, which
// covers it.
TEST(AutomaticSweepTest, TwoTurnsOnDrawnSensorErrors) {
  const SweepAims a = RunTwelveDrives(2.0);
  EXPECT_LT(a.rms[0], 0.5e-3);
  EXPECT_LT(a.worst[0], 1.2e-3);
  for (int k = 1; k < 3; ++k) {
    EXPECT_LT(a.rms[k], 0.5e-3) << k;
    EXPECT_LT(a.worst[k], 1.0e-3) << k;
  }
  EXPECT_EQ(a.inside, 3 * SweepAims::kDrives);
}

// The drive docs/calibration.md asks for now, three turns, on the same 12
// seeds: the aims for every angle, 0.5 mrad RMS and 1 mrad at most
// (over the 120 drives of docs/results.md, "Robustness": alpha 0.307 /
// 0.809, beta 0.193 / 0.433, gamma 0.064 / 0.179), every error inside 3 sigma.
TEST(AutomaticSweepTest, ThreeTurnsMeetTheAimsOnDrawnSensorErrors) {
  const SweepAims a = RunTwelveDrives(3.0);
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(a.rms[k], 0.5e-3) << k;
    EXPECT_LT(a.worst[k], 1.0e-3) << k;
  }
  EXPECT_EQ(a.inside, 3 * SweepAims::kDrives);
}

// Measurement aid (docs/calibration.md, "What biased the automatic mode"):
// SWEEPSCAN_DIAG=1 prints the kept planes and the errors under option
// variants for a few drives. Skipped otherwise.
TEST(AutomaticDiagnostics, PlanesAndVariants) {
  if (std::getenv("SWEEPSCAN_DIAG") == nullptr) GTEST_SKIP() << "set SWEEPSCAN_DIAG=1";
  const int seeds = SeedCount();
  for (int a = 0; a < 3; ++a) {
    for (int k = 0; k < seeds; ++k) {
      const uint64_t seed = 10 + 100 * a + k;
      sim::SimConfig config = testing::CircleConfig(seed);
      config.mounting_error = kAngleSets[a].truth;
      sim::SimWorld world(config);
      const SensorLog log = world.RunAll();
      const SampleStore store(log, world.TruthPoses(1000.0));
      struct Variant {
        const char* name;
        AutoCalibrationOptions o;
      };
      std::vector<Variant> variants;
      AutoCalibrationOptions base;
      variants.push_back({"base", base});
      if (const char* v = std::getenv("SWEEPSCAN_DIAG_VARIANTS"); v != nullptr && std::atoi(v)) {
        AutoCalibrationOptions o = base;
        o.edge_margin_m = 0.0;
        variants.push_back({"edge0", o});
        o = base;
        o.edge_margin_m = 0.15;
        variants.push_back({"edge15", o});
        o = base;
        o.membership_sigmas = 2.0;
        variants.push_back({"memb2", o});
        o = base;
        o.max_points_per_plane = 30000;
        o.max_segmentation_points = 400000;
        variants.push_back({"allpts", o});
        o = base;
        o.min_range_m = 1.0;
        variants.push_back({"minr1", o});
        o = base;
        o.max_planes = 5;
        variants.push_back({"planes5", o});
      }
      for (const auto& v : variants) {
        CalibrationSummary s;
        const Status st = SolveAutomatic(store, config.geometry, {}, v.o, &s);
        const MountingError& t = kAngleSets[a].truth;
        std::printf(
            "[diag] seed %3llu %-5s %-8s %s err %+7.3f %+7.3f %+7.3f sigma %.3f %.3f %.3f "
            "iid %.3f %.3f %.3f pts %d\n",
            static_cast<unsigned long long>(seed), kAngleSets[a].name, v.name,
            st.ok() ? "ok  " : "FAIL", 1e3 * (s.angles.alpha - t.alpha),
            1e3 * (s.angles.beta - t.beta), 1e3 * (s.angles.gamma - t.gamma), 1e3 * s.sigma_rad[0],
            1e3 * s.sigma_rad[1], 1e3 * s.sigma_rad[2], 1e3 * s.sigma_iid_rad[0],
            1e3 * s.sigma_iid_rad[1], 1e3 * s.sigma_iid_rad[2], s.residual_blocks);
        if (std::string(v.name) == "base") {
          for (const auto& p : s.plane_reports) {
            std::printf(
                "[diag]    plane n (%+.4f %+.4f %+.4f) d %+.3f pts %5d sight %d rms %.4f "
                "rms/sigma %.2f\n",
                p.normal.x(), p.normal.y(), p.normal.z(), p.d, p.points, p.sightings, p.rms_m,
                p.rms_sigmas);
          }
        }
      }
    }
  }
}

}  // namespace
}  // namespace sweepscan
