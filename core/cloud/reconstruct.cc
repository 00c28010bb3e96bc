#include "core/cloud/reconstruct.h"

namespace sweepscan {

Status Reconstruct(const SensorLog& log, const RobotGeometry& geometry,
                   const ReconstructionOptions& options, const PoseBuffer* truth,
                   ReconstructionResult* result) {
  std::string error;
  if (!geometry.IsValid(&error) || !options.pose.ekf.IsValid(&error) ||
      !options.assembly.IsValid(&error)) {
    return Status::Error(error);
  }
  if (options.pose.source == PoseSource::kTruth || options.pose.source == PoseSource::kSfm) {
    if (truth == nullptr || truth->empty()) {
      return Status::Error(std::string("pose source '") + PoseSourceName(options.pose.source) + "' needs given poses");
    }
    result->poses = *truth;
  } else {
    // The EKF runs on the IMU alone when there is no odometry (an imported
    // bag without it: the robot turns in place, docs/ros-bags.md); wheel
    // odometry alone needs wheels.
    if (log.wheels.empty() && (log.imu.empty() || options.pose.source == PoseSource::kOdometry)) {
      return Status::Error("the recording has no wheel odometry records");
    }
    PoseEstimator estimator = EstimatePoses(log, options.pose, geometry);
    result->ekf_counters = estimator.ekf().counters();
    result->poses = std::move(*estimator.mutable_poses());
  }
  Assembler assembler(options.assembly, BodyFromLidar(geometry, options.calibration),
                      options.pose.source);
  PointChunks chunks;
  for (const LidarScan& scan : log.scans) assembler.AddScan(scan, result->poses, &chunks);
  chunks.Seal();
  result->points = chunks.Flatten();
  result->stats = assembler.stats();
  return Status::Ok();
}

}  // namespace sweepscan
