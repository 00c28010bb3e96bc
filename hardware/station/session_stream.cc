#include "hardware/station/session_stream.h"

#include <algorithm>
#include <condition_variable>
#include <deque>
#include <limits>
#include <mutex>
#include <thread>

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
  // No scan sink: the lidar's bytes are not decoded in this pass (pass 2
  // decodes them, and not the motion records).
  SessionStreamSinks sinks;
  sinks.motion = &motion_;
  scans_ = 0;
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
  // Decoding is sequential (the codecs carry state from byte to byte);
  // placing the points and the sink's work (a file, the cloud store) run
  // beside it on a second thread, fed whole scans through a bounded queue
  // in the decoder's order, so the points and their order are the same.
  std::mutex mutex;
  std::condition_variable queued, taken;
  std::deque<LidarScan> queue;
  constexpr size_t kQueuedScans = 32;  // about 4.5 s of X4 revolutions
  bool decoded = false;
  Status failed;  // the sink's first error; guarded by mutex
  std::thread placer([&] {
    constexpr size_t kChunk = 65536;
    CloudChunk points;
    points.reserve(kChunk + 4096);
    auto hand = [&](size_t n) {
      if (n == 0) return true;
      const Status s = sink(points.data(), n);
      points.erase(points.begin(), points.begin() + static_cast<std::ptrdiff_t>(n));
      if (s.ok()) return true;
      std::lock_guard<std::mutex> lock(mutex);
      failed = s;
      taken.notify_all();
      return false;
    };
    for (;;) {
      LidarScan scan;
      {
        std::unique_lock<std::mutex> lock(mutex);
        queued.wait(lock, [&] { return !queue.empty() || decoded; });
        if (queue.empty()) break;
        scan = std::move(queue.front());
        queue.pop_front();
      }
      taken.notify_one();
      ++scans_;
      CountSamplesInGaps(scan, result_.poses, o.assembly, result_.gaps, &dropped);
      assembler.AddScan(scan, result_.poses, &points);
      bool ok = true;
      while (ok && points.size() >= kChunk) ok = hand(kChunk);
      if (!ok) return;
    }
    hand(points.size());
  });
  SessionStreamSinks sinks;
  sinks.scan = [&](LidarScan&& scan) {
    std::unique_lock<std::mutex> lock(mutex);
    taken.wait(lock, [&] { return queue.size() < kQueuedScans || !failed.ok(); });
    if (!failed.ok()) return false;
    queue.push_back(std::move(scan));
    lock.unlock();
    queued.notify_one();
    return true;
  };
  SessionDecodeInfo again;
  FramesLoadOptions same_file = frames_options_;  // The file pass 1 read, not its successor.
  same_file.expect_device = decode_.frames.file_device;
  same_file.expect_inode = decode_.frames.file_inode;
  same_file.expect_first_record = decode_.frames.has_first_record;
  same_file.expect_first_record_crc = decode_.frames.first_record_crc;
  const Status s = DecodeSessionStreaming(dir_, same_file, sinks, &again, progress);
  {
    std::lock_guard<std::mutex> lock(mutex);
    decoded = true;
    if (!s.ok()) queue.clear();  // cancelled or unreadable: nothing more to place
  }
  queued.notify_all();
  placer.join();
  if (!failed.ok()) return failed;
  if (!s.ok()) return s;
  FinishGapCounts(dropped, &result_);
  result_.stats = assembler.stats();
  // Pass 1 decoded the wheels and IMU, pass 2 the lidar: together the
  // counts of one whole decode (every other count is the same in both).
  decode_.telemetry.x4 = again.telemetry.x4;
  return Status::Ok();
}

}  // namespace sweepscan::hardware
