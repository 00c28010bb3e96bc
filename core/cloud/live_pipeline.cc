#include "core/cloud/live_pipeline.h"

namespace sweepscan {

LivePipeline::LivePipeline(const ReconstructionOptions& options, const RobotGeometry& geometry,
                           size_t chunk_capacity)
    : assembly_options_(options.assembly),
      estimator_(options.pose, geometry),
      assembler_(options.assembly, BodyFromLidar(geometry, options.calibration), options.pose.source),
      chunks_(chunk_capacity) {}

void LivePipeline::Add(const SensorLog& batch) {
  wheels_.insert(wheels_.end(), batch.wheels.begin(), batch.wheels.end());
  imu_.insert(imu_.end(), batch.imu.begin(), batch.imu.end());
  scans_.insert(scans_.end(), batch.scans.begin(), batch.scans.end());
  Drain(false);
}

std::vector<PoseGap> LivePipeline::gaps() const {
  std::vector<PoseGap> gaps = estimator_.gaps();
  for (size_t k = 0; k < gaps.size() && k < gap_samples_dropped_.size(); ++k) {
    gaps[k].samples_dropped = gap_samples_dropped_[k];
  }
  return gaps;
}

void LivePipeline::Finish() {
  Drain(true);
  chunks_.Seal();
}

void LivePipeline::Drain(bool final) {
  // Merge by time exactly as EstimatePoses does (IMU first on ties). A
  // record is only taken when the other stream has something at or after
  // it, or at the end: a later batch can no longer put anything before it.
  while (!wheels_.empty() || !imu_.empty()) {
    const bool have_w = !wheels_.empty(), have_i = !imu_.empty();
    if (!final && (!have_w || !have_i)) break;
    const bool take_wheel = !have_i || (have_w && wheels_.front().time < imu_.front().time);
    if (take_wheel) {
      estimator_.AddWheels(wheels_.front());
      wheels_.pop_front();
    } else {
      estimator_.AddImu(imu_.front());
      imu_.pop_front();
    }
  }
  // A pose stored at time tau is final once no held-back record has a time
  // <= tau (one at tau itself would replace it). A scan is placed when the
  // pose interval around its last sample ends at a final pose, so live and
  // offline interpolate between the very same poses.
  const PoseBuffer& poses = estimator_.poses();
  bool pending = !wheels_.empty() || !imu_.empty();
  Time first_pending;
  if (!wheels_.empty()) first_pending = wheels_.front().time;
  if (!imu_.empty() && (wheels_.empty() || imu_.front().time < first_pending)) first_pending = imu_.front().time;
  while (!scans_.empty()) {
    const LidarScan& scan = scans_.front();
    bool covered = !poses.empty();
    if (covered && !scan.samples.empty() && scan.end_time() < poses.earliest()) {
      // Entirely before the first pose (lidar started before the wheels):
      // nothing will ever place it; let the assembler count it and move on.
    } else if (covered && !scan.samples.empty()) {
      // The first pose at or after the scan's last sample closes the
      // interval it is interpolated in (or refused in, inside a gap).
      covered = scan.end_time() <= poses.latest();
      if (covered && !final) {
        covered = !pending || poses.time(poses.FirstAtOrAfter(scan.end_time())) < first_pending;
      }
    }
    if (!covered && !final) break;
    CountSamplesInGaps(scan, poses, assembly_options_, estimator_.gaps(), &gap_samples_dropped_);
    assembler_.AddScan(scan, poses, &chunks_);
    scans_.pop_front();
  }
}

}  // namespace sweepscan
