// Turns wheel and IMU records into a PoseBuffer of world_from_body, either by
// the EKF (odometry + IMU) or by wheel odometry alone, for comparison.
//
// Measurements from the two streams must be fed in time order (the caller
// merges them; EstimatePoses does it for a whole SensorLog). The IMU yaw has
// its own heading reference; the EKF estimates its offset (state b).
//
// Gyro bias from a standstill: while the wheels report zero speed (both
// |v_l|, |v_r| <= standstill_max_wheel_mps) from the first wheel record on,
// the robot cannot turn, so the gyro reads only its bias and noise:
//   g0 = mean(z_gyro),  var(g0) = gyro_sigma^2 / n        (n readings)
// Those readings are held back from the filter (whose w the wheels keep at
// 0) and, if the standstill lasted at least standstill_min_s, seed the
// EKF's bias state g (PoseEkf::SetGyroBias) when the wheels first move.
// A drive that starts moving at once keeps the prior g = 0 +- prior sigma
// and learns g from the IMU yaw.
//
// Smoothing: a whole recording's EKF poses can be smoothed (options.smooth,
// EstimatePoses only): the Rauch-Tung-Striebel pass of ekf.h, so every pose
// uses every reading of the drive. The calibration uses it; the live
// pipeline cannot (it has no future readings), and `reconstruct` does not by
// default so that a replayed session's cloud equals the live one's.
//
// Gaps in the data (docs/models.md, "Gaps in the data"): when the link to
// the robot drops for longer than it buffers, every stream has a hole. An
// interval longer than max_gap_s between consecutive records of the merged
// wheel + IMU stream (once initialised) is a gap. The filter does not
// predict across it (PoseEkf::ResumeAfterGap): the position is held with
// its covariance inflated by the distance the robot can have covered before
// its watchdog stopped it, v and w restart from the next readings, and the
// heading is re-established by the first IMU yaw after the gap (b is known
// from before), its covariance inflated by the turn bound. Poses between
// the last record before the gap and that yaw are not stored, and the pose
// buffer refuses lookups in between (PoseBuffer, after_gap). Wheel
// odometry alone holds its pose across a gap. gaps() lists what was found.
//
// Lives on the processing thread.
#ifndef SWEEPSCAN_CORE_POSE_POSE_ESTIMATOR_H_
#define SWEEPSCAN_CORE_POSE_POSE_ESTIMATOR_H_

#include <string>
#include <utility>
#include <vector>

#include "core/pose/ekf.h"
#include "core/pose/odometry.h"
#include "core/pose/pose_buffer.h"
#include "core/robot/robot_model.h"
#include "core/robot/sensor_data.h"

namespace sweepscan {

// kSfm: lidar-only structure from motion on top of the EKF (core/sfm/
// wheeled.h); like kTruth, its poses are computed elsewhere and given to
// the reconstruction, never by the PoseEstimator.
enum class PoseSource : uint8_t { kEkf = 0, kOdometry = 1, kTruth = 2, kSfm = 3 };
const char* PoseSourceName(PoseSource source);
bool ParsePoseSource(const std::string& name, PoseSource* source);

struct PoseEstimatorOptions {
  PoseSource source = PoseSource::kEkf;
  EkfOptions ekf;
  // Per-sensor flags (which IMU outputs the EKF uses).
  bool use_imu_gyro = true;
  bool use_imu_yaw = true;
  bool use_imu_tilt = true;
  // Gyro bias from a standstill at the start of the drive (see above).
  bool gyro_bias_from_standstill = true;
  double standstill_min_s = 0.5;
  double standstill_max_wheel_mps = 0.0005;
  // Where the robot starts in the world; the cloud is expressed in this frame.
  Pose2d initial_pose;
  // EKF only: EstimatePoses returns the smoothed poses (see above).
  bool smooth = false;

  // Gaps (see above). A longer interval between consecutive wheel / IMU
  // records is a gap; the streams run at <= 20 ms spacing, so 0.5 s is 25
  // missed wheel records and 50 IMU ones: never jitter.
  double max_gap_s = 0.5;
  // The bound on the robot's motion in a gap (docs/models.md). The agent's
  // watchdog stops the motors within gap_watchdog_s of the link going
  // quiet; they then brake at >= gap_min_deceleration_mps2 per wheel. A
  // wheel at speed u covers at most s(u) = |u| t_w + u^2 / (2 a) meanwhile:
  // the body travels <= (s_l + s_r) / 2 and turns <= max(s_l, s_r) / (2 d)
  // ((s_l + s_r) / (2 d) turning in place; d = wheel_distance_m). The
  // floors cover what the speeds before the gap do not tell: a nudge, the
  // speed estimate's own error.
  double gap_watchdog_s = 0.5;
  double gap_min_deceleration_mps2 = 1.0;
  double gap_min_position_sigma_m = 0.05;
  double gap_min_heading_sigma_rad = 0.05;
};

// A gap in the wheel + IMU records (see above).
struct PoseGap {
  enum class Recovery : uint8_t {
    kImuHeading,  // heading from the first IMU yaw after it, position held
    kHeld,        // no IMU yaw (odometry, or no attitude): heading and position held
  };
  Time begin;            // the last record before the gap
  Time end;              // the first record after it
  Time first_pose;       // the first stored pose after it (>= end; lookups in
                         // (begin, first_pose) fail); end until it exists
  bool has_first_pose = false;
  double length_s = 0.0;  // end - begin
  Recovery recovery = Recovery::kHeld;
  double travel_bound_m = 0.0;      // the motion bound (options above), floored
  double turn_bound_rad = 0.0;
  double position_sigma_m = 0.0;    // 1-sigma of x, y (the larger) after it
  double heading_sigma_rad = 0.0;   // 1-sigma of psi at first_pose
  // The first IMU yaw after it disagreed with the turn bound beyond the
  // gate (the robot was carried?) and set the heading regardless.
  bool turned_beyond_bound = false;
  // Lidar samples (in range) not placed because they fall in the gap;
  // filled by the reconstruction (core/cloud/reconstruct.h), 0 here.
  size_t samples_dropped = 0;
};
const char* PoseGapRecoveryName(PoseGap::Recovery recovery);
// One line for the operator, times from `origin` (the session's start):
//   "gap at 12.3 s: 10.0 s without data; pose after it from the IMU
//    heading, position held (+-0.20 m); 57 lidar samples dropped"
std::string FormatPoseGap(const PoseGap& gap, Time origin);

class PoseEstimator {
 public:
  PoseEstimator(const PoseEstimatorOptions& options, const RobotGeometry& geometry);

  void AddWheels(const WheelSpeedMeasurement& m);
  void AddImu(const ImuMeasurement& m);

  const PoseBuffer& poses() const { return poses_; }
  // Replaces poses() by the EKF's smoothed estimates, one per filter time
  // (ekf.h, Smooth); needs options.smooth (the filter keeps its history
  // only then) and the EKF source, else a no-op. For a whole recording:
  // records added after it are not smoothed.
  void SmoothPoses();
  PoseBuffer* mutable_poses() { return &poses_; }
  const PoseEkf& ekf() const { return ekf_; }
  // Heading of the latest estimate (for tests and status displays).
  Pose2d LatestPose2d() const;
  // The initial standstill: its length (s) and whether it seeded the gyro
  // bias (false until the wheels first move).
  double standstill_s() const { return standstill_s_; }
  bool gyro_bias_seeded() const { return gyro_bias_seeded_; }
  // The gaps found so far, in time order.
  const std::vector<PoseGap>& gaps() const { return gaps_; }

 private:
  void EnsureInitialized(Time time);
  void RecordPose(Time time);
  void TrackStandstill(const WheelSpeedMeasurement& m);
  void EndStandstill();
  bool HoldingGyro() const;
  // Gap handling: called with every record's time before it is used.
  void CheckGap(Time time);
  void BeginAfterGap(Time begin, Time end);
  void SettleAfterGap(PoseGap::Recovery recovery);

  // The initial standstill: no wheel record yet, wheels at rest so far, moved.
  enum class StartPhase { kNoWheels, kStill, kMoved };
  StartPhase phase_ = StartPhase::kNoWheels;
  Time still_begin_, still_end_;
  double gyro_sum_ = 0.0;
  int gyro_count_ = 0;
  // Gyro readings held during the standstill not yet covered by a
  // zero-speed wheel record (the robot may have started moving meanwhile).
  std::vector<std::pair<Time, double>> pending_gyro_;
  double standstill_s_ = 0.0;
  bool gyro_bias_seeded_ = false;

  PoseEstimatorOptions options_;
  RobotGeometry geometry_;
  PoseEkf ekf_;
  WheelOdometry odometry_;
  PoseBuffer poses_;

  bool have_last_record_ = false;
  Time last_record_;
  // Wheel speeds of the last wheel record (the odometry's bound at a gap).
  double last_left_mps_ = 0.0, last_right_mps_ = 0.0;
  std::vector<PoseGap> gaps_;
  // After a gap, until the first IMU yaw: no pose is stored.
  bool awaiting_heading_ = false;
  bool next_pose_after_gap_ = false;
};

// Runs the estimator over a whole log, merging wheel and IMU records by
// time (an IMU record goes first on a tie). Returns the estimator, whose
// poses() and ekf() hold the result; poses() smoothed with options.smooth.
PoseEstimator EstimatePoses(const SensorLog& log, const PoseEstimatorOptions& options,
                            const RobotGeometry& geometry);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_POSE_POSE_ESTIMATOR_H_
