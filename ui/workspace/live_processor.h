// The processing thread's worker: runs the LivePipeline (EKF, deskew,
// assembly) on decoded records, live from the robot or replayed from a
// session, and posts the new points as LiveBatches to the mailbox the GUI
// drains (docs/architecture.md, "Threads").
//
// Replay feeds a recording's records (a ReplaySource: the log decoded whole,
// or a session's scans decoded as the replay goes) in robot-time order at a
// speed factor
// (1x..20x, or 0 = as fast as possible, in slices that keep the thread
// responsive). Seeking backwards restarts the pipeline; either way the
// records up to the target are then fed at full speed in the same slices, so
// that a seek across hours of recording keeps the thread answering (pause,
// another seek, stop) and the view takes the cloud as it grows, instead of
// one event that feeds it all and one batch of every chunk at its end. The
// replay then goes on as it was: paused, or at its speed. For the same
// records the replayed cloud equals the offline Reconstruct (LivePipeline's
// guarantee), hence `sweepscan-cli reconstruct`.
//
// A replay may also be given its poses, computed beforehand over the whole
// log (SfM, core/sfm/wheeled.h: a batch method): then no estimator runs and
// each scan, once released, is placed with the given poses by the same
// Assembler as Reconstruct with given poses, so the cloud equals
// `sweepscan-cli reconstruct --pose-source sfm` too.
//
// Threading: lives on the processing thread; every slot is called through
// queued connections (QMetaObject::invokeMethod) from the workspace.
#ifndef SWEEPSCAN_UI_WORKSPACE_LIVE_PROCESSOR_H_
#define SWEEPSCAN_UI_WORKSPACE_LIVE_PROCESSOR_H_

#include <QElapsedTimer>
#include <QObject>
#include <memory>

#include "core/cloud/assembler.h"
#include "core/cloud/live_pipeline.h"
#include "core/cloud/reconstruct.h"
#include "hardware/station/replay_source.h"
#include "ui/workspace/live_batch.h"

class QTimer;

namespace sweepscan::ui {

class LiveProcessor : public QObject {
  Q_OBJECT
 public:
  explicit LiveProcessor(BatchMailbox* mailbox, QObject* parent = nullptr);
  ~LiveProcessor() override;

  // Slots (processing thread).
  // Starts a new cloud (live, EKF or odometry by options.pose.source):
  // drops the old pipeline, posts a reset batch.
  void Reset(const ReconstructionOptions& options, const RobotGeometry& geometry);
  // Live records from the robot (each stream in time order).
  void AddRecords(const SensorLog& batch);
  // End of a recording: places the scans still waiting for poses.
  void Finish();

  // `given_poses`: world_from_body over the whole recording, required when
  // options.pose.source is kSfm or kTruth (poses computed elsewhere) and
  // ignored otherwise.
  // The source's start pose and geometry replace options' and the reset's.
  void StartReplay(std::shared_ptr<hardware::ReplaySource> source,
                   const ReconstructionOptions& options, double speed,
                   std::shared_ptr<const PoseBuffer> given_poses = nullptr);
  // A session's cloud built elsewhere (the workspace's streamed open,
  // hardware/station/session_stream.h: the same points as a replay at full
  // speed) becomes the cloud shown, placed with `poses`; published at once
  // with the whole trajectory, then replayProgress(length, length) and
  // replayFinished as a replay's end.
  void AdoptCloud(std::shared_ptr<std::unique_ptr<PointChunks>> cloud, std::shared_ptr<const PoseBuffer> poses,
                  const ReconstructionOptions& options, const RobotGeometry& geometry, size_t scans);
  void SetReplaySpeed(double speed);  // 0 = as fast as possible.
  void SetReplayPaused(bool paused);
  void SeekReplay(double robot_time_s);
  void StopReplay();

  // The whole cloud assembled since the last reset (processing thread; the
  // workspace reads it through a blocking queued call for save/export).
  std::vector<CloudPoint> Flatten() const;
  CloudSnapshotRef Snapshot() const;  // To decode on another thread.
  size_t CloudSize() const;

 signals:
  // Replay position (robot seconds from the recording's start) and length.
  void replayProgress(double position_s, double length_s);
  // `seeks`: the SeekReplay calls handled so far, so that the workspace can
  // tell a finish that a seek it has sent since overtook (the replay goes on).
  void replayFinished(quint64 seeks);
  // The source's records ended early (frames.bin unreadable mid-replay):
  // the replay finished with what it had read.
  void replayFailed(const QString& message);

 private:
  // A new pipeline (or assembler, with given poses) under options_ / geometry_.
  void ResetPipeline();
  PointChunks* chunks() const;
  // The robot's latest pose and its time; false before the first pose.
  bool LatestPose(Pose2d* pose, Time* time) const;
  void Publish(bool reset);
  void OnReplayTick();
  // One slice of a seek; at the target, the replay goes on as it was.
  void SeekTick();
  // The replay timer's period for the current state (0: as fast as possible).
  int ReplayTickMs() const;
  // Feeds every record with time < until (robot time) not fed yet.
  void FeedReplayUntil(Time until);
  void EmitReplayProgress();

  BatchMailbox* mailbox_;
  std::unique_ptr<LivePipeline> pipeline_;  // Null while replaying with given poses.
  // Replay with given poses: the poses, their assembler and the cloud.
  std::shared_ptr<const PoseBuffer> given_poses_;
  std::unique_ptr<Assembler> given_assembler_;
  std::unique_ptr<PointChunks> given_chunks_;
  ReconstructionOptions options_;
  RobotGeometry geometry_;
  size_t published_chunk_ = 0;   // Next chunk index to publish from.
  size_t published_offset_ = 0;  // Points of that chunk already published.
  size_t total_points_ = 0;
  size_t scans_ = 0;
  Time latest_time_;
  Time last_trajectory_time_;
  bool reset_pending_ = false;
  std::vector<Pose2d> adopted_trajectory_;  // For the next Publish (AdoptCloud).
  // An adopted cloud is published kAdoptChunks chunks a tick, so that the
  // GUI takes it in slices (a 100 M-point cloud is 1 519 chunks).
  size_t publish_cap_ = static_cast<size_t>(-1);  // Sealed chunks publishable.
  QTimer* adopt_timer_ = nullptr;
  double adopt_length_s_ = 0.0;
  void OnAdoptTick();

  // Replay state.
  std::shared_ptr<hardware::ReplaySource> replay_;
  QTimer* replay_timer_ = nullptr;
  QElapsedTimer replay_clock_;
  double replay_speed_ = 1.0;
  bool replay_paused_ = false;
  Time replay_start_;     // Robot time of the recording's first record.
  Time replay_position_;  // Everything before this has been fed.
  Time replay_anchor_;    // replay_position_ when replay_clock_ was restarted.
  bool seeking_ = false;  // Feeding up to seek_target_ at full speed.
  Time seek_target_;
  quint64 seeks_ = 0;             // SeekReplay calls handled.
  bool replay_finished_ = false;  // Finish() ran for the records fed.
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_WORKSPACE_LIVE_PROCESSOR_H_
