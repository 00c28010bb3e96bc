// Offline reconstruction of a whole recording: poses from the wheel and IMU
// records (EKF or odometry alone, or given truth), then every scan placed in
// the world with per-sample deskew. Deterministic: the same log and options
// give the same cloud, bit for bit.
//
// Gaps in the wheel + IMU records (core/pose/pose_estimator.h): the pose
// buffer refuses times inside them, so their lidar samples are dropped, not
// placed at invented poses; the result lists the gaps with those counts.
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
  // The estimator's gaps, each with the lidar samples (in range) dropped
  // because they fall in it (PoseGap::samples_dropped); FormatPoseGap
  // makes the operator's line. Empty for given poses (kTruth, kSfm).
  std::vector<PoseGap> gaps;
  double gap_seconds = 0.0;         // sum of the gaps' lengths
  size_t gap_samples_dropped = 0;   // sum of their samples_dropped (within stats.no_pose)
};

// Counts the samples of `scan` that the assembler (with `options`) drops
// because `poses` has a gap at their time, per gap of `gaps` (the gap whose
// begin last precedes the sample); `dropped` is resized to gaps.size().
// Scans that touch no gap cost O(gaps).
void CountSamplesInGaps(const LidarScan& scan, const PoseBuffer& poses, const AssemblyOptions& options,
                        const std::vector<PoseGap>& gaps, std::vector<size_t>* dropped);

// `truth` (the given poses) is required when options.pose.source is kTruth
// or kSfm (poses computed elsewhere: the simulation's truth, or core/sfm's
// corrected EKF poses) and ignored otherwise.
Status Reconstruct(const SensorLog& log, const RobotGeometry& geometry,
                   const ReconstructionOptions& options, const PoseBuffer* truth,
                   ReconstructionResult* result);

// Reconstruct's first half, for a reader that places the scans itself as
// they stream in (hardware/station/session_stream.h): validates the options
// and fills result->poses, ekf_counters and gaps; log.scans is not read.
Status EstimateReconstructionPoses(const SensorLog& log, const RobotGeometry& geometry,
                                   const ReconstructionOptions& options, const PoseBuffer* truth,
                                   ReconstructionResult* result);
// Its last step: each gap's samples_dropped (CountSamplesInGaps summed over
// the scans) and the sums.
void FinishGapCounts(const std::vector<size_t>& dropped, ReconstructionResult* result);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CLOUD_RECONSTRUCT_H_
