#include "core/sim/world.h"

#include <gtest/gtest.h>

#include "tests/testing/worlds.h"

namespace sweepscan::sim {
namespace {

TEST(WorldTest, LidarTimingMatchesTheX4) {
  const SimConfig c = testing::LabConfig();
  SimWorld world(c);
  const SensorLog log = world.RunAll();
  // 5 kHz samples, 7 Hz revolutions: about 714 samples a scan.
  const double duration = world.duration_s();
  EXPECT_NEAR(static_cast<double>(log.scans.size()), duration * 7.0, 2.0);
  for (size_t i = 1; i + 1 < log.scans.size(); ++i) {
    const auto& s = log.scans[i];
    EXPECT_NEAR(static_cast<double>(s.samples.size()), 5000.0 / 7.0, 1.0);
    EXPECT_EQ(s.index, i);
    EXPECT_NEAR(ToSeconds(s.samples[1].time - s.samples[0].time), 1.0 / 5000, 1e-9);
    EXPECT_EQ(s.samples.back().beam, s.samples.size() - 1);
  }
  size_t zero = 0, total = 0;
  for (const auto& s : log.scans) {
    for (const auto& smp : s.samples) {
      ++total;
      if (smp.range_m == 0.0f) {
        ++zero;
      } else {
        EXPECT_GE(smp.range_m, 0.12f);
        EXPECT_LE(smp.range_m, 10.0f);
        // Quantised to the X4's 1 mm.
        EXPECT_NEAR(smp.range_m * 1000.0, std::round(smp.range_m * 1000.0), 1e-3);
      }
    }
  }
  // Dropouts: 1 % at random plus grazing returns, not more than a few percent.
  EXPECT_GT(zero, total / 200);
  EXPECT_LT(zero, total / 10);
}

TEST(WorldTest, NoiseFreeRangesAreExactRayCasts) {
  SimConfig c = testing::LabConfig();
  testing::MakeNoiseFree(&c);
  c.mounting_error = {0.01, -0.02, 0.03};
  SimWorld world(c);
  world.KeepSampleTruth(true);
  const SensorLog log = world.RunAll();
  size_t k = 0, checked = 0;
  for (const auto& scan : log.scans) {
    for (const auto& s : scan.samples) {
      const SampleTruth& t = world.sample_truth()[k++];
      if (s.range_m == 0.0f || checked > 5000) continue;
      ++checked;
      // Re-derive the point from the true lidar pose at the sample's time.
      const Eigen::Vector3d p = world.TrueWorldFromLidar(s.time) * LidarPoint(s.range_m, s.theta);
      EXPECT_LT(c.scene.DistanceToSurface(p), 1e-5);
      EXPECT_NEAR(s.range_m, t.true_range, 1e-5);
    }
  }
  EXPECT_GT(checked, 5000u);
}

TEST(WorldTest, WheelScaleErrorAndImuHeadingReference) {
  SimConfig c = testing::LabConfig();
  testing::MakeNoiseFree(&c);
  c.odometry.scale_error_left = 0.01;
  SimWorld world(c);
  const SensorLog log = world.RunAll();
  ASSERT_GT(log.wheels.size(), 100u);
  // On the first straight (0.2 m/s) the left wheel reads 1 % high.
  EXPECT_NEAR(log.wheels[50].left_mps, 0.202, 1e-9);
  EXPECT_NEAR(log.wheels[50].right_mps, 0.2, 1e-9);
  // IMU heading = world yaw + its reference offset.
  EXPECT_NEAR(log.imu[10].yaw, c.imu.yaw_reference_offset_rad, 1e-12);
  // During the half turn the gyro reads 0.3 rad/s.
  EXPECT_NEAR(log.imu[4000].gyro_z, 0.3, 1e-12);
}

TEST(WorldTest, RunUntilInPiecesEqualsRunAll) {
  const SimConfig c = testing::CircleConfig(3);
  SimWorld whole(c), pieces(c);
  const SensorLog a = whole.RunAll();
  SensorLogCollector collector;
  for (double t = 1.0; !pieces.finished(); t += 0.0371) pieces.RunUntil(TimeFromSeconds(t), &collector);
  const SensorLog& b = *collector.log();
  ASSERT_EQ(a.scans.size(), b.scans.size());
  ASSERT_EQ(a.wheels.size(), b.wheels.size());
  ASSERT_EQ(a.imu.size(), b.imu.size());
  EXPECT_EQ(a.scans[10].samples[100].range_m, b.scans[10].samples[100].range_m);
  EXPECT_EQ(a.imu[77].yaw, b.imu[77].yaw);
}

TEST(WorldTest, TrajectoryIsExact) {
  const Trajectory t({0, 0, 0}, {{0.2, 0.0, 10.0}, {0.0, 0.5, M_PI}});
  EXPECT_NEAR(t.PoseAt(10.0).x, 2.0, 1e-12);
  EXPECT_NEAR(t.PoseAt(10.0 + M_PI).x, 2.0, 1e-12);
  EXPECT_NEAR(std::abs(t.PoseAt(10.0 + M_PI).yaw), M_PI / 2, 1e-12);
  EXPECT_NEAR(t.TwistAt(11.0).w, 0.5, 1e-12);
  EXPECT_NEAR(t.TwistAt(100.0).v, 0.0, 1e-12);
}

// A robot standing 1 m in front of a board (the scan plane crosses it
// from 0.8 to 1.4 m high) with the room's wall 4 m behind it: every scan
// crosses two depth edges of more than 3 m. Noise-free, so any reported
// range that is not the beam's own surface is a mixed return.
SimConfig BoardBeforeAWall(double seconds) {
  SimConfig c = testing::LabConfig();
  testing::MakeNoiseFree(&c);
  c.lidar.grazing_dropout_start_deg = 89.0;
  c.lidar.grazing_dropout_end_deg = 90.0;
  Box room;
  room.label = "room";
  room.center = {5.0, 5.0, 1.5};
  room.size = {10.0, 10.0, 3.0};
  room.inside = true;
  Box board;
  board.label = "board";
  board.center = {5.0, 6.01, 1.1};
  board.size = {1.0, 0.02, 0.6};
  c.scene = Scene({room, board});
  c.mounting_error = {};
  c.start = {5.0, 5.0, 0.0};
  c.path = {{0.0, 0.0, seconds}};
  return c;
}

struct EdgeCounts {
  size_t scans = 0, valid = 0, edge = 0, mixed = 0, off_surface = 0, blended = 0,
         blended_off_surface = 0, other = 0, other_near_surface = 0;
};

// Counts the edge beams and mixed returns of a run, and checks each
// sample's range against its truth: a plain return reads its surface's
// range, a mixed one lies between its two surfaces' ranges.
EdgeCounts CountEdges(const SimConfig& c) {
  SimWorld world(c);
  world.KeepSampleTruth(true);
  const SensorLog log = world.RunAll();
  EdgeCounts n;
  n.scans = log.scans.size();
  size_t k = 0;
  for (const auto& scan : log.scans) {
    for (const auto& s : scan.samples) {
      const SampleTruth& t = world.sample_truth()[k++];
      n.edge += t.edge;
      n.mixed += t.mixed;
      if (s.range_m == 0.0f) continue;
      ++n.valid;
      const Eigen::Vector3d p = world.TrueWorldFromLidar(s.time) * LidarPoint(s.range_m, s.theta);
      n.off_surface += c.scene.DistanceToSurface(p) > 0.01;
      if (!t.mixed) {
        EXPECT_NEAR(s.range_m, t.true_range, 1e-4);
        continue;
      }
      EXPECT_TRUE(t.edge);
      EXPECT_GT(std::abs(t.other_range - t.true_range), c.lidar.mixed_min_jump_m);
      EXPECT_GE(s.range_m, std::min(t.true_range, t.other_range) - 1e-4);
      EXPECT_LE(s.range_m, std::max(t.true_range, t.other_range) + 1e-4);
      const bool blend = std::abs(s.range_m - t.true_range) > 1e-3 &&
                         std::abs(s.range_m - t.other_range) > 1e-3;
      n.blended += blend;
      n.blended_off_surface += blend && c.scene.DistanceToSurface(p) > 0.01;
      if (std::abs(s.range_m - t.other_range) <= 1e-3) {
        ++n.other;
        // The other surface's part of the spot, decoded on the beam's own
        // laser line at its range: that part turned about the centre by
        // half the footprint, so within range x footprint / 2 of it.
        n.other_near_surface +=
            c.scene.DistanceToSurface(p) < 0.5 * c.lidar.mixed_footprint_rad * t.other_range + 1e-3;
      }
    }
  }
  return n;
}

TEST(WorldTest, NoMixedReturnsByDefault) {
  const EdgeCounts n = CountEdges(BoardBeforeAWall(3.0));
  EXPECT_GT(n.valid, 10000u);
  EXPECT_EQ(n.edge, 0u);  // not even looked for
  EXPECT_EQ(n.mixed, 0u);
  EXPECT_EQ(n.off_surface, 0u);
}

TEST(WorldTest, MixedReturnsAtDepthEdges) {
  SimConfig c = BoardBeforeAWall(10.0);
  c.lidar.mixed_return_share = 0.4;
  c.lidar.mixed_blend_share = 0.5;
  const EdgeCounts n = CountEdges(c);
  // About one beam per edge crossing straddles it (the footprint is one
  // beam step): two per scan on the board, and one where the scan meets the
  // floor at the far wall 5 m off (the floor's range recedes ~0.2 m over
  // half a step at that grazing incidence, so the rule takes the concave
  // corner for an edge). Until 2026-11-27 there were 2.4 a scan in all:
  // the spot's sides were the centre's rays, skewed by half a step against
  // the laser's line, and a straddling beam whose own return was shadowed
  // from the centre was lost unlooked-at (docs/calibration.md, "The
  // simulator's \"other surface\" returns").
  const double per_scan = static_cast<double>(n.edge) / n.scans;
  EXPECT_GT(per_scan, 2.5);
  EXPECT_LT(per_scan, 3.5);
  // The drawn share of them is mixed (binomial, ~220 edge beams: sd 0.03).
  const double share = static_cast<double>(n.mixed) / n.edge;
  EXPECT_NEAR(share, 0.4, 0.13) << n.mixed << " of " << n.edge;
  // About half of those blend (strictly between the two ranges, sd 0.07).
  EXPECT_NEAR(static_cast<double>(n.blended) / n.mixed, 0.5, 0.22) << n.blended;
  // Only mixed returns land off every surface: a blend in the air between
  // the surfaces (nearly all of them more than 1 cm off); one at the other
  // surface's range beside that surface, within half a footprint of it
  // (beyond the board's edge by up to a beam, or on the wall in the
  // board's shadow).
  EXPECT_LE(n.off_surface, n.mixed);
  EXPECT_GE(n.blended_off_surface, n.blended * 8 / 10);
  EXPECT_GT(n.other, 10u);
  EXPECT_EQ(n.other_near_surface, n.other);
}

TEST(WorldTest, EveryEdgeBeamMixedWithoutBlending) {
  SimConfig c = BoardBeforeAWall(3.0);
  c.lidar.mixed_return_share = 1.0;
  c.lidar.mixed_blend_share = 0.0;
  const EdgeCounts n = CountEdges(c);
  EXPECT_GT(n.edge, n.scans);
  EXPECT_EQ(n.mixed, n.edge);
  EXPECT_EQ(n.blended, 0u);  // each reports the other surface's range
}

TEST(WorldTest, RangeScaleErrorAndOffset) {
  SimConfig c = testing::LabConfig();
  testing::MakeNoiseFree(&c);
  c.lidar.range_scale_error = 0.01;  // 1 %, the X4 data sheet's bound beyond 2 m
  c.lidar.range_offset_m = 0.006;
  c.path = {{0.2, 0.1, 2.0}};
  SimWorld world(c);
  world.KeepSampleTruth(true);
  const SensorLog log = world.RunAll();
  size_t k = 0, checked = 0, long_ranges = 0;
  for (const auto& scan : log.scans) {
    for (const auto& s : scan.samples) {
      const SampleTruth& t = world.sample_truth()[k++];
      if (s.range_m == 0.0f) continue;
      ++checked;
      long_ranges += t.true_range > 3.0;
      EXPECT_NEAR(s.range_m, 1.01 * t.true_range + 0.006, 1e-5) << t.true_range;
    }
  }
  EXPECT_GT(checked, 5000u);
  EXPECT_GT(long_ranges, 100u);  // where a 1 % scale error is 3 cm
}

TEST(WorldTest, ConfigValidation) {
  SimConfig c = testing::LabConfig();
  std::string error;
  EXPECT_TRUE(c.IsValid(&error)) << error;
  c.lidar.max_range_m = 0.1;
  EXPECT_FALSE(c.IsValid(&error));
  c = testing::LabConfig();
  c.path.clear();
  EXPECT_FALSE(c.IsValid(&error));
  c = testing::LabConfig();
  c.lidar.range_scale_error = 0.2;
  EXPECT_FALSE(c.IsValid(&error));
  c = testing::LabConfig();
  c.lidar.mixed_return_share = 1.5;
  EXPECT_FALSE(c.IsValid(&error));
}

}  // namespace
}  // namespace sweepscan::sim
