// What the processing thread hands to the GUI thread: immutable batches of
// new cloud points with the robot's latest pose, through a bounded mailbox
// (docs/architecture.md, "Threads").
//
// The mailbox never drops points: when it is full, a new batch is merged into
// the newest one, so the number of batches (and the GUI's work per tick) stays
// bounded while every point still arrives in order.
#ifndef SWEEPSCAN_UI_WORKSPACE_LIVE_BATCH_H_
#define SWEEPSCAN_UI_WORKSPACE_LIVE_BATCH_H_

#include <deque>
#include <memory>
#include <mutex>
#include <vector>

#include "core/cloud/cloud.h"
#include "core/cloud/packed_chunk.h"
#include "core/pose/odometry.h"

namespace sweepscan::ui {

struct LiveBatch {
  bool reset = false;  // Forget every point shown before (new recording, seek).
  // New points, in assembly order: chunks the store sealed (shared, not
  // copied; the first one holds the points of the open chunk published
  // before), then the new points of the open chunk.
  std::vector<std::shared_ptr<const PackedChunk>> sealed;
  // sealed[i]'s payload when that chunk is compressed, unpacked on the
  // processing thread (an opened 100 M-point session hands the view ~1 200
  // compressed chunks, ~2 ms each to unpack); null for an unpacked chunk.
  std::vector<std::shared_ptr<const ChunkPayload>> unpacked;
  std::vector<CloudPoint> points;
  std::vector<Pose2d> trajectory;  // New robot poses (world), ~10 Hz.
  bool has_pose = false;
  Pose2d pose;                // The robot's latest estimated pose.
  double robot_time_s = 0.0;  // Robot time of the latest record processed.
  size_t total_points = 0;    // Points assembled since the last reset.
  size_t scans = 0;           // Scans assembled since the last reset.
};

// Any thread. Push from the processing thread, TakeAll from the GUI thread.
class BatchMailbox {
 public:
  explicit BatchMailbox(size_t capacity = 32) : capacity_(capacity) {}

  void Push(LiveBatch batch) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (batch.reset) queue_.clear();  // Whatever was queued is superseded.
    if (queue_.size() < capacity_ || batch.reset) {
      queue_.push_back(std::move(batch));
      return;
    }
    LiveBatch& last = queue_.back();
    if (!batch.sealed.empty()) {
      // The open chunk whose tail `last` carries is the first sealed one.
      last.points.clear();
      // The payloads unpacked for them come along, index for index (else the
      // GUI thread would unpack them again).
      last.unpacked.resize(last.sealed.size());
      batch.unpacked.resize(batch.sealed.size());
      last.sealed.insert(last.sealed.end(), batch.sealed.begin(), batch.sealed.end());
      last.unpacked.insert(last.unpacked.end(), batch.unpacked.begin(), batch.unpacked.end());
    }
    last.points.insert(last.points.end(), batch.points.begin(), batch.points.end());
    last.trajectory.insert(last.trajectory.end(), batch.trajectory.begin(), batch.trajectory.end());
    if (batch.has_pose) {
      last.has_pose = true;
      last.pose = batch.pose;
    }
    last.robot_time_s = batch.robot_time_s;
    last.total_points = batch.total_points;
    last.scans = batch.scans;
    ++merged_;
  }

  std::deque<LiveBatch> TakeAll() {
    std::lock_guard<std::mutex> lock(mutex_);
    std::deque<LiveBatch> out;
    out.swap(queue_);
    return out;
  }

  size_t merged() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return merged_;
  }

 private:
  const size_t capacity_;
  mutable std::mutex mutex_;
  std::deque<LiveBatch> queue_;
  size_t merged_ = 0;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_WORKSPACE_LIVE_BATCH_H_
