// Session folders: a recording of every robot link frame the workstation
// received, with its receive time, plus metadata (robot geometry, lidar angle
// convention, calibration, settings, notes). Format: docs/session-format.md.
//
//   NAME.sweepscan/
//     frames.bin   append-only: 16-byte file header, then records
//                  [u32 length][i64 receive time ns][length bytes][u32 CRC-32C]
//     meta.json    written atomically (temporary file + fsync + rename)
//     picks.json, calibration.json, ...  added later by other tools
//
// The core stores the link frames as opaque bytes (core must not depend on
// hardware/); hardware/link/telemetry_decoder.h turns them into sensor records.
//
// Durability: SessionWriter buffers appends in memory and hands them to the
// kernel (write) and the disk (fsync) whenever FlushIfDue() finds the flush
// interval elapsed, on Flush() and on Close(). A process killed by SIGKILL
// loses at most what was appended since the last write(); a power loss at
// most what was appended since the last fsync. A reader drops a torn final
// record (and says so) and refuses corruption elsewhere with its byte offset.
//
// Threading: a SessionWriter is used from one thread (the recorder); the
// loaders are pure functions.
#ifndef SWEEPSCAN_CORE_SESSION_SESSION_H_
#define SWEEPSCAN_CORE_SESSION_SESSION_H_

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/common/time.h"
#include "core/pose/odometry.h"
#include "core/robot/robot_model.h"

namespace sweepscan {

inline constexpr uint32_t kSessionFormatVersion = 1;
// frames.bin starts with these 8 bytes (PNG-style: a non-ASCII first byte,
// and CR LF / SUB / LF to detect text-mode mangling), then u32 version, u32 0.
inline constexpr uint8_t kSessionFramesMagic[8] = {0x89, 'S', 'W', 'F', 0x0D, 0x0A, 0x1A, 0x0A};
inline constexpr size_t kSessionFramesHeaderSize = 16;
inline constexpr size_t kSessionRecordOverhead = 16;  // u32 length + i64 time + u32 CRC.
// Records longer than this are corrupt (a link frame is at most 64 KiB + 32).
inline constexpr uint32_t kSessionMaxRecordBytes = 1u << 20;
inline constexpr char kSessionFramesFile[] = "frames.bin";

// The bytes of frames.bin as SessionWriter writes them (docs/session-format.md):
// the 16-byte header, and one record appended to `out` (u32 length, i64
// receive time, the bytes, CRC-32C of the three; little-endian). For a
// writer of its own kind (`sweepscan-cli repair`).
std::vector<uint8_t> SessionFramesHeader();
void AppendSessionRecord(const uint8_t* bytes, size_t n, int64_t receive_time_ns,
                         std::vector<uint8_t>* out);
inline constexpr char kSessionMetaFile[] = "meta.json";

// Everything meta.json holds (docs/session-format.md, "meta.json").
struct SessionMeta {
  uint32_t format_version = kSessionFormatVersion;
  std::string created_utc;  // ISO 8601, e.g. "2026-11-22T10:15:00Z"; filled by Create() if empty.
  RobotGeometry geometry;
  LidarAngleConvention lidar_angle_convention;
  MountingError calibration;  // alpha, beta, gamma (rad) in use while recording.
  std::string link;           // Where the frames came from: "tcp:127.0.0.1:5600",
                              // "serial:/dev/ttyUSB0@921600", "sim".
  std::string agent;          // The agent's Hello name, if known.
  nlohmann::json settings = nlohmann::json::object();  // Owned by the components that wrote them.
  std::string notes;
  // What frames.bin's records hold: "" (the default, not written) = robot
  // link frames as received; kSessionContentMeasurements = decoded sensor
  // measurements (core/session/measurements.h), as an imported ROS bag
  // gives them. Readers that do not know this key refuse the session.
  std::string content;
};
inline constexpr char kSessionContentMeasurements[] = "measurements";

// The world pose the recording starts at, which fixes the frame its clouds
// and picks are in: a simulated session's scenario start
// (settings.scenario.path.start, written by `sweepscan-cli simulate`), so
// that it lines up with the scenario's world; an imported bag's first
// odometry pose (settings.import.start), so that its clouds are in the
// bag's odometry frame; otherwise the origin (a real robot's world is its
// start pose).
Pose2d SessionStartPose(const SessionMeta& meta);
// What recorded the session, as a LAS file's System Identifier names it
// (ASPRS LAS 1.4 §2.4, docs/las-format.md): the hardware for a robot's
// recording, the operation otherwise (a simulation: a link named "sim..."
// or a scenario in the settings; an imported bag, whose sensors are
// unknown: "OTHER").
std::string SessionSystemIdentifier(const SessionMeta& meta);

nlohmann::json SessionMetaToJson(const SessionMeta& meta);
// Strict: missing keys, wrong types, unknown keys, out-of-range values and an
// unsupported format_version are refused with `source` and the JSON path.
Status SessionMetaFromJson(const nlohmann::json& j, const std::string& source, SessionMeta* meta);
Status ReadSessionMeta(const std::string& path, SessionMeta* meta);
Status WriteSessionMeta(const std::string& path, const SessionMeta& meta);  // Atomic.

// One received link frame.
struct SessionRecord {
  int64_t receive_time_ns =
      0;  // Workstation CLOCK_REALTIME, ns since the Unix epoch (informational).
  std::vector<uint8_t> bytes;
};

struct FramesLoadOptions {
  // false (default here; `--strict` in the CLI): a corrupt record before the
  // end of the file is an error.
  // true (what the CLI and the app use by default): the damaged bytes are
  // skipped up to the next intact record (found by its CRC, whatever the
  // damaged length field says) and described in FramesLoadReport::damage.
  bool skip_corrupt_records = false;
  // A pass after the first over the same session (the streamed readers open
  // frames.bin once a pass): the file must be the one the first pass read
  // (FramesLoadReport's file_device and file_inode), or the read fails
  // before any record. A session recorded over in the meantime (`record
  // --overwrite`) mixed one file's poses with another's scans. 0, 0: any.
  uint64_t expect_device = 0;
  uint64_t expect_inode = 0;
  // Or, when the first pass saw a whole first record, its CRC field must be
  // this one (the inode alone may change, or come back: frames_file.cc).
  bool expect_first_record = false;
  uint32_t expect_first_record_crc = 0;
};

// One damaged stretch of frames.bin that was skipped.
struct FramesDamage {
  uint64_t first_record = 0;   // Index of the first record lost.
  uint64_t records = 0;        // Records lost (read from their length fields where usable).
  uint64_t offset = 0;         // Byte offset of the damage in the file.
  uint64_t bytes = 0;          // Bytes skipped.
  std::string reason;          // "CRC mismatch", "absurd length 4294967295".
  // Receive times (ns, workstation wall clock) of the intact records around
  // it; has_before / has_after are false at the start / end of the file.
  bool has_before = false;
  bool has_after = false;
  int64_t time_before_ns = 0;
  int64_t time_after_ns = 0;
  // The damage runs to the end of the file (no intact record after it):
  // `records` and the seconds lost are then estimated from the intact
  // records' mean size and data rate (the lengths in damaged bytes stop
  // being usable within a record or two).
  bool to_end_of_file = false;
  double estimated_seconds_lost = 0.0;

  // Seconds of data lost: the gap between the intact neighbours, or the
  // estimate for damage to the end of the file (0 if unknown).
  double SecondsLost() const;
};

struct FramesLoadReport {
  uint32_t format_version = 0;
  uint64_t records = 0;       // Records loaded.
  uint64_t record_bytes = 0;  // Sum of their payload sizes.
  uint64_t file_bytes = 0;
  uint64_t valid_bytes = 0;     // Offset just after the last good record (where appending resumes).
  bool truncated_tail = false;  // A torn final record was dropped.
  uint64_t tail_bytes_dropped = 0;
  std::string tail_reason;  // e.g. "record 812 at byte 53211: needs 96 bytes, 40 left".
  uint64_t corrupt_records_skipped = 0;  // Sum of damage[i].records.
  std::vector<FramesDamage> damage;      // Skipped damaged stretches, in file order.
  int64_t first_time_ns = 0;             // Receive times of the first and last good record.
  int64_t last_time_ns = 0;
  uint64_t file_device = 0;  // The file read (VisitFramesFile; 0 from memory).
  uint64_t file_inode = 0;
  bool has_first_record = false;  // Its first record is whole; its CRC field:
  uint32_t first_record_crc = 0;

  bool damaged() const { return !damage.empty(); }
  uint64_t damaged_bytes() const;
  double seconds_lost() const;
  // One line: "3 damaged records skipped (252 bytes; about 0.30 s of data lost):
  // record 12 at byte 4567 (CRC mismatch, 0.10 s at 1.2 s into the recording), ..."
  // (at most 5 places listed). Empty when not damaged.
  std::string DamageSummary() const;
  std::string ToString() const;
};

// One intact record of frames.bin as a reader visits it: the bytes point
// into the file's mapping and are valid only during the call.
struct SessionRecordView {
  uint64_t ordinal = 0;  // Among the intact records (what LoadFramesFile's vector index would be).
  int64_t receive_time_ns = 0;
  const uint8_t* bytes = nullptr;
  size_t size = 0;
  uint64_t offset = 0;      // Of the record in the file (progress: offset / file_bytes).
  uint64_t file_bytes = 0;
};
// Returns false to stop (the visit then fails with "SOURCE: cancelled").
using FrameVisitor = std::function<bool(const SessionRecordView& record)>;

// Parses frames.bin content. `source` names it in messages
// ("lab.sweepscan/frames.bin"). Error messages look like
//   lab.sweepscan/frames.bin: record 1234 at byte 5678901: CRC mismatch
// A torn tail (an incomplete final record, or a complete final record whose
// CRC fails) is not an error: it is dropped and reported in *report.
Status LoadFramesFromMemory(const uint8_t* data, size_t n, const std::string& source,
                            const FramesLoadOptions& options, std::vector<SessionRecord>* records,
                            FramesLoadReport* report);
Status LoadFramesFile(const std::string& path, const FramesLoadOptions& options,
                      std::vector<SessionRecord>* records, FramesLoadReport* report);
// The same checks and report, visiting each intact record in file order
// instead of keeping them: memory stays bounded whatever the file's size
// (the streaming readers of a long session, hardware/link/telemetry_decoder.h).
Status VisitFramesInMemory(const uint8_t* data, size_t n, const std::string& source,
                           const FramesLoadOptions& options, const FrameVisitor& visit,
                           FramesLoadReport* report);
Status VisitFramesFile(const std::string& path, const FramesLoadOptions& options,
                       const FrameVisitor& visit, FramesLoadReport* report);

struct Session {
  std::string dir;
  SessionMeta meta;
  std::vector<SessionRecord> records;
  FramesLoadReport frames;
};
// Reads meta.json (strictly) and every complete record of frames.bin.
Status LoadSession(const std::string& dir, const FramesLoadOptions& options, Session* session);

struct SessionWriterOptions {
  // Replace an existing session in the folder (frames.bin, meta.json and the
  // derived files picks.json, calibration.json are deleted first). Default:
  // refuse when the folder exists and is not empty.
  bool overwrite = false;
  // FlushIfDue() writes and fsyncs when this much time passed since the last
  // sync. With the caller ticking every <= 0.25 s and fsync taking < 0.25 s,
  // everything older than 1 s is on disk.
  std::chrono::steady_clock::duration flush_interval = std::chrono::milliseconds(500);
  // Appends beyond this many buffered bytes are written to the kernel at once
  // (no fsync), bounding the memory.
  size_t max_buffered_bytes = 4u << 20;
  // FlushIfDue() (and the writes above max_buffered_bytes) hand the bytes
  // and the fdatasync to a thread of the writer's and return at once;
  // Flush() and Close() still wait for the disk. For a caller whose thread
  // has other work on time: a link's, which sends the robot's heartbeats,
  // must not wait for a sync that takes a second on a busy laptop disk
  // (the robot's watchdog stops it after 0.5 s). A failure there is
  // returned by the next FlushIfDue, Flush or Close (due or not). Bytes wait in memory while the disk is
  // slower than the data (an X4 recording makes ~100 kB a second).
  bool sync_on_thread = false;

  bool IsValid(std::string* error) const;
};

class BackgroundFileWriter;  // session.cc

// Gives a session written whole under another name (`from`, a sibling
// folder) its name `to`: one rename(2), so `to` never holds part of a
// session (an import killed midway leaves only `from`). Refuses a `to` that
// exists and is not an empty folder; the rename is made durable (fsync of
// the parent folder).
Status RenameSessionIntoPlace(const std::string& from, const std::string& to);
// The folder a session `dir` is written in before RenameSessionIntoPlace:
// hidden, beside it, this process's (lab.sweepscan is written as
// .lab.sweepscan.WHAT-PID, e.g. WHAT "importing"). A command killed
// midway, or a power loss, leaves that folder, never a `dir` that opens as
// if it were whole.
std::string SessionWritingDir(const std::string& dir, const std::string& what);
// Whether `dir` can take a new session: absent, or an empty folder (what
// RenameSessionIntoPlace replaces). Asked before the work, so that a folder
// in the way is said before minutes of reading.
Status CheckNewSessionFolder(const std::string& dir);
// `s` with `writing` (SessionWritingDir's) said as `dir`: the operator's
// name for where the failure was ("lab.sweepscan/frames.bin: write failed").
Status SaidOfSession(const Status& s, const std::string& writing, const std::string& dir);

class SessionWriter {
 public:
  // Creates the folder (and parents) with meta.json and an empty frames.bin.
  static Status Create(const std::string& dir, const SessionMeta& meta,
                       const SessionWriterOptions& options, std::unique_ptr<SessionWriter>* out);
  // Reopens an existing session to append: validates frames.bin, cuts a torn
  // tail (reported in *report), refuses corruption. meta.json is kept.
  static Status Open(const std::string& dir, const SessionWriterOptions& options,
                     std::unique_ptr<SessionWriter>* out, FramesLoadReport* report = nullptr);
  ~SessionWriter();  // Close(), errors ignored: call Close() to see them.
  SessionWriter(const SessionWriter&) = delete;
  SessionWriter& operator=(const SessionWriter&) = delete;

  // Buffers one record. Fails for n > kSessionMaxRecordBytes or after an
  // earlier I/O error (the writer stays failed: the file may be torn).
  Status Append(const uint8_t* bytes, size_t n, int64_t receive_time_ns);
  Status Append(const std::vector<uint8_t>& bytes, int64_t receive_time_ns) {
    return Append(bytes.data(), bytes.size(), receive_time_ns);
  }
  // The caller's time-based trigger: flushes (write + fsync) when the flush
  // interval has elapsed since the last sync and there is anything new.
  Status FlushIfDue(std::chrono::steady_clock::time_point now);
  // write + fsync now.
  Status Flush();
  Status Close();
  // Rewrites meta.json atomically (notes, calibration updated while recording).
  Status UpdateMeta(const SessionMeta& meta);

  const std::string& dir() const { return dir_; }
  uint64_t records_appended() const { return records_appended_; }
  uint64_t bytes_on_disk() const { return file_bytes_; }  // Written (not necessarily synced).

 private:
  SessionWriter(std::string dir, int fd, uint64_t file_bytes, const SessionWriterOptions& options);
  Status WriteBuffer();

  std::string dir_;
  int fd_ = -1;
  SessionWriterOptions options_;
  std::vector<uint8_t> buffer_;
  uint64_t file_bytes_ = 0;
  uint64_t records_appended_ = 0;
  bool dirty_ = false;  // Appended or written since the last fsync.
  std::chrono::steady_clock::time_point last_sync_;
  std::string failed_;  // Sticky I/O error.
  std::string created_utc_;  // meta.json's, kept by UpdateMeta
  std::unique_ptr<BackgroundFileWriter> background_;  // with sync_on_thread
};

// Current UTC time as ISO 8601 ("2026-11-22T10:15:00Z").
std::string UtcNowIso8601();

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_SESSION_SESSION_H_
