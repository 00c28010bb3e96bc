#include "core/pose/pose_estimator.h"

#include <algorithm>
#include <cmath>

namespace sweepscan {

const char* PoseSourceName(PoseSource source) {
  switch (source) {
    case PoseSource::kEkf:
      return "ekf";
    case PoseSource::kOdometry:
      return "odometry";
    case PoseSource::kTruth:
      return "truth";
    case PoseSource::kSfm:
      return "sfm";
  }
  return "unknown";
}

bool ParsePoseSource(const std::string& name, PoseSource* source) {
  for (PoseSource s : {PoseSource::kEkf, PoseSource::kOdometry, PoseSource::kTruth, PoseSource::kSfm}) {
    if (name == PoseSourceName(s)) {
      *source = s;
      return true;
    }
  }
  return false;
}

PoseEstimator::PoseEstimator(const PoseEstimatorOptions& options, const RobotGeometry& geometry)
    : options_(options), geometry_(geometry), ekf_(options.ekf), odometry_(geometry.wheel_distance_m) {
  ekf_.KeepHistory(options.smooth && options.source == PoseSource::kEkf);
}

void PoseEstimator::SmoothPoses() {
  if (!options_.smooth || options_.source != PoseSource::kEkf || !ekf_.initialized()) return;
  PoseBuffer smoothed;
  for (const PoseEkf::Estimate& e : ekf_.Smooth()) {
    const PoseEkf::State& s = e.state;
    smoothed.Add(e.time, Rigid3d::FromPose(s[PoseEkf::kX], s[PoseEkf::kY], 0.0, s[PoseEkf::kRoll],
                                           s[PoseEkf::kPitch], s[PoseEkf::kPsi]));
  }
  poses_ = std::move(smoothed);
}

void PoseEstimator::EnsureInitialized(Time time) {
  if (odometry_.initialized()) return;
  odometry_.Reset(time, options_.initial_pose);
  PoseEkf::State s = PoseEkf::State::Zero();
  s[PoseEkf::kX] = options_.initial_pose.x;
  s[PoseEkf::kY] = options_.initial_pose.y;
  s[PoseEkf::kPsi] = options_.initial_pose.yaw;
  // The start pose defines the world frame: tiny position/yaw uncertainty,
  // velocity unknown within a walking pace, tilt within a few degrees.
  // The gyro bias within the HI219's turn-on range (gyro_bias_prior_sigma)
  // until a standstill measures it.
  PoseEkf::State var;
  const double g = options_.ekf.gyro_bias_prior_sigma;
  var << 1e-8, 1e-8, 1e-8, 0.25, 0.25, 0.003, 0.003, 1.0, g * g;
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

bool PoseEstimator::HoldingGyro() const {
  return phase_ == StartPhase::kStill && options_.gyro_bias_from_standstill &&
         options_.ekf.estimate_gyro_bias && options_.source != PoseSource::kOdometry;
}

void PoseEstimator::TrackStandstill(const WheelSpeedMeasurement& m) {
  if (phase_ == StartPhase::kMoved) return;
  const bool still = std::abs(m.left_mps) <= options_.standstill_max_wheel_mps &&
                     std::abs(m.right_mps) <= options_.standstill_max_wheel_mps;
  if (still) {
    if (phase_ == StartPhase::kNoWheels) still_begin_ = m.time;
    phase_ = StartPhase::kStill;
    still_end_ = m.time;
    standstill_s_ = ToSeconds(still_end_ - still_begin_);
    // The record is the mean speed over the period that ends at m.time, so
    // held readings before m.time were taken at rest; one at m.time itself
    // may be the first instant of the motion (an instantaneous rate) and
    // waits for the next record.
    for (const auto& [t, z] : pending_gyro_) {
      if (t < m.time) gyro_sum_ += z, ++gyro_count_;
    }
    pending_gyro_.erase(std::remove_if(pending_gyro_.begin(), pending_gyro_.end(),
                                       [&](const auto& r) { return r.first < m.time; }),
                        pending_gyro_.end());
    return;
  }
  // The wheels move: seed g from the standstill if it was long enough, then
  // give the filter the readings held since the last record at rest.
  const bool holding = HoldingGyro();
  phase_ = StartPhase::kMoved;
  if (holding && standstill_s_ >= options_.standstill_min_s && gyro_count_ > 0) {
    const double sigma = options_.ekf.gyro_sigma;
    ekf_.SetGyroBias(gyro_sum_ / gyro_count_, sigma * sigma / gyro_count_);
    gyro_bias_seeded_ = true;
  }
  for (const auto& [t, z] : pending_gyro_) ekf_.UpdateGyro(t, z);
  pending_gyro_.clear();
}

void PoseEstimator::AddWheels(const WheelSpeedMeasurement& m) {
  const bool first = !odometry_.initialized();
  EnsureInitialized(m.time);
  TrackStandstill(m);
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
  if (m.has_gyro && options_.use_imu_gyro) {
    if (HoldingGyro()) {
      pending_gyro_.emplace_back(m.time, m.gyro_z);  // at rest: w = 0, z = g + noise
    } else {
      ekf_.UpdateGyro(m.time, m.gyro_z);
    }
  }
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
  estimator.SmoothPoses();
  return estimator;
}

}  // namespace sweepscan
