// Where a replay takes its records: a recording's records in robot-time
// order, handed out a stretch of time at a time, as a live link would have
// delivered them (docs/desktop-app.md, "Replay").
//
//   LogReplaySource      a recording decoded whole (a simulation, a small
//                        session, an imported bag): indices into its log.
//   SessionReplaySource  a session read as it is replayed: the wheel and IMU
//                        records decoded up front (about 20 MB an hour of
//                        drive), the lidar's scans decoded from frames.bin on
//                        a thread of the source's own, a bounded stretch ahead
//                        of the replay. A replay then holds no decoded samples
//                        (24 bytes each: 3.1 GiB for the 5.7-hour drive of
//                        docs/performance.md when decoded whole).
//
// Both hand out the same records in the same order for the same session
// (DecodeSessionStreaming decodes a device exactly as DecodeSession does), so
// a replay's cloud does not depend on which one feeds it.
//
// Not thread-safe: one thread (the app's processing thread) calls a source;
// SessionReplaySource's decoder thread is internal.
#ifndef SWEEPSCAN_HARDWARE_STATION_REPLAY_SOURCE_H_
#define SWEEPSCAN_HARDWARE_STATION_REPLAY_SOURCE_H_

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "core/common/status.h"
#include "core/robot/robot_model.h"
#include "core/robot/sensor_data.h"
#include "hardware/link/telemetry_decoder.h"
#include "hardware/station/recording.h"

namespace sweepscan::hardware {

class ReplaySource {
 public:
  virtual ~ReplaySource() = default;

  const std::string& name() const { return name_; }  // "session DIR", for messages
  const RobotGeometry& geometry() const { return geometry_; }
  const Pose2d& start_pose() const { return start_pose_; }  // the robot at the first record

  // Robot time of the first record (a wheel or IMU record, or a scan's
  // first sample), and of the last one: a session read as it is replayed
  // knows its last scan only once it has read it, and until then gives the
  // last agent frame's time, at or after every record's.
  virtual Time start() const = 0;
  virtual Time end() const = 0;

  // Appends to *batch every record not handed out yet that a live link had
  // delivered before robot time `until`: wheel and IMU records with
  // time < until, scans with end_time() < until (a revolution arrives when
  // it is complete). Each stream stays in time order.
  virtual void Take(Time until, SensorLog* batch) = 0;
  // Every record handed out (as of the last Take).
  virtual bool done() const = 0;
  // Hands out from the first record again (a seek backwards).
  virtual void Rewind() = 0;
  // Nothing handed out since it was made or rewound (a replay starting on
  // it need not rewind: a session's decoder would start over for nothing).
  virtual bool at_start() const = 0;
  // Why the records ended before the recording's end (frames.bin could not
  // be read when the replay started over); done() is then true at once.
  // Ok otherwise.
  virtual Status status() const { return Status::Ok(); }

 protected:
  std::string name_;
  RobotGeometry geometry_;
  Pose2d start_pose_;
};

class LogReplaySource final : public ReplaySource {
 public:
  explicit LogReplaySource(std::shared_ptr<const Recording> recording);

  Time start() const override { return start_; }
  Time end() const override { return end_; }
  void Take(Time until, SensorLog* batch) override;
  bool done() const override;
  void Rewind() override { next_wheel_ = next_imu_ = next_scan_ = 0; }
  bool at_start() const override { return next_wheel_ == 0 && next_imu_ == 0 && next_scan_ == 0; }

 private:
  std::shared_ptr<const Recording> recording_;
  Time start_, end_;
  size_t next_wheel_ = 0, next_imu_ = 0, next_scan_ = 0;
};

class SessionReplaySource final : public ReplaySource {
 public:
  // Scans decoded ahead of the replay, at most (about 50 s of an X4 at
  // 5 000 samples a second: 6 MB).
  static constexpr size_t kAheadSamples = 1 << 18;

  // Decodes the session's wheel and IMU records (the lidar's bytes are
  // skipped: a few seconds for hours of drive; progress and cancel as
  // DecodeSession's) and starts the scans' decoder. Damaged stretches are
  // skipped as by OpenRecording (DefaultSessionFramesOptions); a corrupt
  // meta.json or frames.bin that cannot be read is refused. Sessions of
  // measurements (an imported bag) are decoded whole by the decoder thread,
  // then handed out (docs/ros-bags.md). `ahead_samples`: the queue's bound.
  static Status Open(const std::string& session_dir, const DecodeProgress& progress,
                     std::unique_ptr<SessionReplaySource>* source,
                     size_t ahead_samples = kAheadSamples);
  ~SessionReplaySource() override;  // stops the decoder

  Time start() const override { return start_; }
  Time end() const override { return end_; }
  void Take(Time until, SensorLog* batch) override;
  bool done() const override { return done_; }
  void Rewind() override;
  bool at_start() const override { return !taken_; }
  Status status() const override { return status_; }

  // What Open's pass found: meta.json, frames.bin's damage, the link (the
  // lidar's codec counts stay zero: its bytes were skipped).
  const SessionDecodeInfo& decode() const { return decode_; }
  // The wheel and IMU records, held for the replays (about 20 MB an hour).
  const SensorLog& motion() const { return motion_; }
  size_t motion_bytes() const;
  // Scans the decoder had to wait for room in its queue (the replay was
  // behind it), and the most samples the queue held: for tests and figures.
  size_t decoder_waits() const;
  size_t peak_queued_samples() const;

 private:
  SessionReplaySource() = default;
  void StartDecoder();
  void StopDecoder();
  void Decode();  // the decoder thread
  // Waits until the queue's first scan is known (or the decoder is done).
  // Requires lock held.
  void WaitForFront(std::unique_lock<std::mutex>* lock);

  std::string dir_;
  size_t ahead_samples_ = kAheadSamples;
  SessionDecodeInfo decode_;
  SensorLog motion_;
  size_t next_wheel_ = 0, next_imu_ = 0;
  Time start_, end_;
  Time motion_end_;     // the last wheel or IMU record's time
  Time last_scan_end_;  // of the scans handed out since the last rewind
  bool done_ = false;
  bool taken_ = false;  // a Take since the last rewind
  Status status_;

  std::thread decoder_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<LidarScan> queue_;     // guarded by mu_
  size_t queued_samples_ = 0;       // guarded by mu_
  bool decoder_done_ = false;       // guarded by mu_
  bool stop_ = false;               // guarded by mu_
  Status decoder_status_;           // guarded by mu_
  size_t decoder_waits_ = 0;        // guarded by mu_
  size_t peak_queued_samples_ = 0;  // guarded by mu_
};

}  // namespace sweepscan::hardware

#endif  // SWEEPSCAN_HARDWARE_STATION_REPLAY_SOURCE_H_
