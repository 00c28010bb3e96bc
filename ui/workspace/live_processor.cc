#include "ui/workspace/live_processor.h"

#include <malloc.h>

#include <QTimer>
#include <algorithm>
#include <cmath>

#include "core/cloud/packed_chunk.h"
#include "core/geometry/transform.h"

namespace sweepscan::ui {
namespace {

// Replay tick: 50 Hz is smooth for the view and cheap for the thread.
constexpr int kReplayTickMs = 20;
// "As fast as possible" feeds this much robot time per slice, then returns to
// the event loop so that pause, seek and stop are handled promptly.
constexpr double kFastSliceS = 2.0;
// Trajectory samples for the view.
constexpr double kTrajectoryStepS = 0.1;
// An adopted cloud goes to the view 32 chunks (2 M points) every 25 ms: the
// GUI builds their motion levels in a tick of ~10-20 ms, and 100 M points
// appear in 1.2 s.
constexpr size_t kAdoptChunks = 32;
// An adopted cloud's path: a pose every 0.25 m or 15 degrees.
constexpr double kAdoptStepM = 0.25;
constexpr double kAdoptStepRad = 15.0 * M_PI / 180.0;
constexpr int kAdoptTickMs = 25;

Time LastTime(const SensorLog& log) {
  Time t = Time::min();
  if (!log.wheels.empty()) t = std::max(t, log.wheels.back().time);
  if (!log.imu.empty()) t = std::max(t, log.imu.back().time);
  if (!log.scans.empty()) t = std::max(t, log.scans.back().end_time());
  return t == Time::min() ? Time() : t;
}

}  // namespace

LiveProcessor::LiveProcessor(BatchMailbox* mailbox, QObject* parent)
    : QObject(parent), mailbox_(mailbox) {}

LiveProcessor::~LiveProcessor() = default;

void LiveProcessor::Reset(const ReconstructionOptions& options, const RobotGeometry& geometry) {
  options_ = options;
  geometry_ = geometry;
  given_poses_.reset();
  ResetPipeline();
}

void LiveProcessor::ResetPipeline() {
  if (adopt_timer_ != nullptr) adopt_timer_->stop();  // an adopted cloud's slices
  publish_cap_ = static_cast<size_t>(-1);
  if (given_poses_ != nullptr) {
    // As Reconstruct with given poses: one assembler over every scan in order.
    pipeline_.reset();
    given_assembler_ = std::make_unique<Assembler>(
        options_.assembly, BodyFromLidar(geometry_, options_.calibration), options_.pose.source);
    given_chunks_ = std::make_unique<PointChunks>();
  } else {
    given_assembler_.reset();
    given_chunks_.reset();
    pipeline_ = std::make_unique<LivePipeline>(options_, geometry_);
  }
  published_chunk_ = 0;
  published_offset_ = 0;
  total_points_ = 0;
  scans_ = 0;
  latest_time_ = Time();
  last_trajectory_time_ = Time::min();
  Publish(true);
}

PointChunks* LiveProcessor::chunks() const {
  if (given_chunks_ != nullptr) return given_chunks_.get();
  return pipeline_ != nullptr ? &pipeline_->cloud() : nullptr;
}

bool LiveProcessor::LatestPose(Pose2d* pose, Time* time) const {
  if (given_poses_ != nullptr) {
    // Given poses cover the whole recording: the robot is where the replay is.
    const PoseBuffer& poses = *given_poses_;
    if (poses.empty() || latest_time_ < poses.earliest()) return false;
    *time = std::min(latest_time_, poses.latest());
    Rigid3d world_from_body;
    if (!poses.Lookup(*time, &world_from_body)) return false;
    *pose = {world_from_body.translation().x(), world_from_body.translation().y(),
             YawFromQuaternion(world_from_body.rotation())};
    return true;
  }
  if (pipeline_ == nullptr || pipeline_->estimator().poses().empty()) return false;
  *pose = pipeline_->estimator().LatestPose2d();
  *time = pipeline_->estimator().poses().latest();
  return true;
}

void LiveProcessor::AddRecords(const SensorLog& batch) {
  if (given_assembler_ != nullptr) {
    // Only the scans matter: the poses are known already.
    for (const LidarScan& scan : batch.scans) {
      given_assembler_->AddScan(scan, *given_poses_, given_chunks_.get());
    }
  } else if (pipeline_ != nullptr) {
    pipeline_->Add(batch);
  } else {
    return;
  }
  scans_ += batch.scans.size();
  const Time last = LastTime(batch);
  if (last > latest_time_) latest_time_ = last;
  Publish(false);
}

void LiveProcessor::Finish() {
  if (given_chunks_ != nullptr) {
    given_chunks_->Seal();
  } else if (pipeline_ != nullptr) {
    pipeline_->Finish();
  } else {
    return;
  }
  Publish(false);
}

std::vector<CloudPoint> LiveProcessor::Flatten() const {
  const PointChunks* c = chunks();
  return c != nullptr ? c->Flatten() : std::vector<CloudPoint>();
}

CloudSnapshotRef LiveProcessor::Snapshot() const {
  const PointChunks* c = chunks();
  return c != nullptr ? c->Snapshot() : CloudSnapshotRef();
}

size_t LiveProcessor::CloudSize() const {
  const PointChunks* c = chunks();
  return c != nullptr ? c->sealed_point_count() + c->open_chunk().size() : 0;
}

void LiveProcessor::Publish(bool reset) {
  LiveBatch batch;
  batch.reset = reset;
  if (PointChunks* c = chunks()) {
    // New points: the sealed chunks not published yet (shared: the view
    // draws from the same packed chunks), then the open chunk's new tail.
    // The first new sealed chunk holds the open chunk published before.
    const auto sealed = c->SealedChunks();
    for (; published_chunk_ < std::min(sealed.size(), publish_cap_); ++published_chunk_) {
      const auto& chunk = sealed[published_chunk_];
      batch.sealed.push_back(chunk);
      batch.unpacked.push_back(chunk->unpacked() ? nullptr : chunk->Pin());
      total_points_ += chunk->size() - published_offset_;
      published_offset_ = 0;
    }
    const CloudChunk& open = c->open_chunk();
    batch.points.insert(batch.points.end(), open.begin() + published_offset_, open.end());
    published_offset_ = open.size();
    total_points_ += batch.points.size();

    Time pose_time;
    if (LatestPose(&batch.pose, &pose_time)) {
      batch.has_pose = true;
      if (last_trajectory_time_ == Time::min() ||
          ToSeconds(pose_time - last_trajectory_time_) >= kTrajectoryStepS) {
        batch.trajectory.push_back(batch.pose);
        last_trajectory_time_ = pose_time;
      }
    }
  }
  if (!adopted_trajectory_.empty()) {
    batch.trajectory.insert(batch.trajectory.begin(), adopted_trajectory_.begin(), adopted_trajectory_.end());
    adopted_trajectory_.clear();
  }
  batch.robot_time_s = ToSeconds(latest_time_);
  batch.total_points = total_points_;
  batch.scans = scans_;
  if (!reset && batch.points.empty() && batch.sealed.empty() && !batch.has_pose) return;
  mailbox_->Push(std::move(batch));
}

void LiveProcessor::StartReplay(std::shared_ptr<hardware::ReplaySource> source,
                                const ReconstructionOptions& options, double speed,
                                std::shared_ptr<const PoseBuffer> given_poses) {
  StopReplay();
  replay_ = std::move(source);
  if (!replay_->at_start()) replay_->Rewind();  // One kept from an earlier replay starts over.
  options_ = options;
  options_.pose.initial_pose = replay_->start_pose();
  geometry_ = replay_->geometry();
  const bool given =
      options.pose.source == PoseSource::kSfm || options.pose.source == PoseSource::kTruth;
  given_poses_ = given ? std::move(given_poses) : nullptr;
  // Given nothing, nothing is placed (the assembler counts the samples).
  if (given && given_poses_ == nullptr) given_poses_ = std::make_shared<PoseBuffer>();
  ResetPipeline();
  replay_start_ = replay_->start();
  replay_position_ = replay_start_;
  replay_anchor_ = replay_start_;
  replay_finished_ = false;
  replay_speed_ = speed;
  replay_paused_ = false;
  if (replay_timer_ == nullptr) {
    replay_timer_ = new QTimer(this);
    connect(replay_timer_, &QTimer::timeout, this, &LiveProcessor::OnReplayTick);
  }
  replay_clock_.start();
  replay_timer_->start(ReplayTickMs());
}

void LiveProcessor::AdoptCloud(std::shared_ptr<std::unique_ptr<PointChunks>> cloud,
                               std::shared_ptr<const PoseBuffer> poses, const ReconstructionOptions& options,
                               const RobotGeometry& geometry, size_t scans) {
  StopReplay();
  options_ = options;
  geometry_ = geometry;
  pipeline_.reset();
  given_assembler_.reset();
  given_poses_ = std::move(poses);
  given_chunks_ = std::move(*cloud);
  if (given_chunks_ == nullptr) given_chunks_ = std::make_unique<PointChunks>();
  given_chunks_->Seal();
  published_chunk_ = 0;
  published_offset_ = 0;
  total_points_ = 0;
  scans_ = scans;
  const PoseBuffer& p = *given_poses_;
  latest_time_ = p.empty() ? Time() : p.latest();
  // The path, a pose every kAdoptStepM moved or kAdoptStepRad turned: a
  // 5.7-hour drive at a pose every 0.1 s would be a 200 000-vertex wide line,
  // which alone halved the frame rate under llvmpipe.
  adopted_trajectory_.clear();
  for (size_t i = 0; i < p.size(); ++i) {
    const Rigid3d& pose = p.pose(i);
    const Pose2d now{pose.translation().x(), pose.translation().y(), YawFromQuaternion(pose.rotation())};
    if (!adopted_trajectory_.empty() && i + 1 < p.size()) {
      const Pose2d& last = adopted_trajectory_.back();
      const double turned = std::abs(std::remainder(now.yaw - last.yaw, 2.0 * M_PI));
      if (std::hypot(now.x - last.x, now.y - last.y) < kAdoptStepM && turned < kAdoptStepRad) continue;
    }
    adopted_trajectory_.push_back(now);
  }
  last_trajectory_time_ = latest_time_;
  adopt_length_s_ = p.empty() ? 0.0 : ToSeconds(p.latest() - p.earliest());
  // From here on only the last pose is looked up (LatestPose, at
  // latest_time_; nothing is placed any more: a replay or a seek opens the
  // session again), so the rest goes: a pose a wheel or IMU record, ~200 MB
  // for the 5.7-hour drive of docs/performance.md.
  auto tail = std::make_shared<PoseBuffer>();
  for (size_t i = p.size() >= 2 ? p.size() - 2 : 0; i < p.size(); ++i) {
    tail->Add(p.time(i), p.pose(i), i > 0 && p.AfterGap(i));
  }
  given_poses_ = std::move(tail);
  publish_cap_ = kAdoptChunks;
  Publish(true);
  if (adopt_timer_ == nullptr) {
    adopt_timer_ = new QTimer(this);
    connect(adopt_timer_, &QTimer::timeout, this, &LiveProcessor::OnAdoptTick);
  }
  adopt_timer_->start(kAdoptTickMs);
}

void LiveProcessor::OnAdoptTick() {
  const size_t sealed = given_chunks_ != nullptr ? given_chunks_->SealedChunks().size() : 0;
  publish_cap_ += kAdoptChunks;
  Publish(false);
  if (published_chunk_ < sealed) {
    emit replayProgress(adopt_length_s_ * published_chunk_ / sealed, adopt_length_s_);
    return;
  }
  adopt_timer_->stop();
  publish_cap_ = static_cast<size_t>(-1);
  // The open's transient memory (the poses, the chunks unpacked for the
  // view, the decoders' buffers: hundreds of MB for 100 M points) back to
  // the system: glibc returns a freed block inside its heaps only when
  // trimmed, and the app keeps up to 512 MiB free otherwise (gui_main.cc).
  malloc_trim(0);
  emit replayProgress(adopt_length_s_, adopt_length_s_);
  emit replayFinished(seeks_);
}

int LiveProcessor::ReplayTickMs() const {
  return seeking_ || replay_speed_ <= 0 ? 0 : kReplayTickMs;
}

void LiveProcessor::SetReplaySpeed(double speed) {
  replay_speed_ = speed;
  replay_anchor_ = replay_position_;
  replay_clock_.restart();
  if (replay_timer_ != nullptr && replay_timer_->isActive()) replay_timer_->start(ReplayTickMs());
}

void LiveProcessor::SetReplayPaused(bool paused) {
  if (replay_ == nullptr || replay_timer_ == nullptr) return;
  replay_paused_ = paused;
  if (seeking_) return;  // The seek finishes first, then honours the pause.
  if (paused) {
    replay_timer_->stop();
  } else if (!replay_finished_) {  // Also when every record is fed: the next tick finishes.
    replay_anchor_ = replay_position_;
    replay_clock_.restart();
    replay_timer_->start(ReplayTickMs());
  }
}

void LiveProcessor::SeekReplay(double robot_time_s) {
  ++seeks_;
  if (replay_ == nullptr) return;
  const Time target = replay_start_ + FromSeconds(std::max(0.0, robot_time_s));
  if (target < replay_position_) {
    // Backwards: the EKF cannot un-see records; start over from the beginning.
    ResetPipeline();
    replay_->Rewind();
    replay_position_ = replay_start_;
    replay_finished_ = false;
  }
  seek_target_ = std::min(target, replay_->end() + FromSeconds(1e-9));
  seeking_ = true;
  replay_timer_->start(ReplayTickMs());
  SeekTick();  // A seek a few seconds ahead ends here.
}

void LiveProcessor::SeekTick() {
  FeedReplayUntil(std::min(seek_target_, replay_position_ + FromSeconds(kFastSliceS)));
  EmitReplayProgress();
  if (replay_position_ < seek_target_) return;
  seeking_ = false;
  replay_anchor_ = replay_position_;
  replay_clock_.restart();
  if (replay_paused_) {
    replay_timer_->stop();
  } else {
    replay_timer_->start(ReplayTickMs());
  }
}

void LiveProcessor::StopReplay() {
  if (replay_timer_ != nullptr) replay_timer_->stop();
  if (adopt_timer_ != nullptr) adopt_timer_->stop();
  publish_cap_ = static_cast<size_t>(-1);
  seeking_ = false;
  replay_.reset();
}

void LiveProcessor::OnReplayTick() {
  if (replay_ == nullptr) return;
  if (seeking_) {
    SeekTick();
    return;
  }
  Time until;
  if (replay_speed_ > 0) {
    until = replay_anchor_ + FromSeconds(replay_speed_ * replay_clock_.elapsed() * 1e-3);
  } else {
    until = replay_position_ + FromSeconds(kFastSliceS);
  }
  FeedReplayUntil(until);
  const bool done = replay_->done();
  // At the end the position is the last record's (a seek to the end then
  // does not start over).
  if (done) replay_position_ = std::min(replay_position_, replay_->end() + FromSeconds(1e-9));
  EmitReplayProgress();
  if (done) {
    replay_timer_->stop();
    replay_finished_ = true;
    Finish();
    const Status status = replay_->status();
    if (!status.ok()) {
      emit replayFailed(tr("The replay of %1 ended at %2 s: %3")
                            .arg(QString::fromStdString(replay_->name()))
                            .arg(ToSeconds(replay_position_ - replay_start_), 0, 'f', 1)
                            .arg(QString::fromStdString(status.message())));
    }
    emit replayFinished(seeks_);
  }
}

void LiveProcessor::EmitReplayProgress() {
  const double length = ToSeconds(replay_->end() - replay_start_);
  emit replayProgress(std::min(ToSeconds(replay_position_ - replay_start_), length), length);
}

void LiveProcessor::FeedReplayUntil(Time until) {
  // A scan is released once its last sample is due (a live link delivers a
  // revolution when it is complete): ReplaySource::Take.
  SensorLog batch;
  replay_->Take(until, &batch);
  replay_position_ = until;
  if (!batch.wheels.empty() || !batch.imu.empty() || !batch.scans.empty()) AddRecords(batch);
}

}  // namespace sweepscan::ui
