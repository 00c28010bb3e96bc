#include "core/pose/pose_estimator.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

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

const char* PoseGapRecoveryName(PoseGap::Recovery recovery) {
  switch (recovery) {
    case PoseGap::Recovery::kImuHeading:
      return "imu-heading";
    case PoseGap::Recovery::kHeld:
      return "held";
  }
  return "unknown";
}

std::string FormatPoseGap(const PoseGap& gap, Time origin) {
  char line[256];
  const char* how = gap.recovery == PoseGap::Recovery::kImuHeading
                        ? "pose after it from the IMU heading, position held"
                        : "pose after it held (heading and position)";
  std::snprintf(line, sizeof(line), "gap at %.1f s: %.1f s without data; %s (+-%.2f m)%s; %zu lidar samples dropped",
                ToSeconds(gap.begin - origin), gap.length_s, how, gap.position_sigma_m,
                gap.turned_beyond_bound ? ", turned beyond the bound" : "", gap.samples_dropped);
  return line;
}

void PoseEstimator::SmoothPoses() {
  if (!options_.smooth || options_.source != PoseSource::kEkf || !ekf_.initialized()) return;
  PoseBuffer smoothed;
  size_t g = 0;  // the next gap
  for (const PoseEkf::Estimate& e : ekf_.Smooth()) {
    // The same poses as the filter stored: none from a gap's end until its
    // first pose (the heading re-established), that one marked after_gap.
    bool after_gap = false, skip = false;
    while (g < gaps_.size() && e.time > gaps_[g].begin) {
      const PoseGap& gap = gaps_[g];
      if (gap.has_first_pose && e.time >= gap.first_pose) {
        after_gap = true;
        ++g;
      } else if (!gap.has_first_pose && g + 1 < gaps_.size()) {
        ++g;  // superseded by the next gap before a pose was stored
      } else {
        skip = true;
        break;
      }
    }
    if (skip) continue;
    const PoseEkf::State& s = e.state;
    smoothed.Add(e.time,
                 Rigid3d::FromPose(s[PoseEkf::kX], s[PoseEkf::kY], 0.0, s[PoseEkf::kRoll],
                                   s[PoseEkf::kPitch], s[PoseEkf::kPsi]),
                 after_gap);
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
  if (awaiting_heading_) return;  // after a gap, until the first IMU yaw
  const bool after_gap = next_pose_after_gap_;
  if (options_.source == PoseSource::kOdometry) {
    const Pose2d& p = odometry_.pose();
    poses_.Add(time, Rigid3d::FromPose(p.x, p.y, 0.0, 0.0, 0.0, p.yaw), after_gap);
  } else {
    poses_.Add(time, ekf_.WorldFromBody(), after_gap);
  }
  if (after_gap) {
    next_pose_after_gap_ = false;
    gaps_.back().first_pose = time;
    gaps_.back().has_first_pose = true;
  }
}

void PoseEstimator::CheckGap(Time time) {
  if (!have_last_record_) {
    have_last_record_ = true;
    last_record_ = time;
    return;
  }
  if (ToSeconds(time - last_record_) > options_.max_gap_s) BeginAfterGap(last_record_, time);
  if (time > last_record_) last_record_ = time;
}

// The bound (docs/models.md, "Gaps in the data"): a wheel at speed u when
// the data stops keeps it for at most the watchdog's t_w, then brakes at
// >= a towards 0 (never past it), so it rolls at most
//   s(u) = |u| t_w + u^2 / (2 a)
// in the direction of u. The body origin midway between the wheels moves
// at |v_l + v_r| / 2 <= (|v_l| + |v_r|) / 2, so it travels at most
//   D = (s_l + s_r) / 2,
// and the heading changes by (Delta s_r - Delta s_l) / (2 d): with both
// wheels turning the same way each Delta s_i lies in [0, s_i] (signed like
// u_i), so |Delta psi| <= max(s_l, s_r) / (2 d); turning in place (signs
// opposite) |Delta psi| <= (s_l + s_r) / (2 d). D and the turn bound, with
// their floors, are used as 1-sigma in P: the displacement is bounded by D,
// so its spread is smaller (a uniform disc of radius D has sigma D / 2 per
// axis), and the IMU yaw's gate at 3.3 sigma refuses only turns of over 3.3
// times the bound (then AddImu lets the heading go).
void PoseEstimator::BeginAfterGap(Time begin, Time end) {
  if (HoldingGyro()) EndStandstill();  // the readings before the gap were at rest
  if (awaiting_heading_) {  // a second gap before the first IMU yaw: held so far
    awaiting_heading_ = false;
    gaps_.back().recovery = PoseGap::Recovery::kHeld;
  }
  PoseGap gap;
  gap.begin = begin;
  gap.end = end;
  gap.first_pose = end;
  gap.length_s = ToSeconds(end - begin);
  const double d = geometry_.wheel_distance_m;
  double v_l = last_left_mps_, v_r = last_right_mps_;
  if (options_.source == PoseSource::kEkf) {
    const double v = ekf_.state()[PoseEkf::kV], w = ekf_.state()[PoseEkf::kW];
    v_l = v - w * d;
    v_r = v + w * d;
  }
  const double a = std::max(options_.gap_min_deceleration_mps2, 1e-3);  // > 0 by contract
  const auto rolled = [&](double u) { return std::abs(u) * options_.gap_watchdog_s + u * u / (2.0 * a); };
  const double s_l = rolled(v_l), s_r = rolled(v_r);
  const double wheel_turn = v_l * v_r >= 0.0 ? std::max(s_l, s_r) : s_l + s_r;
  gap.travel_bound_m = std::max(0.5 * (s_l + s_r), options_.gap_min_position_sigma_m);
  gap.turn_bound_rad = std::max(wheel_turn / (2.0 * d), options_.gap_min_heading_sigma_rad);
  gap.position_sigma_m = gap.travel_bound_m;
  gap.heading_sigma_rad = gap.turn_bound_rad;
  // Wheel odometry (also the EKF's companion) holds its pose: the next
  // wheel record integrates from the end of the gap, not across it.
  odometry_.Reset(end, odometry_.pose());
  if (options_.source == PoseSource::kEkf && ekf_.initialized()) {
    PoseEkf::GapReset reset;
    reset.position_sigma = gap.travel_bound_m;
    reset.heading_sigma = gap.turn_bound_rad;
    ekf_.ResumeAfterGap(end, reset);
    const PoseEkf::Covariance& p = ekf_.covariance();
    gap.position_sigma_m = std::sqrt(std::max(p(PoseEkf::kX, PoseEkf::kX), p(PoseEkf::kY, PoseEkf::kY)));
    gap.heading_sigma_rad = std::sqrt(p(PoseEkf::kPsi, PoseEkf::kPsi));
    awaiting_heading_ = options_.use_imu_yaw && ekf_.yaw_offset_known();
    if (awaiting_heading_) gap.recovery = PoseGap::Recovery::kImuHeading;
  }
  next_pose_after_gap_ = true;
  gaps_.push_back(gap);
}

void PoseEstimator::SettleAfterGap(PoseGap::Recovery recovery) {
  awaiting_heading_ = false;
  PoseGap& gap = gaps_.back();
  gap.recovery = recovery;
  if (options_.source == PoseSource::kEkf) {
    gap.heading_sigma_rad = std::sqrt(ekf_.covariance()(PoseEkf::kPsi, PoseEkf::kPsi));
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
  EndStandstill();
}

void PoseEstimator::EndStandstill() {
  // The wheels move (or a gap ends the standstill): seed g from the
  // standstill if it was long enough, then give the filter the readings
  // held since the last record at rest.
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
  CheckGap(m.time);
  TrackStandstill(m);
  if (!first) odometry_.Add(m);
  last_left_mps_ = m.left_mps;
  last_right_mps_ = m.right_mps;
  if (options_.source == PoseSource::kEkf) {
    const Twist2d t = TwistFromWheels(m.left_mps, m.right_mps, geometry_.wheel_distance_m);
    ekf_.UpdateWheels(m.time, t.v, t.w);
  }
  // No IMU yaw within max_gap_s of the gap's end (no attitude in the
  // records): the heading stays the held one.
  if (awaiting_heading_ && ToSeconds(m.time - gaps_.back().end) > options_.max_gap_s) {
    SettleAfterGap(PoseGap::Recovery::kHeld);
  }
  RecordPose(m.time);
}

void PoseEstimator::AddImu(const ImuMeasurement& m) {
  EnsureInitialized(m.time);
  CheckGap(m.time);
  if (options_.source == PoseSource::kOdometry) return;  // odometry alone ignores the IMU
  if (m.has_gyro && options_.use_imu_gyro) {
    if (HoldingGyro()) {
      pending_gyro_.emplace_back(m.time, m.gyro_z);  // at rest: w = 0, z = g + noise
    } else {
      ekf_.UpdateGyro(m.time, m.gyro_z);
    }
  }
  if (m.has_attitude) {
    if (options_.use_imu_yaw) {
      const bool accepted = ekf_.UpdateYaw(m.time, m.yaw);
      if (awaiting_heading_) {
        // The first yaw after a gap sets the heading (P_psipsi holds the
        // turn bound). Gated out, the robot turned by more than 3.3 times
        // the bound (carried?): the IMU's heading is still the reference,
        // so psi is let go (sigma pi) and the reading applied again.
        if (!accepted) {
          ekf_.InflateHeading(M_PI);
          ekf_.UpdateYaw(m.time, m.yaw);
          gaps_.back().turned_beyond_bound = true;
        }
        SettleAfterGap(PoseGap::Recovery::kImuHeading);
      }
    }
    if (options_.use_imu_tilt) ekf_.UpdateTilt(m.time, m.roll, m.pitch);
  }
  if (awaiting_heading_ && ToSeconds(m.time - gaps_.back().end) > options_.max_gap_s) {
    SettleAfterGap(PoseGap::Recovery::kHeld);
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
  // At most a pose a record (pages never written cost nothing).
  estimator.mutable_poses()->reserve(log.wheels.size() + log.imu.size() + 1);
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
