#include "core/pose/pose_estimator.h"

namespace sweepscan {

const char* PoseSourceName(PoseSource source) {
  switch (source) {
    case PoseSource::kEkf:
      return "ekf";
    case PoseSource::kOdometry:
      return "odometry";
    case PoseSource::kTruth:
      return "truth";
  }
  return "unknown";
}

bool ParsePoseSource(const std::string& name, PoseSource* source) {
  for (PoseSource s : {PoseSource::kEkf, PoseSource::kOdometry, PoseSource::kTruth}) {
    if (name == PoseSourceName(s)) {
      *source = s;
      return true;
    }
  }
  return false;
}

PoseEstimator::PoseEstimator(const PoseEstimatorOptions& options, const RobotGeometry& geometry)
    : options_(options), geometry_(geometry), ekf_(options.ekf), odometry_(geometry.wheel_distance_m) {}

void PoseEstimator::EnsureInitialized(Time time) {
  if (odometry_.initialized()) return;
  odometry_.Reset(time, options_.initial_pose);
  PoseEkf::State s = PoseEkf::State::Zero();
  s[PoseEkf::kX] = options_.initial_pose.x;
  s[PoseEkf::kY] = options_.initial_pose.y;
  s[PoseEkf::kPsi] = options_.initial_pose.yaw;
  // The start pose defines the world frame: tiny position/yaw uncertainty,
  // velocity unknown within a walking pace, tilt within a few degrees.
  PoseEkf::State var;
  var << 1e-8, 1e-8, 1e-8, 0.25, 0.25, 0.003, 0.003, 1.0;
  ekf_.Initialize(time, s, var.asDiagonal());
}

void PoseEstimator::RecordPose(Time time) {
  if (options_.source == PoseSource::kOdometry) {
    const Pose2d& p = odometry_.pose();
    poses_.Add(time, Rigid3d::FromPose(p.x, p.y, 0.0, 0.0, 0.0, p.yaw));
  } else {
    poses_.Add(time, ekf_.WorldFromBody());
  }
}

void PoseEstimator::AddWheels(const WheelSpeedMeasurement& m) {
  const bool first = !odometry_.initialized();
  EnsureInitialized(m.time);
  if (!first) odometry_.Add(m);
  if (options_.source == PoseSource::kEkf) {
    const Twist2d t = TwistFromWheels(m.left_mps, m.right_mps, geometry_.wheel_distance_m);
    ekf_.UpdateWheels(m.time, t.v, t.w);
  }
  RecordPose(m.time);
}

void PoseEstimator::AddImu(const ImuMeasurement& m) {
  EnsureInitialized(m.time);
  if (options_.source == PoseSource::kOdometry) return;  // odometry alone ignores the IMU
  if (m.has_gyro && options_.use_imu_gyro) ekf_.UpdateGyro(m.time, m.gyro_z);
  if (m.has_attitude) {
    if (options_.use_imu_yaw) ekf_.UpdateYaw(m.time, m.yaw);
    if (options_.use_imu_tilt) ekf_.UpdateTilt(m.time, m.roll, m.pitch);
  }
  RecordPose(m.time);
}

Pose2d PoseEstimator::LatestPose2d() const {
  if (options_.source == PoseSource::kOdometry) return odometry_.pose();
  const auto& s = ekf_.state();
  return {s[PoseEkf::kX], s[PoseEkf::kY], s[PoseEkf::kPsi]};
}

PoseEstimator EstimatePoses(const SensorLog& log, const PoseEstimatorOptions& options,
                            const RobotGeometry& geometry) {
  PoseEstimator estimator(options, geometry);
  size_t i = 0, j = 0;
  while (i < log.wheels.size() || j < log.imu.size()) {
    // On equal times the IMU goes first: the gyro is the better yaw-rate
    // sensor, so a slipping wheel is then judged (and gated) against it
    // rather than the other way round.
    const bool take_wheel =
        j >= log.imu.size() || (i < log.wheels.size() && log.wheels[i].time < log.imu[j].time);
    if (take_wheel) {
      estimator.AddWheels(log.wheels[i++]);
    } else {
      estimator.AddImu(log.imu[j++]);
    }
  }
  return estimator;
}

}  // namespace sweepscan
