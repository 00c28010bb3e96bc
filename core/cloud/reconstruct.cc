#include "core/cloud/reconstruct.h"

namespace sweepscan {

void CountSamplesInGaps(const LidarScan& scan, const PoseBuffer& poses, const AssemblyOptions& options,
                        const std::vector<PoseGap>& gaps, std::vector<size_t>* dropped) {
  dropped->resize(gaps.size(), 0);
  if (scan.samples.empty() || gaps.empty() || poses.gap_count() == 0) return;
  // The buffer refuses (begin, first pose after); without a first pose yet
  // the buffer ends at begin and everything later is outside it anyway.
  bool touches = false;
  for (const PoseGap& g : gaps) {
    const Time hi = g.has_first_pose ? g.first_pose : Time::max();
    touches |= scan.end_time() > g.begin && scan.start_time() < hi;
  }
  if (!touches) return;
  const float min_r = static_cast<float>(options.min_range_m);
  const float max_r = static_cast<float>(options.max_range_m);
  // Without deskew the whole scan uses the pose at its first sample.
  const bool scan_in_gap = !options.deskew && poses.InGap(scan.start_time());
  for (const LidarSample& s : scan.samples) {
    if (!(s.range_m >= min_r && s.range_m <= max_r)) continue;  // the assembler's order
    const Time t = options.deskew ? s.time : scan.start_time();
    if (options.deskew ? !poses.InGap(t) : !scan_in_gap) continue;
    size_t k = gaps.size();
    while (k > 0 && !(gaps[k - 1].begin < t)) --k;
    if (k > 0) ++(*dropped)[k - 1];
  }
}

Status EstimateReconstructionPoses(const SensorLog& log, const RobotGeometry& geometry,
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
    result->gaps = estimator.gaps();
  }
  return Status::Ok();
}

void FinishGapCounts(const std::vector<size_t>& dropped, ReconstructionResult* result) {
  for (size_t k = 0; k < result->gaps.size(); ++k) {
    result->gaps[k].samples_dropped = dropped[k];
    result->gap_seconds += result->gaps[k].length_s;
    result->gap_samples_dropped += dropped[k];
  }
}

Status Reconstruct(const SensorLog& log, const RobotGeometry& geometry,
                   const ReconstructionOptions& options, const PoseBuffer* truth,
                   ReconstructionResult* result) {
  const Status s = EstimateReconstructionPoses(log, geometry, options, truth, result);
  if (!s.ok()) return s;
  Assembler assembler(options.assembly, BodyFromLidar(geometry, options.calibration),
                      options.pose.source);
  PointChunks chunks;
  std::vector<size_t> dropped(result->gaps.size(), 0);
  for (const LidarScan& scan : log.scans) {
    CountSamplesInGaps(scan, result->poses, options.assembly, result->gaps, &dropped);
    assembler.AddScan(scan, result->poses, &chunks);
  }
  FinishGapCounts(dropped, result);
  chunks.Seal();
  result->points = chunks.Flatten();
  result->stats = assembler.stats();
  return Status::Ok();
}

}  // namespace sweepscan
