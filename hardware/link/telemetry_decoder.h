// From recorded link frames to sensor records: Telemetry messages carry each
// device's raw bytes with the robot's receive time; this feeds them to the
// X4, HI219 and motor-board decoders and converts their output into the
// core's SensorLog:
//   lidar:  one LidarScan per X4 revolution; theta = convention(corrected X4
//           angle), range_m = distance_mm / 1000 (0 for invalid samples),
//           sample times from the X4 decoder's time-stamp rule.
//   imu:    gyro z (rad/s), roll/pitch/yaw (rad), time = frame receive time.
//   wheels: (left, right) = WheelsFromTwist(vx, wz, wheel_distance) of each
//           motor-board feedback frame (Eq. 2-3 inverted), time = receive time.
// Device latencies are subtracted from the receive times (options).
//
// Threading: TelemetryDecoder is used from one thread at a time (the
// processing thread); DecodeSession is a pure function of the folder.
#ifndef SWEEPSCAN_HARDWARE_LINK_TELEMETRY_DECODER_H_
#define SWEEPSCAN_HARDWARE_LINK_TELEMETRY_DECODER_H_

#include <functional>
#include <string>

#include <array>

#include "core/common/status.h"
#include "core/robot/robot_model.h"
#include "core/robot/sensor_data.h"
#include "core/session/measurements.h"
#include "core/session/session.h"
#include "hardware/codecs/hi219_codec.h"
#include "hardware/codecs/motor_board_codec.h"
#include "hardware/codecs/x4_codec.h"
#include "hardware/link/link_protocol.h"

namespace sweepscan {
namespace hardware {

struct TelemetryDecoderOptions {
  double wheel_distance_m = RobotGeometry().wheel_distance_m;
  LidarAngleConvention lidar_angle_convention;
  X4DecoderOptions x4;  // keep_packets is forced off (only revolutions are used).
  // IMU and motor-board frame times (docs/device-codecs.md, "Time stamps"):
  // the data in a frame was measured before its bytes were sent, so
  //   t = receive_time - latency - frame_bytes * 10 / baud
  // with each decoded frame's own length (8N1, 10 bits a byte): an 82-byte
  // HI219 0x91 frame at 115200 baud is 7.118 ms, a legacy frame its own
  // length, a 24-byte motor feedback frame 2.083 ms. baud <= 0 drops the
  // transmission term. latency: further delay (adapter, driver), 0 by default.
  // A session's meta.json may set these under settings.serial
  // (SerialSettingsFromMeta); the lidar's are x4.baud_rate and x4.latency.
  double imu_baud = 115200.0;
  double motor_baud = 115200.0;
  Duration imu_latency{0};
  Duration motor_latency{0};
  // False: that device's bytes are counted but not decoded (no records,
  // no codec stats). A pass that needs only the wheel and IMU records (the
  // poses) saves the X4 decode, about a third of reading a session; one
  // that needs only the scans saves the HI219's and motor board's.
  bool decode_lidar = true;
  bool decode_motion = true;  // the IMU and the motor board

  bool IsValid(std::string* error) const;
};

struct TelemetryDecoderStats {
  uint64_t telemetry_messages = 0;
  uint64_t other_messages = 0;            // Non-telemetry link messages (ignored).
  uint64_t unknown_device_messages = 0;   // Telemetry from a device id we do not decode.
  uint64_t device_bytes[3] = {0, 0, 0};   // lidar, imu, motor board.
  uint64_t imu_samples_without_data = 0;  // HI219 frames with neither gyro nor Euler angles.
  uint64_t late_messages = 0;   // Telemetry the agent resent from its buffer after an outage.
  uint64_t late_bytes = 0;
  uint64_t breaks = 0;          // Telemetry marked "bytes before this were lost" (codec restarted).
  DecoderStats x4;
  DecoderStats hi219;
  DecoderStats motor;

  std::string ToString() const;
};

// One outage of the robot link within a recording, from the recorder's
// events (docs/session-format.md, "Recorder events") and the telemetry
// around them.
struct SessionLinkGap {
  double lost_at_s = 0.0;      // Last frame before it, seconds after the recording's first
                               // agent frame (DecodeSession; the decoder alone: robot time).
  std::string reason;          // "no frame for 2.0 s", "connection reset", ...
  bool restored = false;       // False: the recording ended during the outage.
  double outage_s = 0.0;       // Link down (workstation clock).
  uint32_t attempts = 0;       // Connection attempts.
  bool resumed = false;        // The agent was asked for what it buffered.
  bool new_clock_epoch = false;
  uint32_t epoch = 0;
  double robot_time_shift_s = 0.0;
  double tie_uncertainty_s = 0.0;
  uint64_t late_messages = 0;  // Resent by the agent from its buffer.
  uint64_t late_bytes = 0;
  // Per device (lidar, IMU, motor board): seconds of data lost (the time
  // between the last bytes before and the first after, where the agent said
  // bytes were lost); 0 when its buffer covered the outage.
  std::array<double, 3> data_lost_s{};
  std::string ToString() const;
};

class TelemetryDecoder {
 public:
  explicit TelemetryDecoder(const TelemetryDecoderOptions& options = TelemetryDecoderOptions());

  // Any link message: Telemetry is decoded; a RecorderEvent of a restored
  // link sets the time shift of the new clock epoch and opens a gap.
  void Add(const LinkMessage& message);
  void AddTelemetry(const Telemetry& telemetry);
  // Added to every Telemetry receive time from now on: a robot clock epoch
  // after a reboot, placed on the first epoch's timeline (RecorderEvent).
  void SetTimeShift(Duration shift) { time_shift_ = shift; }
  Duration time_shift() const { return time_shift_; }
  // The link outages seen in RecorderEvents so far (DecodeSession's info).
  const std::vector<SessionLinkGap>& gaps() const { return gaps_; }

  // Moves everything decoded since the last call to the end of *log (each
  // stream stays in time order as long as the telemetry was in order).
  void TakeInto(SensorLog* log);

  TelemetryDecoderStats stats() const;

 private:
  TelemetryDecoderOptions options_;
  X4Decoder x4_;
  Hi219Decoder hi219_;
  MotorFeedbackDecoder motor_;
  TelemetryDecoderStats stats_;
  SensorLog pending_;
  Duration time_shift_{0};
  std::vector<SessionLinkGap> gaps_;
  std::array<bool, 3> have_time_{};
  std::array<Time, 3> last_time_{};  // Per device, shifted.
  Time last_robot_time_;
};

// Applies a session's settings.serial (docs/session-format.md) to *options:
//   "serial": {"lidar_baud": 128000, "imu_baud": 115200, "motor_baud": 115200,
//              "lidar_latency_s": 0, "imu_latency_s": 0, "motor_latency_s": 0}
// every key optional (absent: the option is left as it is, so sessions
// without the key decode as before); bauds are numbers >= 0 (0: no
// transmission term), latencies numbers in [0, 1] s. Strict: unknown keys and
// wrong types are refused with `source` and the JSON path.
Status SerialSettingsFromMeta(const SessionMeta& meta, const std::string& source,
                              TelemetryDecoderOptions* options);

// What DecodeSession found, for `sweepscan-cli info` and the logs.
struct SessionDecodeInfo {
  SessionMeta meta;
  FramesLoadReport frames;
  uint64_t frames_refused = 0;  // Records that are not one valid link frame (skipped).
  std::string first_refusal;    // e.g. "record 12: link frame: frame CRC mismatch".
  LinkDecoderStats link;        // Sequence gaps per sender (frames lost before recording).
  TelemetryDecoderStats telemetry;
  std::vector<SessionLinkGap> gaps;  // Link outages during the recording, in order.
  Time first_robot_time;  // Header time of the first / last agent frame.
  Time last_robot_time;
  // Measurement sessions (meta.content "measurements", an imported bag):
  // what their records held; the link and telemetry counters stay zero.
  bool measurements = false;
  MeasurementDecodeStats measurement_stats;

  std::string ToString() const;
};

// What DecodeSession uses unless told otherwise: damaged records of
// frames.bin are skipped and described in info->frames.damage (a measuring
// instrument must not lose an hour of scanning to one bad sector). Callers
// warn with info->frames.DamageSummary(); `--strict` refuses instead.
FramesLoadOptions DefaultSessionFramesOptions();

// Loads a session folder and decodes it with the geometry, lidar angle
// convention and serial settings (settings.serial) of its meta.json, and
// otherwise default decoder options.
// Records that do not hold exactly one valid link frame are skipped and
// counted; damaged stretches of frames.bin are skipped and reported in
// info->frames (DefaultSessionFramesOptions); a corrupt meta.json is an error.
Status DecodeSession(const std::string& session_dir, SensorLog* log, SessionDecodeInfo* info);
// Progress of a long decode: called with the fraction done (0..1, monotone,
// ending at 1 on success); returning false cancels (the call then fails with
// "cancelled"). Called every 4096 records, so a cancel takes effect within
// milliseconds.
using DecodeProgress = std::function<bool(double fraction)>;
// The same with explicit frames.bin options (skip_corrupt_records = false:
// a damaged record is an error with its place, the CLI's --strict).
Status DecodeSession(const std::string& session_dir, const FramesLoadOptions& frames_options,
                     SensorLog* log, SessionDecodeInfo* info,
                     const DecodeProgress& progress = nullptr);
// The same with progress and cancel (the desktop app's open job).
Status DecodeSession(const std::string& session_dir, SensorLog* log, SessionDecodeInfo* info,
                     const DecodeProgress& progress);
// The same with explicit decoder options (wheel distance, convention and
// serial settings are taken from the options, not from meta.json).
Status DecodeSession(const std::string& session_dir, const TelemetryDecoderOptions& options,
                     SensorLog* log, SessionDecodeInfo* info);
// Where a streaming decode hands what it decodes, as it goes (every 256
// records, each stream in time order). `scan` returning false stops the
// decode (it then fails with "cancelled"); a null `scan` drops the scans,
// a null `motion` the IMU and wheel records.
struct SessionStreamSinks {
  std::function<bool(LidarScan&& scan)> scan;
  SensorLog* motion = nullptr;  // wheels and imu appended; scans untouched
};
// DecodeSession without holding the session: frames.bin is visited record
// by record through a mapping whose pages are dropped behind the reader
// (core/session/session.h VisitFramesFile), and the decoded records go to
// the sinks. Memory is what the sinks keep. The records decoded, their
// order and *info are exactly DecodeSession's, except that a device
// without a sink is not decoded (no scan sink: decode_lidar off, and
// info->telemetry.x4 stays zero; no motion sink: decode_motion off, and
// .hi219, .motor and .imu_samples_without_data stay zero). Measurement
// sessions (an imported bag) are loaded whole, then handed out.
Status DecodeSessionStreaming(const std::string& session_dir, const TelemetryDecoderOptions& options,
                              const FramesLoadOptions& frames_options, const SessionStreamSinks& sinks,
                              SessionDecodeInfo* info, const DecodeProgress& progress = nullptr);
// The same with the decoder options of the session's meta.json (as DecodeSession).
Status DecodeSessionStreaming(const std::string& session_dir, const FramesLoadOptions& frames_options,
                              const SessionStreamSinks& sinks, SessionDecodeInfo* info,
                              const DecodeProgress& progress = nullptr);
// The decoding part alone, on records already loaded; *info must not be null
// (its frames_refused, link, telemetry and robot times are filled).
// With `progress`, returns false if it cancelled (the log is then partial).
bool DecodeSessionRecords(const std::vector<SessionRecord>& records,
                          const TelemetryDecoderOptions& options, SensorLog* log,
                          SessionDecodeInfo* info, const DecodeProgress& progress = nullptr);

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_LINK_TELEMETRY_DECODER_H_
