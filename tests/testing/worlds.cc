#include "tests/testing/worlds.h"

#include <gtest/gtest.h>

#include "core/scenario/scenario.h"

namespace sweepscan::testing {

sim::SimConfig LabConfig(uint64_t seed) {
  sim::SimConfig c;
  c.name = "lab";
  c.seed = seed;
  c.scene = sim::LabScene();
  c.start = {1.5, 2.5, 0.0};
  c.path = {{0.2, 0.0, 35.0},            // 7 m along the room
            {0.0, 0.3, M_PI / 0.3},      // half turn in place at x = 8.5
            {0.2, 0.0, 10.0}};           // 2 m back
  return c;
}

sim::SimConfig GapDriveConfig(uint64_t seed) {
  sim::SimConfig c = LabConfig(seed);
  c.start = {2.0, 2.5, 0.0};
  c.path = {{0.0, 0.0, 2.0}, {0.3, 0.0, 6.0}, {0.3, 0.3, 2.0},
            {0.0, 0.0, 10.0}, {0.3, 0.0, 5.0}, {0.2, -0.3, 3.0}};
  return c;
}

sim::SimConfig CircleConfig(uint64_t seed) {
  sim::SimConfig c;
  c.name = "lab-circle";
  c.seed = seed;
  c.scene = sim::LabScene();
  // Start on the circle's west side heading south, counter-clockwise about
  // the centre (5, 1.7): the near pass of the target comes a quarter turn
  // later, the far pass (seen through the centre) three quarters later.
  c.start = {5.0 - 0.83, 1.7, -M_PI / 2};
  c.path = {CircleSegment(0.83, 0.2, 1.0, /*left=*/true)};
  return c;
}

sim::SimConfig BuildingConfig(char drive, uint64_t seed) {
  sim::SimConfig c;
  c.name = std::string("building_") + drive;
  c.seed = seed;
  c.scene = sim::OfficeFloorScene();
  const double turn = 2 * M_PI / 0.3, quarter = 0.5 * M_PI / 0.3;
  const sim::DriveSegment rest{0.0, 0.0, 1.0}, spin{0.0, 0.3, turn}, left{0.0, 0.3, quarter};
  if (drive == 'a') {
    c.start = {2.45, 5.0, -M_PI / 2};
    c.path = {rest, spin, {0.2, 0.0, 20.0}, left, {0.2, 0.0, 25.0}, left, {0.2, 0.0, 20.0}, spin};
  } else if (drive == 'b') {
    c.start = {7.45, 4.0, -M_PI / 2};
    c.path = {rest, spin, {0.2, 0.0, 15.0}, left, {0.2, 0.0, 27.5}, left, {0.2, 0.0, 20.0}, spin};
  } else {
    c.start = {1.0, 1.0, 0.0};
    c.path = {rest, {0.25, 0.0, 56.0}};
  }
  return c;
}

void MakeNoiseFree(sim::SimConfig* c) {
  c->lidar.range_noise_m = 0.0;
  c->lidar.range_noise_fraction = 0.0;
  c->lidar.range_quantum_m = 0.0;
  c->lidar.dropout_probability = 0.0;
  c->imu.gyro_noise_rad_s = 0.0;
  c->imu.gyro_bias_rad_s = 0.0;
  c->imu.tilt_noise_rad = 0.0;
  c->imu.yaw_noise_rad = 0.0;
  c->odometry.scale_error_left = 0.0;
  c->odometry.scale_error_right = 0.0;
  c->odometry.speed_noise_mps = 0.0;
  c->slips.clear();
}

ReconstructionResult SimulateAndReconstruct(const sim::SimConfig& config, PoseSource source,
                                            bool deskew, const MountingError& calibration,
                                            bool ekf_gyro_bias) {
  sim::SimWorld world(config);
  const SensorLog log = world.RunAll();
  const PoseBuffer truth = world.TruthPoses(1000.0);
  ReconstructionOptions options;
  options.pose.source = source;
  options.pose.initial_pose = config.start;
  options.assembly.deskew = deskew;
  options.calibration = calibration;
  options.pose.ekf.estimate_gyro_bias = ekf_gyro_bias;
  ReconstructionResult result;
  const Status s = Reconstruct(log, config.geometry, options, &truth, &result);
  EXPECT_TRUE(s.ok()) << s.message();
  return result;
}

}  // namespace sweepscan::testing
