#include "hardware/station/session_stream.h"

#include <algorithm>
#include <limits>

#include "core/cloud/assembler.h"

namespace sweepscan::hardware {

Status SessionCloudStream::EstimatePoses(const std::string& session_dir, const FramesLoadOptions& frames_options,
                                         const ReconstructionOptions& options, const PoseBuffer* given,
                                         const DecodeProgress& progress) {
  dir_ = session_dir;
  frames_options_ = frames_options;
  options_ = options;
  result_ = ReconstructionResult();
  motion_ = SensorLog();
  SessionStreamSinks sinks;
  sinks.motion = &motion_;
  scans_ = 0;
  sinks.scan = [this](LidarScan&&) {
    ++scans_;
    return true;
  };
  decoded_ = false;
  Status s = DecodeSessionStreaming(session_dir, frames_options, sinks, &decode_, progress);
  if (!s.ok()) return s;
  decoded_ = true;
  // EstimatePoses reads the wheel and IMU records only; the motion records
  // go once the poses exist (pass 2 needs the poses alone).
  s = EstimateReconstructionPoses(motion_, decode_.meta.geometry, options_, given, &result_);
  if (!keep_motion_) motion_ = SensorLog();
  return s;
}

void SessionCloudStream::PointBounds(double min[3], double max[3]) const {
  const PoseBuffer& poses = result_.poses;
  for (int k = 0; k < 3; ++k) {
    min[k] = std::numeric_limits<double>::infinity();
    max[k] = -std::numeric_limits<double>::infinity();
  }
  for (size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Vector3d t = poses.pose(i).translation();
    for (int k = 0; k < 3; ++k) {
      min[k] = std::min(min[k], t[k]);
      max[k] = std::max(max[k], t[k]);
    }
  }
  // |R_wb (R_bl p_L + t_bl)| <= rho_max + |t_bl| (Assembler, Eq. 11-14), and
  // a deskewed point's body position is a blend of two poses' positions.
  const double reach =
      options_.assembly.max_range_m +
      BodyFromLidar(decode_.meta.geometry, options_.calibration).translation().norm() + 1e-3;
  for (int k = 0; k < 3; ++k) {
    min[k] -= reach;
    max[k] += reach;
  }
}

size_t SessionCloudStream::held_bytes() const {
  return result_.poses.size() * (sizeof(int64_t) + sizeof(Rigid3d) + sizeof(uint8_t));
}

Status SessionCloudStream::PlacePoints(const PointSink& sink, const DecodeProgress& progress) {
  const ReconstructionOptions& o = options_;
  Assembler assembler(o.assembly, BodyFromLidar(decode_.meta.geometry, o.calibration), o.pose.source);
  std::vector<size_t> dropped(result_.gaps.size(), 0);
  constexpr size_t kChunk = 65536;
  CloudChunk points;
  points.reserve(kChunk + 4096);
  Status failed;
  auto hand = [&](size_t n) {
    if (failed.ok() && n > 0) failed = sink(points.data(), n);
    points.erase(points.begin(), points.begin() + static_cast<std::ptrdiff_t>(n));
  };
  SessionStreamSinks sinks;
  sinks.scan = [&](LidarScan&& scan) {
    CountSamplesInGaps(scan, result_.poses, o.assembly, result_.gaps, &dropped);
    assembler.AddScan(scan, result_.poses, &points);
    while (points.size() >= kChunk) hand(kChunk);
    return failed.ok();
  };
  SessionDecodeInfo again;
  Status s = DecodeSessionStreaming(dir_, frames_options_, sinks, &again, progress);
  if (!failed.ok()) return failed;
  if (!s.ok()) return s;
  hand(points.size());
  if (!failed.ok()) return failed;
  FinishGapCounts(dropped, &result_);
  result_.stats = assembler.stats();
  return Status::Ok();
}

}  // namespace sweepscan::hardware
