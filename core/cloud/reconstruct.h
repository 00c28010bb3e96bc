// Offline reconstruction of a whole recording: poses from the wheel and IMU
// records (EKF or odometry alone, or given truth), then every scan placed in
// the world with per-sample deskew. Deterministic: the same log and options
// give the same cloud, bit for bit.
#ifndef SWEEPSCAN_CORE_CLOUD_RECONSTRUCT_H_
#define SWEEPSCAN_CORE_CLOUD_RECONSTRUCT_H_

#include <vector>

#include "core/cloud/assembler.h"
#include "core/cloud/cloud.h"
#include "core/common/status.h"
#include "core/pose/pose_estimator.h"

namespace sweepscan {

struct ReconstructionOptions {
  PoseEstimatorOptions pose;
  AssemblyOptions assembly;
  MountingError calibration;  // the mounting error to undo (from calibration)
};

struct ReconstructionResult {
  std::vector<CloudPoint> points;
  AssemblyStats stats;
  PoseBuffer poses;
  PoseEkf::Counters ekf_counters;
};

// `truth` (the given poses) is required when options.pose.source is kTruth
// or kSfm (poses computed elsewhere: the simulation's truth, or core/sfm's
// corrected EKF poses) and ignored otherwise.
Status Reconstruct(const SensorLog& log, const RobotGeometry& geometry,
                   const ReconstructionOptions& options, const PoseBuffer* truth,
                   ReconstructionResult* result);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CLOUD_RECONSTRUCT_H_
