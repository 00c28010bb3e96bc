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
};

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

 private:
  void EnsureInitialized(Time time);
  void RecordPose(Time time);
  void TrackStandstill(const WheelSpeedMeasurement& m);
  bool HoldingGyro() const;

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
};

// Runs the estimator over a whole log, merging wheel and IMU records by
// time (an IMU record goes first on a tie). Returns the estimator, whose
// poses() and ekf() hold the result; poses() smoothed with options.smooth.
PoseEstimator EstimatePoses(const SensorLog& log, const PoseEstimatorOptions& options,
                            const RobotGeometry& geometry);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_POSE_POSE_ESTIMATOR_H_
