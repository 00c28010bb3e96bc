#include "hardware/station/replay_source.h"

#include <algorithm>

namespace sweepscan::hardware {
namespace {

template <typename T>
void TakeUntil(const std::vector<T>& from, Time until, size_t* next, std::vector<T>* to) {
  while (*next < from.size() && from[*next].time < until) to->push_back(from[(*next)++]);
}

// The first and last record times of the wheel and IMU streams, folded
// into [*first, *last].
void MotionSpan(const SensorLog& log, Time* first, Time* last) {
  if (!log.wheels.empty()) {
    *first = std::min(*first, log.wheels.front().time);
    *last = std::max(*last, log.wheels.back().time);
  }
  if (!log.imu.empty()) {
    *first = std::min(*first, log.imu.front().time);
    *last = std::max(*last, log.imu.back().time);
  }
}

Time OrZero(Time t) { return t == Time::max() || t == Time::min() ? Time() : t; }

}  // namespace

LogReplaySource::LogReplaySource(std::shared_ptr<const Recording> recording)
    : recording_(std::move(recording)) {
  name_ = recording_->name;
  geometry_ = recording_->geometry;
  start_pose_ = recording_->start;
  const SensorLog& log = recording_->log;
  Time first = Time::max(), last = Time::min();
  MotionSpan(log, &first, &last);
  if (!log.scans.empty()) {
    first = std::min(first, log.scans.front().start_time());
    last = std::max(last, log.scans.back().end_time());
  }
  start_ = OrZero(first);
  end_ = OrZero(last);
}

void LogReplaySource::Take(Time until, SensorLog* batch) {
  const SensorLog& log = recording_->log;
  TakeUntil(log.wheels, until, &next_wheel_, &batch->wheels);
  TakeUntil(log.imu, until, &next_imu_, &batch->imu);
  while (next_scan_ < log.scans.size() && log.scans[next_scan_].end_time() < until) {
    batch->scans.push_back(log.scans[next_scan_++]);
  }
}

bool LogReplaySource::done() const {
  const SensorLog& log = recording_->log;
  return next_wheel_ == log.wheels.size() && next_imu_ == log.imu.size() &&
         next_scan_ == log.scans.size();
}

Status SessionReplaySource::Open(const std::string& session_dir, const DecodeProgress& progress,
                                 std::unique_ptr<SessionReplaySource>* source,
                                 size_t ahead_samples) {
  std::unique_ptr<SessionReplaySource> s(new SessionReplaySource());
  s->dir_ = session_dir;
  s->ahead_samples_ = ahead_samples;
  SessionStreamSinks sinks;
  sinks.motion = &s->motion_;  // no scan sink: the lidar's bytes are skipped
  Status status = DecodeSessionStreaming(session_dir, DefaultSessionFramesOptions(), sinks,
                                         &s->decode_, progress);
  if (!status.ok()) return status;
  s->name_ = "session " + session_dir;
  s->geometry_ = s->decode_.meta.geometry;
  s->start_pose_ = SessionStartPose(s->decode_.meta);
  s->StartDecoder();
  // The first record's time needs the first scan's: a revolution may
  // start before the first wheel or IMU record (a few ms of decoding).
  Time first = Time::max(), last = Time::min();
  MotionSpan(s->motion_, &first, &last);
  {
    std::unique_lock<std::mutex> lock(s->mu_);
    s->WaitForFront(&lock);
    if (!s->queue_.empty()) {
      first = std::min(first, s->queue_.front().start_time());
      last = std::max(last, s->queue_.front().end_time());
    }
  }
  s->start_ = OrZero(first);
  s->motion_end_ = OrZero(last);
  // The last scan is known once read: until then the end is the last agent
  // frame's time, which no record of it passes (the replay's slider spans
  // the drive from the start); the first Take that finds every record
  // handed out sets the end to the last one's.
  s->end_ = std::max(s->motion_end_, s->decode_.last_robot_time);
  *source = std::move(s);
  return Status::Ok();
}

SessionReplaySource::~SessionReplaySource() { StopDecoder(); }

void SessionReplaySource::StartDecoder() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    queue_.clear();
    queued_samples_ = 0;
    decoder_done_ = false;
    stop_ = false;
    decoder_status_ = Status::Ok();
  }
  decoder_ = std::thread([this] { Decode(); });
}

void SessionReplaySource::StopDecoder() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  if (decoder_.joinable()) decoder_.join();
  std::lock_guard<std::mutex> lock(mu_);
  queue_.clear();
  queue_.shrink_to_fit();
  queued_samples_ = 0;
}

void SessionReplaySource::Decode() {
  SessionStreamSinks sinks;
  // No motion sink: the IMU's and motor board's bytes are skipped (the
  // source decoded them once, in Open).
  sinks.scan = [this](LidarScan&& scan) {
    std::unique_lock<std::mutex> lock(mu_);
    // Room for one more: the queue holds at most ahead_samples_, or one
    // scan whatever its size.
    if (!stop_ && !queue_.empty() && queued_samples_ + scan.samples.size() > ahead_samples_) {
      ++decoder_waits_;
      cv_.wait(lock, [&] {
        return stop_ || queue_.empty() || queued_samples_ + scan.samples.size() <= ahead_samples_;
      });
    }
    if (stop_) return false;
    queued_samples_ += scan.samples.size();
    peak_queued_samples_ = std::max(peak_queued_samples_, queued_samples_);
    queue_.push_back(std::move(scan));
    lock.unlock();
    cv_.notify_all();
    return true;
  };
  SessionDecodeInfo info;
  // The file Open() read the motion from (a replay decodes it again at each
  // rewind and seek): a session recorded over since then is an error.
  FramesLoadOptions same_file = DefaultSessionFramesOptions();
  same_file.expect_device = decode_.frames.file_device;
  same_file.expect_inode = decode_.frames.file_inode;
  same_file.expect_first_record = decode_.frames.has_first_record;
  same_file.expect_first_record_crc = decode_.frames.first_record_crc;
  const Status s = DecodeSessionStreaming(dir_, same_file, sinks, &info);
  {
    std::lock_guard<std::mutex> lock(mu_);
    decoder_done_ = true;
    if (!stop_ && !s.ok()) decoder_status_ = s;
  }
  cv_.notify_all();
}

void SessionReplaySource::WaitForFront(std::unique_lock<std::mutex>* lock) {
  // The decoder may be waiting for room that this Take has just made (a
  // slice that took the whole queue, fewer than 16 scans): wake it before
  // waiting for it, or both wait on each other.
  if (queue_.empty() && !decoder_done_) cv_.notify_all();
  cv_.wait(*lock, [this] { return !queue_.empty() || decoder_done_; });
}

void SessionReplaySource::Take(Time until, SensorLog* batch) {
  taken_ = true;
  TakeUntil(motion_.wheels, until, &next_wheel_, &batch->wheels);
  TakeUntil(motion_.imu, until, &next_imu_, &batch->imu);
  bool scans_done = false;
  {
    std::unique_lock<std::mutex> lock(mu_);
    size_t taken = 0;
    for (;;) {
      WaitForFront(&lock);
      if (queue_.empty() || queue_.front().end_time() >= until) break;
      end_ = std::max(end_, queue_.front().end_time());
      queued_samples_ -= queue_.front().samples.size();
      batch->scans.push_back(std::move(queue_.front()));
      queue_.pop_front();
      // Wake the decoder as room appears, not only at the end: a slice of
      // hours (a seek's) is decoded and handed out side by side.
      if (++taken % 16 == 0) cv_.notify_all();
    }
    if (!queue_.empty()) end_ = std::max(end_, queue_.front().end_time());
    scans_done = queue_.empty() && decoder_done_;
    if (scans_done) status_ = decoder_status_;
  }
  cv_.notify_all();
  if (!batch->scans.empty())
    last_scan_end_ = std::max(last_scan_end_, batch->scans.back().end_time());
  // A decoder that failed (frames.bin unreadable) ends the replay at once,
  // not after hours of wheel and IMU records without scans.
  done_ = scans_done && (!status_.ok() ||
                         (next_wheel_ == motion_.wheels.size() && next_imu_ == motion_.imu.size()));
  if (done_ && status_.ok()) end_ = std::max(motion_end_, last_scan_end_);
}

void SessionReplaySource::Rewind() {
  StopDecoder();
  next_wheel_ = next_imu_ = 0;
  last_scan_end_ = Time();
  done_ = false;
  taken_ = false;
  status_ = Status::Ok();
  StartDecoder();
}

size_t SessionReplaySource::motion_bytes() const {
  return motion_.wheels.capacity() * sizeof(WheelSpeedMeasurement) +
         motion_.imu.capacity() * sizeof(ImuMeasurement);
}

size_t SessionReplaySource::peak_queued_samples() const {
  std::lock_guard<std::mutex> lock(mu_);
  return peak_queued_samples_;
}

size_t SessionReplaySource::decoder_waits() const {
  std::lock_guard<std::mutex> lock(mu_);
  return decoder_waits_;
}

}  // namespace sweepscan::hardware
