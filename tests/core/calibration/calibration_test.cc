#include "core/calibration/calibration.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>

#include "core/calibration/internal.h"
#include "core/pose/pose_estimator.h"
#include "core/scenario/scenario.h"
#include "core/sim/world.h"
#include "tests/core/calibration/lab_board.h"
#include "tests/testing/worlds.h"

namespace sweepscan {
namespace {


struct Case {
  uint64_t seed;
  MountingError truth;
  const char* name;
  sim::LabTarget target = sim::LabTarget::kSquare;
  const Eigen::Vector3d* corners() const {
    return target == sim::LabTarget::kSquare ? kSquareCorners : kDiamondCorners;
  }
  const Eigen::AlignedBox3d& region() const {
    return target == sim::LabTarget::kSquare ? kSquareRegion : kDiamondRegion;
  }
};

const MountingError kPaper{-0.0058, 0.0126, 0.0355};
const MountingError kSetC{-0.0200, 0.0200, 0.0100};
// 0-3: the paper's upright board, one turn at 0.2 m/s; 4-12: the diamond on
// the calibration drive (two turns at 0.05 m/s), 3 seeds per angle set.
const Case kCases[] = {
    {1, kPaper, "paper"},
    {2, kPaper, "paper"},
    {3, kSetB, "B"},
    {4, kSetC, "C"},
    {11, kPaper, "paper", sim::LabTarget::kDiamond},
    {12, kPaper, "paper", sim::LabTarget::kDiamond},
    {13, kPaper, "paper", sim::LabTarget::kDiamond},
    {14, kSetB, "B", sim::LabTarget::kDiamond},
    {15, kSetB, "B", sim::LabTarget::kDiamond},
    {16, kSetB, "B", sim::LabTarget::kDiamond},
    {17, kSetC, "C", sim::LabTarget::kDiamond},
    {18, kSetC, "C", sim::LabTarget::kDiamond},
    {19, kSetC, "C", sim::LabTarget::kDiamond},
};
constexpr int kSquareCases = 4;
constexpr int kAllCases = sizeof(kCases) / sizeof(kCases[0]);

// One simulated circle drive, shared by every test of a case.
struct Drive {
  sim::SimConfig config;
  SampleStore store;
  std::vector<PassWindow> windows;
  std::vector<LidarObservation> board[2];
  std::vector<PickPair> corner_picks;  // raw samples nearest the true corners
  double board_thickness_m = 0.0;      // the simulated target's
};

double Thickness(const Drive& d) { return d.board_thickness_m; }

const Drive& GetDrive(int case_index) {
  static std::map<int, std::unique_ptr<Drive>> cache;
  auto& slot = cache[case_index];
  if (slot) return *slot;
  slot = std::make_unique<Drive>();
  Drive& d = *slot;
  const Case& c = kCases[case_index];
  d.config = testing::CircleConfig(c.seed);
  d.config.scene = sim::LabScene(c.target);
  d.board_thickness_m = sim::LabTargetThickness(c.target);
  // The diamond cases drive the calibration drive (two slow turns: finer
  // scan spacing on the board, docs/calibration.md); SWEEPSCAN_CALIB_SPEED
  // and SWEEPSCAN_CALIB_TURNS override it to measure other drives.
  if (c.target == sim::LabTarget::kDiamond) {
    double speed = 0.05, turns = 2.0;
    if (const char* v = std::getenv("SWEEPSCAN_CALIB_SPEED")) speed = std::atof(v);
    if (const char* v = std::getenv("SWEEPSCAN_CALIB_TURNS")) turns = std::atof(v);
    d.config.path = {CircleSegment(0.83, speed, turns, /*left=*/true)};
  }
  d.config.mounting_error = c.truth;
  sim::SimWorld world(d.config);
  const SensorLog log = world.RunAll();
  // Truth poses: the calibration is about the mount; pose errors are the
  // EKF's business (docs/calibration.md reports an EKF run separately).
  const PoseBuffer poses = world.TruthPoses(1000.0);
  d.store = SampleStore(log, poses);
  // Sightings alternate near / far; with several turns, even ones form pass
  // 1 and odd ones pass 2 (as `sweepscan-cli calibrate --refine` does).
  TargetSightings t = CollectTargetSightings(d.store, d.config.geometry, {}, c.region(), 1.0, 50);
  d.windows = t.windows;
  EXPECT_GE(d.windows.size(), 2u);
  d.board[0] = std::move(t.passes[0]);
  d.board[1] = std::move(t.passes[1]);
  // An operator's clicks: in the first near and the first far sighting,
  // the sample whose true position is nearest each true corner.
  for (int j = 0; j < 4; ++j) {
    PickPair pp;
    Pick* picks[2] = {&pp.pass1, &pp.pass2};
    for (int k = 0; k < 2; ++k) {
      double best = 1e9;
      for (const auto& o : d.board[k]) {
        if (!d.windows[k].Contains(o.time_ns)) continue;
        const double dist =
            (ProjectObservation(o, d.config.geometry, c.truth) - c.corners()[j]).norm();
        if (dist < best) {
          best = dist;
          *picks[k] = SamplePick(o);
        }
      }
    }
    d.corner_picks.push_back(pp);
  }
  return d;
}

double CornerDistance(const Drive& d, const MountingError& c) {
  BoardCorners a, b;
  EXPECT_TRUE(FitBoardCorners(d.board[0], d.config.geometry, c, Thickness(d), &a).ok());
  EXPECT_TRUE(FitBoardCorners(d.board[1], d.config.geometry, c, Thickness(d), &b).ok());
  return CornerRms(a, b);
}

// The ceiling's fitted normal under a calibration (points above 2.3 m, away
// from the walls).
double CeilingTiltDeg(const Drive& d, const MountingError& c) {
  std::vector<Eigen::Vector3d> pts;
  for (const auto& o : d.store.observations()) {
    const Eigen::Vector3d p = ProjectObservation(o, d.config.geometry, c);
    if (p.z() > 2.3 && p.x() > 0.5 && p.x() < 9.5 && p.y() > 0.5 && p.y() < 4.5) pts.push_back(p);
  }
  Plane plane;
  EXPECT_TRUE(FitPlane(pts, &plane));
  return std::acos(std::min(1.0, std::abs(plane.normal.z()))) * 180.0 / M_PI;
}

class CalibrationCaseTest : public ::testing::TestWithParam<int> {
 protected:
  const Case& c() const { return kCases[GetParam()]; }
  const Drive& drive() const { return GetDrive(GetParam()); }
  // Refined corners on the drive's board samples, from zero.
  CalibrationSummary SolveRefined() const {
    CalibrationSummary s;
    const Drive& d = drive();
    CalibrationOptions o;
    o.board_thickness_m = d.board_thickness_m;
    const Status st = SolveRefinedCorners(d.board[0], d.board[1], d.config.geometry, {}, o, &s);
    EXPECT_TRUE(st.ok()) << st.message() << "\n" << s.FullReport();
    return s;
  }
  void Report(const char* mode, const CalibrationSummary& s, double corner_before,
              double corner_after) const {
    const Eigen::Vector3d e = ErrorMrad(s.angles, c().truth);
    std::printf(
        "[calib] seed %llu angles %-5s %-16s err(mrad) alpha %+7.3f beta %+7.3f gamma %+7.3f  "
        "sigma(mrad) %.3f %.3f %.3f  corner RMS %.4f -> %.4f m  outer %d LM %zu\n",
        static_cast<unsigned long long>(c().seed), c().name, mode, e[0], e[1], e[2],
        1e3 * s.sigma_rad[0], 1e3 * s.sigma_rad[1], 1e3 * s.sigma_rad[2], corner_before,
        corner_after, s.outer_iterations, s.trace.size());
  }
};

TEST_P(CalibrationCaseTest, RawSamplePicksAreTheBaseline) {
  const Drive& d = drive();
  std::vector<ObservationPair> pairs;
  ASSERT_TRUE(ResolvePairs(d.corner_picks, d.store, d.windows, d.config.geometry, {}, &pairs).ok());
  CalibrationSummary s;
  s.method = "pairs";
  const Status st = SolvePairs(pairs, d.config.geometry, {}, CalibrationOptions(), &s);
  ASSERT_TRUE(st.ok()) << st.message() << "\n" << s.FullReport();
  // Measured and reported, not bounded (the issue): only sanity here.
  EXPECT_LT(s.final_rms_m, s.initial_rms_m);
  EXPECT_GT(s.trace.size(), 1u);
  Report("raw-picks", s, CornerDistance(d, {}), CornerDistance(d, s.angles));
}

// The upright board (the paper's set-up): its side edges run parallel to
// the scan lines and are located only to the line spacing on the board
// (~5 cm), so refined corners recover gamma (from the top and bottom edges)
// but alpha and beta only to tens of mrad (measured, docs/calibration.md);
// the bounds here are sanity bounds, not the issue's.
class UprightBoardTest : public CalibrationCaseTest {};

TEST_P(UprightBoardTest, RefinedCornersConvergeAndRecoverGamma) {
  const Drive& d = drive();
  const CalibrationSummary s = SolveRefined();
  ASSERT_TRUE(s.converged) << s.FullReport();
  const Eigen::Vector3d e = ErrorMrad(s.angles, c().truth);
  const double before = CornerDistance(d, {}), after = CornerDistance(d, s.angles);
  Report("refined-corners", s, before, after);
  EXPECT_TRUE(s.converged);
  EXPECT_LT(std::abs(e[2]), 5.0) << s.FullReport();
  EXPECT_LT(e.cwiseAbs().maxCoeff(), 50.0) << s.FullReport();
  EXPECT_LT(after, before / 1.5);
  EXPECT_GT(s.sigma_rad.minCoeff(), 0.0);
}

// The diamond (a 5 mm board turned 45 deg) on the calibration drive (two
// turns at 0.05 m/s): every edge crosses the scan lines at 45 deg, so each pass's
// corners are fitted to millimetres. The bounds: refined corners
// within 3 mrad, and the fitted corners of the two passes at least ten
// times closer than uncalibrated.
class DiamondBoardTest : public CalibrationCaseTest {};

TEST_P(DiamondBoardTest, RefinedCornersRecoverEachAngleWithin3Mrad) {
  const Drive& d = drive();
  const CalibrationSummary s = SolveRefined();
  ASSERT_TRUE(s.converged) << s.FullReport();
  const Eigen::Vector3d e = ErrorMrad(s.angles, c().truth);
  const double before = CornerDistance(d, {}), after = CornerDistance(d, s.angles);
  Report("refined-corners", s, before, after);
  EXPECT_TRUE(s.converged);
  EXPECT_LT(e.cwiseAbs().maxCoeff(), 3.0) << s.FullReport();
  EXPECT_GT(before, 10.0 * after);
  EXPECT_GT(s.sigma_rad.minCoeff(), 0.0);
  // Sigma carries the corners' own uncertainty (refined_corners.cc): it
  // covers the error. The four pairs' misfit alone said 0.3-0.8 mrad for
  // alpha here, against errors up to 2.4.
  for (int k = 0; k < 3; ++k) EXPECT_LT(std::abs(e[k]), 3.0 * 1e3 * s.sigma_rad[k]) << k;
}

// Two turns: four sightings, alternately near (about 0.8 m from the lidar)
// and far (about 2.4 m, seen through the centre); pass 1 gathers the near
// ones and pass 2 the far ones.
TEST_P(DiamondBoardTest, SightingsAlternateNearAndFar) {
  const Drive& d = drive();
  ASSERT_EQ(d.windows.size(), 4u);
  for (int k = 0; k < 2; ++k) {
    double range = 0.0;
    for (const auto& o : d.board[k]) {
      range += o.p_lidar.norm();
      const int w = PassOfTime(d.windows, o.time_ns);
      EXPECT_TRUE(w == k || w == k + 2) << w;
    }
    range /= static_cast<double>(d.board[k].size());
    if (k == 0) {
      EXPECT_LT(range, 1.2);
    }
    if (k == 1) {
      EXPECT_GT(range, 2.0);
    }
  }
}

// The fitted board itself: each pass's rectangle at the true angles is the
// true board (0.6 m square, 45 deg) to a few millimetres.
TEST_P(DiamondBoardTest, BoardFitAtTruthFindsTheTrueCorners) {
  const Drive& d = drive();
  for (int k = 0; k < 2; ++k) {
    BoardCorners b;
    ASSERT_TRUE(FitBoardCorners(d.board[k], d.config.geometry, c().truth, Thickness(d), &b).ok());
    double worst = 0.0;
    for (int j = 0; j < 4; ++j) worst = std::max(worst, (b.corners[j] - c().corners()[j]).norm());
    std::printf("[calib] seed %llu pass %d board %.4f x %.4f m rotation %+.3f deg, %zu lines, "
                "%zu edge points, edge RMS %.1f mm, worst corner %.1f mm\n",
                static_cast<unsigned long long>(c().seed), k + 1, b.size_m.x(), b.size_m.y(),
                b.rotation_rad * 180.0 / M_PI, b.scans, b.edge_points, 1e3 * b.edge_rms_m,
                1e3 * worst);
    EXPECT_LT(worst, 0.003);
    EXPECT_NEAR(b.size_m.x(), 0.6, 0.0025);
    EXPECT_NEAR(b.size_m.y(), 0.6, 0.0025);
    EXPECT_NEAR(std::abs(b.rotation_rad), M_PI / 4, 0.02);
  }
}

// The board's 5 mm edge faces: beams passing just below its bottom edges
// hit them, and those hits project onto the edges, so a fit that ignores
// the thickness makes the near pass's board too large (its beams climb
// steeply there: +3.5 to +7.2 mm on width + height); given the thickness it
// is the true size to the scan lattice's quantisation (-2.7 to +1.2 mm,
// the same within an angle set: the lattice, not the noise).
TEST_P(DiamondBoardTest, BoardFitTakesOutTheEdgeFaces) {
  const Drive& d = drive();
  BoardCorners thin, thick;
  ASSERT_TRUE(FitBoardCorners(d.board[0], d.config.geometry, c().truth, 0.0, &thin).ok());
  ASSERT_TRUE(FitBoardCorners(d.board[0], d.config.geometry, c().truth, Thickness(d), &thick).ok());
  const double excess_thin = thin.size_m.sum() - 1.2, excess_thick = thick.size_m.sum() - 1.2;
  std::printf("[calib] seed %llu near pass: width + height - 1.2 m: %+.1f mm as a sheet, "
              "%+.1f mm %.0f mm thick\n",
              static_cast<unsigned long long>(c().seed), 1e3 * excess_thin, 1e3 * excess_thick,
              1e3 * Thickness(d));
  EXPECT_GT(excess_thin, 0.003);
  EXPECT_LT(std::abs(excess_thick), 0.0035);
  EXPECT_GT(excess_thin - excess_thick, 0.004);
}

TEST_P(CalibrationCaseTest, AutomaticModeRecoversEachAngleWithinHalfMrad) {
  const Drive& d = drive();
  CalibrationSummary s;
  const Status st = SolveAutomatic(d.store, d.config.geometry, {}, AutoCalibrationOptions(), &s);
  ASSERT_TRUE(st.ok()) << st.message() << "\n" << s.FullReport();
  const Eigen::Vector3d e = ErrorMrad(s.angles, c().truth);
  const double before = CornerDistance(d, {}), after = CornerDistance(d, s.angles);
  Report("auto-planes", s, before, after);
  EXPECT_LT(e.cwiseAbs().maxCoeff(), 0.5) << s.FullReport();
  if (c().target == sim::LabTarget::kDiamond) {
    EXPECT_GT(before, 10.0 * after);  // the bound
  } else {
    // On the upright board the corner metric is limited by the side edges:
    // the automatic result must do as well on it as the true angles do.
    EXPECT_LT(after, CornerDistance(d, c().truth) + 0.01);
  }
  EXPECT_LT(s.final_rms_m, s.initial_rms_m);
  EXPECT_GE(s.planes, 3);
  const double tilt_before = CeilingTiltDeg(d, {}), tilt_after = CeilingTiltDeg(d, s.angles);
  std::printf("[calib] seed %llu angles %-5s ceiling tilt %.4f deg -> %.4f deg\n",
              static_cast<unsigned long long>(c().seed), c().name, tilt_before, tilt_after);
  EXPECT_LT(tilt_after, 0.1);
}

INSTANTIATE_TEST_SUITE_P(SeedsAndAngles, CalibrationCaseTest, ::testing::Range(0, kAllCases));
INSTANTIATE_TEST_SUITE_P(SeedsAndAngles, UprightBoardTest, ::testing::Range(0, kSquareCases));
INSTANTIATE_TEST_SUITE_P(SeedsAndAngles, DiamondBoardTest,
                         ::testing::Range(kSquareCases, kAllCases));

// --- Bad input: clear errors, never a crash ---------------------------------

TEST(SolvePairsTest, DegenerateRealPicksWarn) {
  const Drive& d = GetDrive(0);
  // Four "pairs" all at one corner of the board: the three angles are not
  // separable from one point seen twice plus noise.
  std::vector<PickPair> picks(4, d.corner_picks[0]);
  std::vector<ObservationPair> pairs;
  ASSERT_TRUE(ResolvePairs(picks, d.store, d.windows, d.config.geometry, {}, &pairs).ok());
  // Make them distinct neighbouring samples, not duplicates.
  for (int k = 1; k < 4; ++k) {
    LidarObservation o;
    SampleRef r = pairs[k].pass1.ref;
    r.beam = static_cast<uint16_t>(r.beam - k);
    if (d.store.Find(r, &o).ok()) pairs[k].pass1 = o;
  }
  CalibrationSummary s;
  const Status st = SolvePairs(pairs, d.config.geometry, {}, CalibrationOptions(), &s);
  EXPECT_FALSE(s.warnings.empty()) << s.FullReport();
  std::printf("[calib] degenerate picks: %s; warnings: %s\n",
              st.ok() ? "solved" : st.message().c_str(),
              s.warnings.empty() ? "none" : s.warnings.front().c_str());
}

TEST(ResolvePairsTest, UnknownSampleAndWrongPassAndWorldSnap) {
  const Drive& d = GetDrive(0);
  std::vector<ObservationPair> pairs;
  // No sample at that time.
  std::vector<PickPair> picks = d.corner_picks;
  picks[1].pass1.sample.time_ns += 1;
  Status st = ResolvePairs(picks, d.store, d.windows, d.config.geometry, {}, &pairs);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("pair 2 (pairs[1]) pass1"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("the nearest is 1e-06 ms away"), std::string::npos) << st.message();
  // The right time with another range: the recording or its timing changed.
  picks = d.corner_picks;
  picks[1].pass1.sample.range_m += 0.002;
  st = ResolvePairs(picks, d.store, d.windows, d.config.geometry, {}, &pairs);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("the pick says"), std::string::npos) << st.message();
  // Unknown (scan, beam) of an older file.
  picks = d.corner_picks;
  picks[1].pass1 = PositionPick({999999, 10});
  st = ResolvePairs(picks, d.store, d.windows, d.config.geometry, {}, &pairs);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("(scan 999999, beam 10)"), std::string::npos) << st.message();
  // Both picks in pass 1.
  picks = d.corner_picks;
  picks[0].pass2 = picks[0].pass1;
  st = ResolvePairs(picks, d.store, d.windows, d.config.geometry, {}, &pairs);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("expected pass 2"), std::string::npos) << st.message();
  // A world position snaps to the nearest sample of its pass.
  picks = d.corner_picks;
  LidarObservation o;
  ASSERT_TRUE(d.store.Find(picks[2].pass2.sample, &o).ok());
  picks[2].pass2.has_sample = false;
  picks[2].pass2.world =
      ProjectObservation(o, d.config.geometry, {}) + Eigen::Vector3d(0.001, 0.0, 0.001);
  ASSERT_TRUE(ResolvePairs(picks, d.store, d.windows, d.config.geometry, {}, &pairs).ok());
  EXPECT_EQ(pairs[2].pass2.ref, o.ref);
  picks[2].pass2.world.x() = std::nan("");
  EXPECT_FALSE(ResolvePairs(picks, d.store, d.windows, d.config.geometry, {}, &pairs).ok());
}

// Two world picks of a pair name their passes either way round: the pair
// resolves to the same two samples whichever order the operator clicked.
TEST(ResolvePairsTest, WorldPicksInEitherPassOrderResolveToTheSameSamples) {
  const Drive& d = GetDrive(0);
  std::vector<PickPair> world = d.corner_picks;
  for (PickPair& p : world) {
    for (Pick* k : {&p.pass1, &p.pass2}) {
      LidarObservation o;
      ASSERT_TRUE(d.store.Find(k->sample, &o).ok());
      k->has_sample = false;  // `sample` still names the truth for the checks below
      k->world = ProjectObservation(o, d.config.geometry, {}) + Eigen::Vector3d(0.002, 0, -0.001);
    }
  }
  std::vector<ObservationPair> in_order, swapped;
  ASSERT_TRUE(ResolvePairs(world, d.store, d.windows, d.config.geometry, {}, &in_order).ok());
  std::vector<PickPair> truth = d.corner_picks;
  for (PickPair& p : world) std::swap(p.pass1, p.pass2);
  ASSERT_TRUE(ResolvePairs(world, d.store, d.windows, d.config.geometry, {}, &swapped).ok());
  ASSERT_EQ(in_order.size(), swapped.size());
  for (size_t k = 0; k < in_order.size(); ++k) {
    EXPECT_EQ(in_order[k].pass1.time_ns, truth[k].pass1.sample.time_ns) << k;
    EXPECT_EQ(in_order[k].pass2.time_ns, truth[k].pass2.sample.time_ns) << k;
    EXPECT_EQ(swapped[k].pass1.ref, in_order[k].pass1.ref) << k;
    EXPECT_EQ(swapped[k].pass2.ref, in_order[k].pass2.ref) << k;
  }
}

TEST(AutomaticTest, EmptyRecordingFails) {
  CalibrationSummary s;
  const Status st =
      SolveAutomatic(SampleStore(), RobotGeometry(), {}, AutoCalibrationOptions(), &s);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("samples"), std::string::npos) << st.message();
}

// --- Gyro bias (issue 14) -----------------------------------------------------

// Automatic mode on EKF poses of the lab circle (seed 1, the paper's angles,
// one turn or two) with a gyro z bias; the filter with or without its bias
// state, its poses smoothed over the drive as `calibrate` uses them.
Eigen::Vector3d EkfAutoErrorMrad(double gyro_bias_rad_s, bool estimate_gyro_bias,
                                 double turns = 1.0) {
  sim::SimConfig c = testing::CircleConfig(1);
  c.path = {CircleSegment(0.83, 0.2, turns, /*left=*/true)};
  c.mounting_error = kPaper;
  c.imu.gyro_bias_rad_s = gyro_bias_rad_s;
  sim::SimWorld world(c);
  const SensorLog log = world.RunAll();
  PoseEstimatorOptions o;
  o.initial_pose = c.start;
  o.ekf.estimate_gyro_bias = estimate_gyro_bias;
  o.smooth = true;
  const PoseEstimator est = EstimatePoses(log, o, c.geometry);
  CalibrationSummary s;
  const Status st =
      SolveAutomatic(SampleStore(log, est.poses()), c.geometry, {}, AutoCalibrationOptions(), &s);
  EXPECT_TRUE(st.ok()) << st.message() << "\n" << s.FullReport();
  const Eigen::Vector3d e = ErrorMrad(s.angles, c.mounting_error);
  std::printf("[calib] %.0f turn(s), gyro bias %.1f mrad/s, EKF %s the bias state: err(mrad) "
              "alpha %+7.3f beta %+7.3f gamma %+7.3f  sigma(mrad) %.3f %.3f %.3f\n",
              turns, 1e3 * gyro_bias_rad_s, estimate_gyro_bias ? "with" : "without", e[0], e[1], e[2],
              1e3 * s.sigma_rad[0], 1e3 * s.sigma_rad[1], 1e3 * s.sigma_rad[2]);
  return e;
}

// A 2 mrad/s gyro bias (the top of the HI219's range) must not reach the
// calibration: with the bias state, alpha on the biased drive is alpha on
// the same drive without bias, within 0.15 mrad. Without the state the bias
// bends the estimated circle and alpha moves by about -3 mrad (measured:
// SWEEPSCAN_GYRO_BIAS_COMPARE=1 prints it). The absolute bound is 1 mrad:
// on this seed and one turn alpha keeps a +0.64 mrad error that does not
// depend on the bias (+0.9 on the forward filter's poses; docs/results.md),
// so the 0.5 mrad is for the two-turn drive, below.
TEST(GyroBiasCalibrationTest, BiasOfTwoMradPerSecondDoesNotReachAlpha) {
  const Eigen::Vector3d biased = EkfAutoErrorMrad(0.002, true);
  const Eigen::Vector3d unbiased = EkfAutoErrorMrad(0.0, true);
  EXPECT_LT(std::abs(biased[0] - unbiased[0]), 0.15);
  EXPECT_LT(biased.cwiseAbs().maxCoeff(), 1.0);
  if (std::getenv("SWEEPSCAN_GYRO_BIAS_COMPARE") != nullptr) {
    const Eigen::Vector3d frozen = EkfAutoErrorMrad(0.002, false);
    EXPECT_GT(std::abs(frozen[0]), std::abs(biased[0]));
  }
}

// The bound on the calibration drive docs/calibration.md asks for,
// two slow turns: a 2 mrad/s gyro bias leaves every angle within 0.5 mrad
// (alpha +0.17 mrad on the smoothed poses, +0.41 on the forward filter's).
TEST(GyroBiasCalibrationTest, TwoTurnsWithBiasOfTwoMradPerSecondGiveAlphaWithinHalfAMilliradian) {
  const Eigen::Vector3d e = EkfAutoErrorMrad(0.002, true, 2.0);
  EXPECT_LT(std::abs(e[0]), 0.5);
  EXPECT_LT(std::abs(e[1]), 0.5);
  EXPECT_LT(std::abs(e[2]), 0.5);
}

// --- The IMU's tilt noise (issue 14) --------------------------------------------

// MeasureImuTiltNoise against the simulator's white tilt noise (the truth):
// within 5 % at the HI219's 0.3 deg and at 2 deg; a real tilt change (a
// 3 deg bump held for a second) does not count; CheckImuTiltNoise refuses
// 2 deg (more than 1 deg) and passes the data sheet's 0.5 deg.
TEST(ImuTiltNoiseTest, MeasuredFromConsecutiveReadings) {
  for (double deg : {0.3, 0.5, 2.0}) {
    sim::SimConfig c = testing::CircleConfig(3);
    c.imu.tilt_noise_rad = deg * M_PI / 180.0;
    sim::SimWorld world(c);
    SensorLog log = world.RunAll();
    const ImuTiltNoise plain = MeasureImuTiltNoise(log);
    ASSERT_GT(plain.pairs, 1000);
    EXPECT_NEAR(plain.roll_rad, c.imu.tilt_noise_rad, 0.05 * c.imu.tilt_noise_rad) << deg;
    EXPECT_NEAR(plain.pitch_rad, c.imu.tilt_noise_rad, 0.05 * c.imu.tilt_noise_rad) << deg;
    // A bump: 3 deg of roll for one second of readings.
    const Time t0 = log.imu[log.imu.size() / 2].time;
    for (ImuMeasurement& m : log.imu) {
      const double t = ToSeconds(m.time - t0);
      if (t >= 0.0 && t < 1.0) m.roll += 3.0 * M_PI / 180.0;
    }
    const ImuTiltNoise bumped = MeasureImuTiltNoise(log);
    EXPECT_NEAR(bumped.roll_rad, plain.roll_rad, 0.03 * plain.roll_rad) << deg;
    const Status check = CheckImuTiltNoise(log);
    EXPECT_EQ(check.ok(), deg < 1.0) << deg << ": " << check.message();
    if (!check.ok()) {
      EXPECT_EQ(check.message().rfind("refused: the IMU's tilt readings scatter", 0), 0u)
          << check.message();
    }
  }
  EXPECT_TRUE(CheckImuTiltNoise(SensorLog()).ok());  // nothing to judge
}

// The calibration's EKF takes the measured tilt noise when it is above the
// data sheet's 0.3 deg (workflow.h), never below it, and keeps the data
// sheet's when there is nothing to measure.
TEST(ImuTiltNoiseTest, TheCalibrationsEkfTakesTheMeasuredNoiseAboveTheDataSheets) {
  const double data_sheet = EkfOptions().imu_tilt_sigma;
  for (double deg : {0.1, 0.45}) {
    sim::SimConfig c = testing::CircleConfig(4);
    c.imu.tilt_noise_rad = deg * M_PI / 180.0;
    sim::SimWorld world(c);
    EkfOptions ekf;
    UseMeasuredTiltNoise(world.RunAll(), &ekf);
    const double expected = std::max(data_sheet, c.imu.tilt_noise_rad);
    EXPECT_NEAR(ekf.imu_tilt_sigma, expected, 0.05 * expected) << deg;
  }
  EkfOptions ekf;
  UseMeasuredTiltNoise(SensorLog(), &ekf);
  EXPECT_EQ(ekf.imu_tilt_sigma, data_sheet);
}

// --- Refusals (issue 14) --------------------------------------------------------

// The automatic mode on a simulated drive with truth poses.
Status SolveAutomaticOnTruth(const sim::SimConfig& c, CalibrationSummary* s) {
  sim::SimWorld world(c);
  const SensorLog log = world.RunAll();
  return SolveAutomatic(SampleStore(log, world.TruthPoses(1000.0)), c.geometry, {},
                        AutoCalibrationOptions(), s);
}

// A straight drive along the lab: no circle, so no two passes of each
// wall; refused before solving, with what to drive instead.
TEST(AutomaticTest, StraightDriveIsRefused) {
  sim::SimConfig c = testing::CircleConfig(1);
  c.start = {2.0, 2.5, 0.0};
  c.path = {{0.2, 0.0, 20.0}};
  CalibrationSummary s;
  const Status st = SolveAutomaticOnTruth(c, &s);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.message().rfind("refused: not a calibration drive", 0), 0u) << st.message();
  EXPECT_NE(st.message().find("circle"), std::string::npos) << st.message();
  EXPECT_EQ(st.message().find('\n'), std::string::npos);
  EXPECT_TRUE(s.trace.empty());  // refused before solving
}

// Before solving: a circle under a floor and a ceiling with no wall in the
// X4's range (two 40 m slabs) has two planes seen in both passes, but
// horizontal planes cannot tell a yaw of the scan plane (alpha): refused,
// naming alpha, before any LM iteration.
TEST(AutomaticTest, DriveThatLeavesAnAngleFreeIsRefusedBeforeSolving) {
  sim::SimConfig c = testing::CircleConfig(1);
  c.mounting_error = kPaper;
  sim::Box floor, ceiling;
  floor.label = "floor";
  floor.center = Eigen::Vector3d(5.0, 1.7, -0.05);
  floor.size = Eigen::Vector3d(40.0, 40.0, 0.1);
  ceiling.label = "ceiling";
  ceiling.center = Eigen::Vector3d(5.0, 1.7, 2.55);
  ceiling.size = Eigen::Vector3d(40.0, 40.0, 0.1);
  c.scene = sim::Scene({floor, ceiling});
  CalibrationSummary s;
  const Status st = SolveAutomaticOnTruth(c, &s);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.message().rfind("refused: the drive leaves alpha weakly determined", 0), 0u)
      << st.message();
  EXPECT_EQ(st.message().find('\n'), std::string::npos);
  EXPECT_TRUE(s.trace.empty());  // refused before solving
}

// After the solve: a result at the angle bound, or with residuals or sigma
// collapsed, is refused. The thresholds are moved onto a good solve of the
// paper's drive (gamma = 35.5 mrad, RMS/sigma ~0.8, sigma >= 0.01 mrad) to
// exercise each check; the defaults (0.45 rad, 0.05, 1e-7 rad) are far from
// it, so a genuine result passes (CalibrationCaseTest).
TEST(AutomaticTest, ResultsAtTheBoundOrCollapsedAreRefused) {
  const Drive& d = GetDrive(0);
  AutoCalibrationOptions o;
  o.max_abs_angle_rad = 0.03;
  CalibrationSummary s;
  Status st = SolveAutomatic(d.store, d.config.geometry, {}, o, &s);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.message().rfind("refused: gamma = ", 0), 0u) << st.message();
  EXPECT_NE(st.message().find("bound"), std::string::npos) << st.message();
  EXPECT_FALSE(s.converged);
  o = AutoCalibrationOptions();
  o.min_rms_sigmas = 5.0;  // as if the X4's noise had vanished from the residuals
  o.max_rms_sigmas = 10.0;
  st = SolveAutomatic(d.store, d.config.geometry, {}, o, &s);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.message().rfind("refused: the residuals collapsed", 0), 0u) << st.message();
  EXPECT_EQ(st.message().find('\n'), std::string::npos);
  o = AutoCalibrationOptions();
  o.min_rms_sigmas = 0.01;
  o.max_rms_sigmas = 0.1;  // as if the lidar were ten times noisier than its model
  st = SolveAutomatic(d.store, d.config.geometry, {}, o, &s);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.message().rfind("refused: the residuals are ", 0), 0u) << st.message();
  EXPECT_NE(st.message().find("times the lidar's noise model"), std::string::npos) << st.message();
  EXPECT_EQ(st.message().find('\n'), std::string::npos);
  o = AutoCalibrationOptions();
  o.max_rms_sigmas = o.min_rms_sigmas;
  EXPECT_FALSE(SolveAutomatic(d.store, d.config.geometry, {}, o, &s).ok());
}

// The plane problem's analytic angle Jacobian (pairs_solver.cc: the
// derivatives of R(c) as cross products with the axes a_k, through the
// Huber loss inside the residual) against central differences, on samples
// of the paper's drive and the floor: its points are inside the loss's
// scale, the walls' and the ceiling's far outside. (Ceres' own check_gradients is no
// referee here: its Ridders differences disagree with both this Jacobian
// and plain central differences on the Huber branch.)
TEST(AutomaticTest, AngleJacobianMatchesCentralDifferences) {
  using calibration_internal::PlaneProblem;
  using calibration_internal::Prepare;
  using calibration_internal::Prepared;
  const Drive& d = GetDrive(0);
  std::vector<Prepared> prepared;
  std::vector<double> sigma;
  std::vector<std::vector<size_t>> chosen(1);
  for (size_t i = 0; i < d.store.observations().size(); i += 997) {
    prepared.push_back(Prepare(d.store.observations()[i], d.config.geometry));
    sigma.push_back(0.003 + 0.002 * (i % 3));
    chosen[0].push_back(prepared.size() - 1);
  }
  ASSERT_GT(prepared.size(), 100u);
  Plane plane;  // the floor
  plane.normal = Eigen::Vector3d::UnitZ();
  plane.d = 0.0;
  const MountingError& truth = kCases[0].truth;
  double abg[3] = {truth.alpha, truth.beta, truth.gamma};
  double scale = 1.0;
  PlaneProblem problem(abg, {plane}, chosen, prepared, sigma, RobustLoss::kHuber, 2.0, &scale,
                       Eigen::Vector3d(4.0, 2.0, 0.0), true);
  std::vector<double> r;
  Eigen::MatrixXd analytic, unused;
  ASSERT_TRUE(problem.EvaluateAngles(&r, &analytic));
  int inside = 0, outside = 0;
  for (double v : r) (std::abs(v) < 2.0 ? inside : outside)++;
  EXPECT_GT(inside, 3);
  EXPECT_GT(outside, 3);
  const double h = 1e-6;
  for (int k = 0; k < 3; ++k) {
    std::vector<double> plus, minus;
    const double c = abg[k];
    abg[k] = c + h;
    ASSERT_TRUE(problem.EvaluateAngles(&plus, &unused));
    abg[k] = c - h;
    ASSERT_TRUE(problem.EvaluateAngles(&minus, &unused));
    abg[k] = c;
    for (size_t i = 0; i < r.size(); ++i) {
      const double numeric = (plus[i] - minus[i]) / (2.0 * h);
      EXPECT_NEAR(analytic(i, k), numeric, 1e-5 * std::max(1.0, std::abs(numeric)))
          << "angle " << k << " row " << i;
    }
  }
}

// Each round's LM ends once a step moves no angle by more than
// lm_angle_tolerance_rad (Huber makes LM converge linearly): the angles
// then agree with a solve run to Ceres' 1e-12 function tolerance to well
// within the mode's settling (1e-5 rad), in fewer steps (here 57 against
// 70; on the two-turn drive of BM_SolveAutomaticTwoTurnsEkf 58 against 83).
TEST(AutomaticTest, AngleStepToleranceEndsTheRoundsEarlyAtTheSameAngles) {
  const Drive& d = GetDrive(0);
  AutoCalibrationOptions early, full;
  full.lm_angle_tolerance_rad = 0.0;
  CalibrationSummary a, b;
  ASSERT_TRUE(SolveAutomatic(d.store, d.config.geometry, {}, early, &a).ok());
  ASSERT_TRUE(SolveAutomatic(d.store, d.config.geometry, {}, full, &b).ok());
  EXPECT_LT(ErrorMrad(a.angles, b.angles).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_LT(a.trace.size(), b.trace.size());
}

TEST(RefinedCornersTest, TooFewSamplesFails) {
  CalibrationSummary s;
  const Status st = SolveRefinedCorners({}, {}, RobotGeometry(), {}, CalibrationOptions(), &s);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("pass 1"), std::string::npos) << st.message();
}

}  // namespace
}  // namespace sweepscan
