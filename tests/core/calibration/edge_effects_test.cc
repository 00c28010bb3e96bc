// The refined corners under what real edges do (issue 32): mixed returns at
// the board's edges and range errors, on the simulated diamond drive.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "core/calibration/calibration.h"
#include "core/calibration/internal.h"
#include "core/scenario/scenario.h"
#include "core/sim/world.h"
#include "tests/core/calibration/lab_board.h"
#include "tests/testing/worlds.h"

namespace sweepscan {
namespace {

// The diamond drive (three turns at 0.05 m/s, truth poses) with what real
// edges do (issue 32): half of the beams straddling the board's edges report
// a mixed range (half of those a blend of the two surfaces', half the other
// surface's), every range reads 0.5 % long plus 6 mm. The refined corners
// must still land within the aims (2 mrad) and inside 3 sigma, and count the
// lines they rejected and the mixed returns they recognised; the same drive
// without mixed returns rejects far fewer.
struct EdgeDrive {
  sim::SimConfig config;
  std::vector<LidarObservation> board[2];
};

EdgeDrive SimulateEdgeDrive(double mixed_share, bool range_errors = true) {
  EdgeDrive d;
  d.config = testing::CircleConfig(21);
  d.config.scene = sim::LabScene(sim::LabTarget::kDiamond);
  d.config.path = {CircleSegment(0.83, 0.05, 3.0, /*left=*/true)};
  d.config.mounting_error = kSetB;
  d.config.lidar.mixed_return_share = mixed_share;
  d.config.lidar.mixed_blend_share = 0.5;
  d.config.lidar.range_offset_m = range_errors ? 0.006 : 0.0;
  d.config.lidar.range_scale_error = range_errors ? 0.005 : 0.0;
  sim::SimWorld world(d.config);
  const SensorLog log = world.RunAll();
  const SampleStore store(log, world.TruthPoses(1000.0));
  TargetSightings t = CollectTargetSightings(store, d.config.geometry, {}, kDiamondRegion, 1.0, 50);
  d.board[0] = std::move(t.passes[0]);
  d.board[1] = std::move(t.passes[1]);
  return d;
}

// Both drives solved once, shared by the tests below.
const CalibrationSummary& EdgeDriveSolve(bool mixed) {
  static std::map<bool, CalibrationSummary> cache;
  auto it = cache.find(mixed);
  if (it != cache.end()) return it->second;
  CalibrationOptions o;
  o.board_thickness_m = sim::LabTargetThickness(sim::LabTarget::kDiamond);
  // Truth poses carry no path scale from the room's planes to take up the
  // range errors (docs/calibration.md, "Range errors do not cancel"), so
  // the solve is told their size, as an operator with a measured lidar
  // would: the drive's +6 mm and +0.5 %.
  o.range_offset_sigma_m = 0.006;
  o.range_scale_sigma = 0.005;
  const EdgeDrive d = SimulateEdgeDrive(mixed ? 0.5 : 0.0);
  CalibrationSummary s;
  const Status st = SolveRefinedCorners(d.board[0], d.board[1], d.config.geometry, {}, o, &s);
  EXPECT_TRUE(st.ok()) << st.message() << "\n" << s.FullReport();
  const Eigen::Vector3d e = ErrorMrad(s.angles, kSetB);
  std::printf("[calib] mixed edges %s: err(mrad) alpha %+7.3f beta %+7.3f gamma %+7.3f  "
              "sigma(mrad) %.3f %.3f %.3f  edge points %d kept, %d rejected, %d a sample off, "
              "%d mixed\n",
              mixed ? "0.5 " : "none", e[0], e[1], e[2], 1e3 * s.sigma_rad[0],
              1e3 * s.sigma_rad[1], 1e3 * s.sigma_rad[2], s.edge_points, s.rejected_edge_points,
              s.shifted_edge_points, s.mixed_edge_samples);
  return cache[mixed] = s;
}

TEST(RefinedCornersTest, MixedEdgeReturnsAreCountedAndSigmaCoversThem) {
  const CalibrationSummary& clean = EdgeDriveSolve(false);
  const CalibrationSummary& mixed = EdgeDriveSolve(true);
  for (const CalibrationSummary* s : {&clean, &mixed}) {
    ASSERT_TRUE(s->converged) << s->FullReport();
    const Eigen::Vector3d e = ErrorMrad(s->angles, kSetB);
    for (int k = 0; k < 3; ++k) {
      EXPECT_LT(std::abs(e[k]), 3.0 * 1e3 * s->sigma_rad[k]) << k << "\n" << s->FullReport();
    }
  }
  EXPECT_GT(mixed.mixed_edge_samples, 20);
  // Lines a sample short or long: kept and counted (they widen the sigma);
  // the few rejected are lines further off (dropouts beside the edge).
  EXPECT_GT(mixed.shifted_edge_points, 2 * clean.shifted_edge_points + 10);
  EXPECT_LT(mixed.rejected_edge_points, mixed.shifted_edge_points / 4);
  EXPECT_GE(clean.mixed_edge_samples, 0);
  EXPECT_LT(clean.mixed_edge_samples, 5);  // a clean drive has (nearly) none
}

// The aim on the same drives: every angle within 2 mrad. Not met
// (2026-11-27): the range offset and scale alone leave alpha, beta +3.0 and
// gamma +1.7 mrad on truth poses, and with the mixed returns alpha and beta
// come out +2.1 / +2.6 (+6.8 / +5.7 before the simulator's spot followed
// the laser's line, +8.5 / +7.6 while the ends a sample off were rejected;
// docs/calibration.md, "Mixed returns and range errors"). Run with
// --gtest_also_run_disabled_tests.
TEST(RefinedCornersTest, DISABLED_MixedEdgeReturnsAndARangeOffsetStayWithinTwoMrad) {
  for (bool mixed : {false, true}) {
    const Eigen::Vector3d e = ErrorMrad(EdgeDriveSolve(mixed).angles, kSetB);
    for (int k = 0; k < 3; ++k) EXPECT_LT(std::abs(e[k]), 2.0) << k << " mixed " << mixed;
  }
}

// Where the angle errors of the drive above come from, each effect alone, at
// the true angles (docs/calibration.md, "Mixed returns and range errors").
// Mixed returns: no edge line is pulled; each pass's board stays within a few
// millimetres of the true one (a spacing's scatter on a share of the end
// points, some shrink from the blends), and the errors of 4-5 mrad come
// from the board's weak alpha / beta combination. Range errors: every sample
// moves along its own beam by offset + scale rho, so each pass's board moves
// back by the mean of that times |n . d| (d the beam, n the board's normal),
// about 7 mm near and 17 mm far: it does not cancel between the passes.
TEST(RefinedCornersTest, AtTheTrueAnglesEachEffectMovesTheBoardAsModelled) {
  const double thickness = sim::LabTargetThickness(sim::LabTarget::kDiamond);
  const EdgeDrive mixed = SimulateEdgeDrive(0.5, /*range_errors=*/false);
  for (int k = 0; k < 2; ++k) {
    BoardCorners b;
    ASSERT_TRUE(FitBoardCorners(mixed.board[k], mixed.config.geometry, kSetB, thickness, &b).ok());
    for (int j = 0; j < 4; ++j) {
      EXPECT_LT((b.corners[j] - kDiamondCorners[j]).norm(), 0.005) << "pass " << k << " corner " << j;
    }
    EXPECT_NEAR(b.size_m.x(), 0.6, 0.007) << k;
    EXPECT_NEAR(b.size_m.y(), 0.6, 0.007) << k;
  }
  const EdgeDrive ranged = SimulateEdgeDrive(0.0, /*range_errors=*/true);
  const Rigid3d body_from_lidar = BodyFromLidar(ranged.config.geometry, kSetB);
  double shift[2];
  for (int k = 0; k < 2; ++k) {
    BoardCorners b;
    ASSERT_TRUE(FitBoardCorners(ranged.board[k], ranged.config.geometry, kSetB, thickness, &b).ok());
    double moved = 0.0, predicted = 0.0;
    for (int j = 0; j < 4; ++j) moved += (0.16 - b.corners[j].y()) / 4.0;
    int n = 0;
    for (const auto& o : ranged.board[k]) {
      const Eigen::Vector3d p = ProjectObservation(o, ranged.config.geometry, kSetB);
      if (std::abs(p.y() - 0.16) > 0.03 || std::abs(p.x() - 5.0) + std::abs(p.z() - 1.35) > 0.4) continue;
      const Eigen::Vector3d d = (p - (o.world_from_body * body_from_lidar).translation()).normalized();
      const double rho = o.p_lidar.norm() - ranged.config.lidar.range_offset_m;
      predicted += (ranged.config.lidar.range_offset_m + ranged.config.lidar.range_scale_error * rho) *
                   std::abs(d.y());
      ++n;
    }
    ASSERT_GT(n, 100);
    predicted /= n;
    std::printf("[calib] range errors, pass %d: board moved back %.1f mm, predicted %.1f mm\n", k,
                1e3 * moved, 1e3 * predicted);
    EXPECT_NEAR(moved, predicted, 0.002) << k;
    shift[k] = moved;
  }
  EXPECT_GT(std::abs(shift[1] - shift[0]), 0.005);
}

// The simulator's mixed returns at the board's edges against its own truth
// (docs/calibration.md, "The simulator's \"other surface\" returns"): every
// straddling beam mixed, none blended (p = 1, b = 0), one turn, noise and
// dropouts off, at the true angles. The straddling beam is a line's last hit
// or its first miss; reported at the other surface's range it makes the
// line a beam short or long. Both must happen at both ends of a line, in
// both passes, and each end point (the outermost hit's beam and the next one
// beyond it, crossed with the board: their midpoint) must then lie within
// (1/2, 1) spacing of the edge, outside for a long line and inside for a
// short one, and within 1/2 for a clean one. Until 2026-11-27 the spot's
// sides were rays from the lidar's centre: on this drive half the near
// pass's line ends had no straddling beam, only 2 of 46 lower and 8 of 46
// upper ends were long, and their returns did not lie on the board turned
// back (this test failed on the near pass). A long
// return is the board's part of the spot: its range is that part's
// distance, so turned back by half the footprint about the centre it lies on
// the board, and it lies off the board's plane by its range x footprint / 2 x
// |n . t| (t the scan plane's tangent, n the board's normal; the comment
// above SimWorld::MixedRange).
TEST(EdgeEffectsSimTest, OtherSurfaceReturnsStraddleBothEndsOfALine) {
  sim::SimConfig c = testing::CircleConfig(21);
  c.scene = sim::LabScene(sim::LabTarget::kDiamond);
  c.path = {CircleSegment(0.83, 0.05, 1.0, /*left=*/true)};
  c.mounting_error = kSetB;
  c.lidar.mixed_return_share = 1.0;
  c.lidar.mixed_blend_share = 0.0;
  c.lidar.range_noise_m = c.lidar.range_noise_fraction = c.lidar.range_quantum_m = 0.0;
  c.lidar.dropout_probability = 0.0;
  const double thickness = sim::LabTargetThickness(sim::LabTarget::kDiamond);
  const double half_footprint = 0.5 * c.lidar.mixed_footprint_rad;
  sim::SimWorld world(c);
  world.KeepSampleTruth(true);
  const SensorLog log = world.RunAll();
  const int target = c.scene.Find("target");
  ASSERT_GE(target, 0);
  const auto on_board = [](const Eigen::Vector3d& p) {
    return std::abs(p.y() - 0.16) < 0.012 &&
           std::abs(p.x() - 5.0) + std::abs(p.z() - 1.35) < kHalfDiagonal + 0.05;
  };
  // [pass: near, far][end: lower, upper]
  struct Ends {
    int lines = 0, longer = 0, shorter = 0, clean = 0, misplaced = 0, off_board = 0;
    double shift_min[3] = {9, 9, 9}, shift_max[3] = {-9, -9, -9};  // long, short, clean
    double off_plane_min = 1.0, off_plane_max = 0.0, off_plane_error = 0.0;
  } ends[2][2];
  size_t first = 0;
  for (const auto& scan : log.scans) {
    const size_t n = scan.samples.size();
    const size_t base = first;
    first += n;
    std::vector<Eigen::Vector3d> p(n);
    std::vector<bool> on(n, false);
    for (size_t i = 0; i < n; ++i) {
      const LidarSample& s = scan.samples[i];
      if (s.range_m <= 0.0f) continue;
      p[i] = world.TrueWorldFromLidar(s.time) * LidarPoint(s.range_m, s.theta);
      on[i] = on_board(p[i]);
    }
    // The line's longest run of board samples, clear of the top and bottom
    // corners (where both ends meet).
    size_t i0 = 0, i1 = 0, best = 0;
    for (size_t i = 0, start = 0; i < n; ++i) {
      if (!on[i]) {
        start = i + 1;
        continue;
      }
      if (i + 1 - start > best) best = i + 1 - start, i0 = start, i1 = i;
    }
    if (best < 8 || i0 < 3 || i1 + 3 >= n) continue;
    if (std::abs(0.5 * (p[i0].x() + p[i1].x()) - 5.0) < 0.04) continue;
    const Rigid3d w = world.TrueWorldFromLidar(scan.samples[i0].time);
    const int pass = w.translation().y() > 1.7 ? 1 : 0;
    const double step = (scan.samples[i1].theta - scan.samples[i0].theta) / double(i1 - i0);
    for (int side : {-1, 1}) {
      const size_t k = side < 0 ? i0 : i1;
      Ends& e = ends[pass][p[k].z() > 0.5 * (p[i0].z() + p[i1].z()) ? 1 : 0];
      const double theta_k = scan.samples[k].theta;
      // The edge along this line: where the centre's rays stop hitting the
      // board (front or edge face), by bisection over +-2 beams.
      const Rigid3d wk = world.TrueWorldFromLidar(scan.samples[k].time);
      const auto hits = [&](double theta) {
        sim::RayHit h;
        return c.scene.Cast(wk.translation(), wk.rotation() * LidarPoint(1.0, theta), 1e-6, 10.0, &h) &&
               h.primitive == target;
      };
      double in = theta_k - 2 * side * step, out = theta_k + 2 * side * step;
      if (!hits(in) || hits(out)) continue;
      for (int it = 0; it < 50; ++it) {
        const double mid = 0.5 * (in + out);
        (hits(mid) ? in : out) = mid;
      }
      const double shift = (theta_k + 0.5 * side * step - in) / (side * step);
      const sim::SampleTruth& last = world.sample_truth()[base + k];
      const sim::SampleTruth& next = world.sample_truth()[base + k + side];
      int kind = 2;
      if (last.mixed && last.primitive != target) {
        kind = 0;
        ++e.longer;
        // The board's part of the spot: this range, half the footprint
        // either way along the scan.
        const double range = scan.samples[k].range_m;
        double d = 1.0;
        for (double a : {-half_footprint, half_footprint}) {
          d = std::min(d, c.scene.DistanceToSurface(wk * LidarPoint(range, theta_k + a)));
        }
        e.off_board += d > 1e-3;
        const Eigen::Vector3d t = wk.rotation() * LidarPoint(1.0, theta_k + M_PI / 2);
        const double off = std::abs(p[k].y() - 0.16);
        const double predicted = range * half_footprint * std::abs(t.y());
        e.off_plane_min = std::min(e.off_plane_min, off);
        e.off_plane_max = std::max(e.off_plane_max, off);
        e.off_plane_error = std::max(e.off_plane_error, std::abs(off - predicted));
      } else if (next.mixed && next.primitive == target) {
        kind = 1;
        ++e.shorter;
      } else {
        ++e.clean;
      }
      ++e.lines;
      e.shift_min[kind] = std::min(e.shift_min[kind], shift);
      e.shift_max[kind] = std::max(e.shift_max[kind], shift);
      const double lo[3] = {0.5, -1.0, -0.5}, hi[3] = {1.0, -0.5, 0.5};
      e.misplaced += shift < lo[kind] - 0.05 || shift > hi[kind] + 0.05;
    }
  }
  for (int pass = 0; pass < 2; ++pass) {
    for (int end = 0; end < 2; ++end) {
      const Ends& e = ends[pass][end];
      std::printf("[sim] %s pass, %s ends: %d lines, %d long (%+.2f..%+.2f), %d short "
                  "(%+.2f..%+.2f), %d clean (%+.2f..%+.2f), %d misplaced; long returns "
                  "%.1f-%.1f mm off the board's plane (model within %.2f mm)\n",
                  pass ? "far" : "near", end ? "upper" : "lower", e.lines, e.longer,
                  e.shift_min[0], e.shift_max[0], e.shorter, e.shift_min[1], e.shift_max[1],
                  e.clean, e.shift_min[2], e.shift_max[2], e.misplaced, 1e3 * e.off_plane_min,
                  1e3 * e.off_plane_max, 1e3 * e.off_plane_error);
      const std::string where = std::string(pass ? "far" : "near") + (end ? " upper" : " lower");
      EXPECT_GT(e.lines, 20) << where;
      // Each line's straddling beam is its last hit or its first miss, about
      // half the time each.
      EXPECT_GT(e.longer, e.lines / 4) << where;
      EXPECT_GT(e.shorter, e.lines / 4) << where;
      EXPECT_LT(e.clean, e.lines / 10) << where;  // the footprint is one beam step
      EXPECT_EQ(e.misplaced, 0) << where;
      EXPECT_EQ(e.off_board, 0) << where;
      // Off the plane as modelled (a side on the lower edges' 5 mm face
      // lies behind the front by up to that).
      EXPECT_LT(e.off_plane_error, thickness + 0.0005) << where;
    }
  }
}

}  // namespace
}  // namespace sweepscan
