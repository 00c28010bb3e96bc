// The processing thread's pipeline for a live recording: records arrive in
// batches (from RobotConnection's decoded telemetry), poses are estimated as
// they come, and each lidar scan is placed as soon as the pose buffer covers
// its last sample. Points go to chunked storage that a viewer on the GUI
// thread reads without blocking the processing (core/cloud/cloud.h).
//
// For the same records the result equals the offline Reconstruct: the EKF
// sees the same measurements in the same order, and a scan is only
// assembled once every sample's pose can be interpolated.
//
// Gaps in the records (core/pose/pose_estimator.h) are handled as offline:
// a scan whose samples fall in one is placed once the pose after the gap is
// final, and those samples are dropped and counted (gaps()).
//
// Lives on the processing thread; only cloud() is meant for other threads.
#ifndef SWEEPSCAN_CORE_CLOUD_LIVE_PIPELINE_H_
#define SWEEPSCAN_CORE_CLOUD_LIVE_PIPELINE_H_

#include <deque>
#include <vector>

#include "core/cloud/assembler.h"
#include "core/cloud/cloud.h"
#include "core/cloud/reconstruct.h"
#include "core/pose/pose_estimator.h"

namespace sweepscan {

class LivePipeline {
 public:
  LivePipeline(const ReconstructionOptions& options, const RobotGeometry& geometry,
               size_t chunk_capacity = 65536);

  // Appends a batch (each stream in time order, later than the previous
  // batch's). Wheel and IMU records are merged by time once both streams
  // have reached it, so that the filter sees them in the offline order.
  void Add(const SensorLog& batch);
  // End of recording: processes whatever is still held back.
  void Finish();

  PointChunks& cloud() { return chunks_; }
  const AssemblyStats& stats() const { return assembler_.stats(); }
  const PoseEstimator& estimator() const { return estimator_; }
  size_t scans_waiting() const { return scans_.size(); }
  // The estimator's gaps so far, each with the lidar samples it dropped
  // among the scans placed so far (as ReconstructionResult::gaps).
  std::vector<PoseGap> gaps() const;

 private:
  void Drain(bool final);

  AssemblyOptions assembly_options_;
  PoseEstimator estimator_;
  Assembler assembler_;
  std::vector<size_t> gap_samples_dropped_;
  PointChunks chunks_;
  std::deque<WheelSpeedMeasurement> wheels_;
  std::deque<ImuMeasurement> imu_;
  std::deque<LidarScan> scans_;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CLOUD_LIVE_PIPELINE_H_
