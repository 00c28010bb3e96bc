// Turns wheel and IMU records into a PoseBuffer of world_from_body, either by
// the EKF (odometry + IMU) or by wheel odometry alone, for comparison.
//
// Measurements from the two streams must be fed in time order (the caller
// merges them; EstimatePoses does it for a whole SensorLog). The IMU yaw has
// its own heading reference; the EKF estimates its offset (state b).
//
// Lives on the processing thread.
#ifndef SWEEPSCAN_CORE_POSE_POSE_ESTIMATOR_H_
#define SWEEPSCAN_CORE_POSE_POSE_ESTIMATOR_H_

#include <string>

#include "core/pose/ekf.h"
#include "core/pose/odometry.h"
#include "core/pose/pose_buffer.h"
#include "core/robot/robot_model.h"
#include "core/robot/sensor_data.h"

namespace sweepscan {

enum class PoseSource : uint8_t { kEkf = 0, kOdometry = 1, kTruth = 2 };
const char* PoseSourceName(PoseSource source);
bool ParsePoseSource(const std::string& name, PoseSource* source);

struct PoseEstimatorOptions {
  PoseSource source = PoseSource::kEkf;
  EkfOptions ekf;
  // Per-sensor flags (which IMU outputs the EKF uses).
  bool use_imu_gyro = true;
  bool use_imu_yaw = true;
  bool use_imu_tilt = true;
  // Where the robot starts in the world; the cloud is expressed in this frame.
  Pose2d initial_pose;
};

class PoseEstimator {
 public:
  PoseEstimator(const PoseEstimatorOptions& options, const RobotGeometry& geometry);

  void AddWheels(const WheelSpeedMeasurement& m);
  void AddImu(const ImuMeasurement& m);

  const PoseBuffer& poses() const { return poses_; }
  PoseBuffer* mutable_poses() { return &poses_; }
  const PoseEkf& ekf() const { return ekf_; }
  // Heading of the latest estimate (for tests and status displays).
  Pose2d LatestPose2d() const;

 private:
  void EnsureInitialized(Time time);
  void RecordPose(Time time);

  PoseEstimatorOptions options_;
  RobotGeometry geometry_;
  PoseEkf ekf_;
  WheelOdometry odometry_;
  PoseBuffer poses_;
};

// Runs the estimator over a whole log, merging wheel and IMU records by
// time (an IMU record goes first on a tie). Returns the estimator, whose
// poses() and ekf() hold the result.
PoseEstimator EstimatePoses(const SensorLog& log, const PoseEstimatorOptions& options,
                            const RobotGeometry& geometry);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_POSE_POSE_ESTIMATOR_H_
