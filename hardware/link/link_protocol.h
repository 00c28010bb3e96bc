// The robot link protocol between the robot agent (sweepscan-robotd, or the
// simulator) and the workstation: framed, versioned, CRC-checked messages over
// a serial port or a TCP stream. The byte layout, the handshake and the
// watchdog rules are specified in docs/protocol.md; this header is the C++
// form of that document.
//
// Frame (all multi-byte fields little-endian):
//   header (28 bytes): sync E7 5C | version u8 | type u8 | sender u8 | reserved u8
//                      | reserved u16 | sequence u32 | time i64 ns | payload_size u32
//                      | header_crc u32 (CRC-32C of bytes 0..23)
//   payload (payload_size bytes, <= kLinkMaxPayload)
//   frame_crc u32 (CRC-32C of the header incl. header_crc, and the payload)
// The header CRC lets a receiver reject a corrupted length at once instead of
// waiting for up to 64 KiB that will never come (which would stall the
// watchdog-critical command stream).
//
// Pure C++17, no Qt. Threading: LinkDecoder and LinkEncoder are used from one
// thread at a time; the free functions are pure.
#ifndef SWEEPSCAN_HARDWARE_LINK_LINK_PROTOCOL_H_
#define SWEEPSCAN_HARDWARE_LINK_LINK_PROTOCOL_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <variant>
#include <vector>

#include "core/common/status.h"
#include "core/common/time.h"
#include "hardware/codecs/codec_common.h"

namespace sweepscan {
namespace hardware {

// ---------------------------------------------------------------------------
// Constants.

inline constexpr uint8_t kLinkSync1 = 0xE7;
inline constexpr uint8_t kLinkSync2 = 0x5C;
// Version 2 (this code) adds per-frame authentication (header flags, a
// 16-byte tag after the payload) and the two-nonce handshake. Receivers
// accept version-1 frames only to tell the operator to update the other end.
inline constexpr uint8_t kLinkProtocolVersion = 2;
inline constexpr uint8_t kLinkMinReadableVersion = 1;
inline constexpr size_t kLinkHeaderSize = 28;
inline constexpr size_t kLinkCrcSize = 4;
inline constexpr size_t kLinkFrameOverhead = kLinkHeaderSize + kLinkCrcSize;  // 32
inline constexpr size_t kLinkMaxPayload = 65536;  // Hard limit; larger frames are length errors.
inline constexpr size_t kLinkNonceSize = 32;
inline constexpr size_t kLinkMacSize = 32;
// HMAC-SHA256 input prefix of the AuthResponse:
// HMAC(key, kLinkAuthContext || agent_nonce || client_nonce).
inline constexpr char kLinkAuthContext[] = "sweepscan-link-v2";
// HKDF info of the session key (docs/protocol.md, "Frame authentication").
inline constexpr char kLinkSessionKeyInfo[] = "sweepscan-link-v2 session";
// Header byte 5 (flags), bit 0: a kLinkTagSize-byte tag follows the payload.
inline constexpr uint8_t kLinkFlagSigned = 0x01;
inline constexpr size_t kLinkTagSize = 16;
// The tag covers header bytes 0..23 (everything before header_crc) and the payload.
inline constexpr size_t kLinkSignedHeaderSize = 24;
using LinkNonce = std::array<uint8_t, kLinkNonceSize>;
using LinkTag = std::array<uint8_t, kLinkTagSize>;
inline constexpr size_t kLinkMaxFrameSize = kLinkMaxPayload + kLinkFrameOverhead + kLinkTagSize;

// Agent stops the robot when no valid frame arrived for this long (docs/protocol.md).
inline constexpr Duration kLinkDefaultWatchdog = std::chrono::milliseconds(500);
// Telemetry payload: device u8, flags u8, 2 reserved bytes, robot receive time i64.
inline constexpr size_t kTelemetryHeaderSize = 12;
inline constexpr size_t kLinkMaxTelemetryBytes = kLinkMaxPayload - kTelemetryHeaderSize;
inline constexpr size_t kLinkMaxStringSize = 255;  // Strings are u8 length + UTF-8 bytes.

enum class LinkMessageType : uint8_t {
  kHello = 0x01,
  kAuthChallenge = 0x02,
  kAuthResponse = 0x03,
  kAuthResult = 0x04,
  kDriveCommand = 0x10,
  kStop = 0x11,
  kEmergencyStop = 0x12,
  kClearEmergencyStop = 0x13,
  kHeartbeat = 0x14,
  kLidarMotor = 0x15,
  kTelemetryResume = 0x16,
  kCommandAck = 0x20,
  kStatus = 0x30,
  kTelemetry = 0x31,
  // Never on the wire: a note the workstation's recorder writes into its
  // session (docs/session-format.md, "Recorder events").
  kRecorderEvent = 0x40,
};
const char* LinkMessageTypeName(uint8_t type);  // "DriveCommand", ... or "unknown".
bool IsKnownLinkMessageType(uint8_t type);

// Who sent a frame. Sequence numbers are counted per sender.
enum class LinkSender : uint8_t { kAgent = 1, kClient = 2 };

// Devices whose raw bytes travel in Telemetry messages.
enum class LinkDevice : uint8_t { kLidar = 1, kImu = 2, kMotorBoard = 3 };
const char* LinkDeviceName(uint8_t device);  // "lidar", "imu", "motor_board" or "unknown".

// ---------------------------------------------------------------------------
// Messages (payloads). Field layouts: docs/protocol.md, "Messages".

struct HelloDevice {
  uint8_t device = 0;       // A LinkDevice value.
  std::string description;  // e.g. "YDLIDAR X4 on /dev/ttyUSB0 @128000"; <= 255 bytes.
};
// Both sides send one first. Strings longer than 255 bytes are cut on encode.
struct Hello {
  uint16_t protocol_version = kLinkProtocolVersion;  // Highest version the sender speaks.
  bool auth_required = false;        // Agent: Drive etc. need a successful AuthResponse first.
  std::string name;                  // "sweepscan-robotd 0.1.0 (robot-1)", "sweepscan 0.1.0".
  std::vector<HelloDevice> devices;  // Agent: the devices it streams; client: empty. <= 255.
};
struct AuthChallenge {
  LinkNonce nonce{};  // The agent's nonce, fresh per connection.
};
struct AuthResponse {
  LinkNonce client_nonce{};                 // The client's nonce, fresh per connection.
  std::array<uint8_t, kLinkMacSize> mac{};  // HMAC-SHA256(key, kLinkAuthContext || agent_nonce || client_nonce).
};
enum class AuthOutcome : uint8_t { kOk = 0, kDenied = 1 };
struct AuthResult {
  AuthOutcome outcome = AuthOutcome::kDenied;
  std::string reason;  // Free text for the operator, may be empty.
};
// Body-frame velocity set-point, IEEE 754 binary64. Non-finite values are
// refused by the decoder (payload error), so the agent never sees them.
// Limits (speed, acceleration) are the agent's business.
struct DriveCommand {
  double v_mps = 0.0;    // Along x_B.
  double w_radps = 0.0;  // About z_B, counter-clockwise positive.
};
struct Stop {};                // Ramp to zero with the agent's deceleration limit.
struct EmergencyStop {};       // Zero at once and latch; Drive is refused until cleared.
struct ClearEmergencyStop {};  // Releases the latch; the robot stays still until the next Drive.
struct Heartbeat {};           // Keeps the watchdog fed; the agent acks it (latency).
struct LidarMotor {
  bool on = false;
};
// Client -> agent, right after a reconnection: "send me, from what you kept
// while I was away, the device bytes after these points" (docs/protocol.md,
// "TelemetryResume"). One position per device (lidar, IMU, motor board).
struct TelemetryResumePosition {
  bool have = false;        // The client holds bytes of this device from this clock epoch.
  Time after_time;          // Receive time of the last Telemetry chunk it holds.
  uint32_t bytes_at_time = 0;  // Bytes it holds of chunks with exactly that receive time.
};
struct TelemetryResume {
  std::array<TelemetryResumePosition, 3> devices;
};
// The recorder's note in a session (sender kClient, never sent on a link).
enum class RecorderEventKind : uint8_t { kLinkLost = 1, kLinkRestored = 2 };
struct RecorderEvent {
  RecorderEventKind kind = RecorderEventKind::kLinkLost;
  bool new_clock_epoch = false;  // Restored: the robot clock was reset (reboot) during the outage.
  bool resumed = false;          // Restored: the agent was asked for what it buffered.
  uint32_t epoch = 0;            // Robot clock epoch from now on (0 = the session's first).
  Time workstation_time;         // Workstation clock (CLOCK_BOOTTIME) at the event.
  Time robot_time;               // Lost: last robot time received; restored: first of the new link.
  Duration outage{};             // Restored: link down (lost event -> authenticated again).
  Duration robot_time_shift{};   // Restored: add to this epoch's robot times to place them on
                                 // the first epoch's timeline (0 in epoch 0).
  Duration tie_uncertainty{};    // Restored: +- of the robot-to-workstation clock tie.
  uint32_t attempts = 0;         // Restored: connection attempts it took.
  std::string reason;            // Lost: why ("no frame for 2.0 s", "connection reset", ...).
};
enum class AckResult : uint8_t {
  kAccepted = 0,
  kNotAuthenticated = 1,
  kEmergencyStopLatched = 2,
  kInvalid = 3,      // e.g. value out of the agent's accepted range.
  kUnsupported = 4,  // The agent does not implement this message (e.g. no lidar motor).
};
// Agent -> client, for every command frame (Drive, Stop, EmergencyStop,
// ClearEmergencyStop, LidarMotor, Heartbeat). echo_time is the acked frame's
// header time, so the client measures round trip = now - echo_time on its own clock.
struct CommandAck {
  uint32_t acked_sequence = 0;
  uint8_t acked_type = 0;
  AckResult result = AckResult::kAccepted;
  Time echo_time;
};
// Status fault bits.
enum LinkFault : uint32_t {
  kFaultLidarSilent = 1u << 0,       // No lidar bytes for > 1 s while the motor is on.
  kFaultImuSilent = 1u << 1,         // No IMU bytes for > 1 s.
  kFaultMotorBoardSilent = 1u << 2,  // No motor-board feedback for > 1 s.
  kFaultLowBattery = 1u << 3,        // Below the agent's configured threshold.
  kFaultMotorBoardStop = 1u << 4,    // The board reports its stop flag.
  kFaultDevicePortError = 1u << 5,   // A serial port could not be opened / was lost.
};
enum class WatchdogState : uint8_t {
  kIdle = 0,     // No motion commanded; nothing to watch.
  kArmed = 1,    // Motion commanded; a valid frame is expected within the watchdog period.
  kTripped = 2,  // The period passed without a frame; the robot was stopped. Next Drive re-arms.
};
// Agent -> client, periodically (10 Hz suggested) and on any change of state.
struct LinkStatus {
  float battery_voltage_v = 0.0f;
  uint32_t fault_bits = 0;  // LinkFault bits.
  WatchdogState watchdog = WatchdogState::kIdle;
  bool emergency_stop_latched = false;
  bool client_authenticated = false;
  bool lidar_motor_on = false;
  double commanded_v_mps = 0.0;  // Last accepted Drive (after the agent's limits).
  double commanded_w_radps = 0.0;
  double applied_v_mps = 0.0;  // What the motor board is being sent now (ramped).
  double applied_w_radps = 0.0;
  uint32_t frames_received = 0;   // Valid frames from the client since the agent started.
  uint32_t frames_rejected = 0;   // CRC / length / framing errors on the client stream.
  uint32_t commands_refused = 0;  // Acks with a result other than kAccepted.
  uint32_t watchdog_trips = 0;
  std::array<uint64_t, 3> device_bytes{};  // Raw bytes read per device: lidar, imu, motor board.
};
// Agent -> client: raw bytes of one device, as read from its serial port.
// Telemetry flags (payload byte 1).
inline constexpr uint8_t kTelemetryLate = 1;   // Read while no client took it; sent from the buffer.
inline constexpr uint8_t kTelemetryBreak = 2;  // Bytes of this device before this chunk were lost.
struct Telemetry {
  uint8_t device = 0;  // A LinkDevice value.
  Time receive_time;   // Robot clock when the agent read the bytes (the codecs' receive_time).
  std::vector<uint8_t> bytes;  // <= kLinkMaxTelemetryBytes.
  uint8_t flags = 0;   // kTelemetryLate | kTelemetryBreak.
};
// A frame with a good CRC but a type this code does not know (a newer peer).
struct UnknownMessage {
  uint8_t type = 0;
  std::vector<uint8_t> payload;
};

using LinkPayload = std::variant<Hello, AuthChallenge, AuthResponse, AuthResult, DriveCommand, Stop,
                                 EmergencyStop, ClearEmergencyStop, Heartbeat, LidarMotor,
                                 TelemetryResume, CommandAck, LinkStatus, Telemetry, RecorderEvent,
                                 UnknownMessage>;

// The wire type of a payload (UnknownMessage: its own `type`).
uint8_t LinkPayloadType(const LinkPayload& payload);

struct LinkHeader {
  uint8_t version = kLinkProtocolVersion;
  uint8_t type = 0;
  LinkSender sender = LinkSender::kAgent;
  bool signed_frame = false;  // Flags bit 0: a tag follows the payload.
  uint32_t sequence = 0;
  // Sender's monotonic clock: robot time for the agent, the workstation's
  // steady clock for the client (only echoed back, never mixed with robot time).
  Time time;
  uint32_t payload_size = 0;
};

struct LinkMessage {
  LinkHeader header;
  LinkPayload payload;
  // The complete frame as received; filled only with
  // LinkDecoderOptions::keep_raw_frames (the session recorder stores it).
  std::vector<uint8_t> raw;
  // Signed frames only: the tag, and the bytes it covers (header bytes
  // 0..23 followed by the payload), for LinkFrameTagValid (hmac_sha256.h).
  LinkTag tag{};
  std::vector<uint8_t> signed_bytes;
};

// Computes the tag of a frame being encoded from its header bytes 0..23 and
// its payload (hardware/link/hmac_sha256.h: MakeLinkFrameSigner). Kept as a
// callback so the protocol code itself needs no crypto library.
using LinkFrameSigner =
    std::function<LinkTag(const uint8_t* header24, const uint8_t* payload, size_t payload_size)>;

// ---------------------------------------------------------------------------
// Encoding.

// Payload bytes of a message (no frame). Strings and lists longer than their
// u8 length field allows are cut (255); Telemetry bytes beyond
// kLinkMaxTelemetryBytes are cut too (the agent splits its reads instead).
void EncodeLinkPayload(const LinkPayload& payload, std::vector<uint8_t>* out);

// Appends one complete frame to *out. Returns false (appending nothing) when
// the payload exceeds kLinkMaxPayload (only an UnknownMessage can).
bool AppendLinkFrame(LinkSender sender, uint32_t sequence, Time time, const LinkPayload& payload,
                     std::vector<uint8_t>* out);

// Wraps already encoded payload bytes in a frame (header, CRCs) of type
// `type`. Returns false (appending nothing) when n > kLinkMaxPayload. With a
// signer, the frame is signed (flags bit 0, tag after the payload). `version`
// other than kLinkProtocolVersion only for telling an old peer why it is refused.
bool AppendRawLinkFrame(LinkSender sender, uint32_t sequence, Time time, uint8_t type,
                        const uint8_t* payload, size_t n, std::vector<uint8_t>* out,
                        const LinkFrameSigner& signer = nullptr,
                        uint8_t version = kLinkProtocolVersion);

// One side of a connection: numbers frames 0, 1, 2, ... (wrapping at 2^32).
class LinkEncoder {
 public:
  explicit LinkEncoder(LinkSender sender, uint32_t first_sequence = 0)
      : sender_(sender), next_sequence_(first_sequence) {}

  // Any message: each payload struct converts to LinkPayload, e.g.
  // encoder.Encode(now, DriveCommand{0.2, 0.0}).
  std::vector<uint8_t> Encode(Time time, const LinkPayload& payload);
  // Shorthands for the frequent ones.
  std::vector<uint8_t> EncodeDrive(Time t, double v_mps, double w_radps) {
    return Encode(t, DriveCommand{v_mps, w_radps});
  }
  std::vector<uint8_t> EncodeHeartbeat(Time t) { return Encode(t, Heartbeat{}); }
  // Splits `bytes` into as many Telemetry frames as kLinkMaxTelemetryBytes
  // needs (all with the same receive_time) and returns them concatenated.
  std::vector<uint8_t> EncodeTelemetry(Time t, LinkDevice device, Time receive_time,
                                       const uint8_t* bytes, size_t n, uint8_t flags = 0);

  uint32_t next_sequence() const { return next_sequence_; }
  LinkSender sender() const { return sender_; }
  // From now on every frame is signed (the client after the handshake).
  void SetSigner(LinkFrameSigner signer) { signer_ = std::move(signer); }
  bool signing() const { return static_cast<bool>(signer_); }

 private:
  LinkSender sender_;
  uint32_t next_sequence_;
  LinkFrameSigner signer_;
};

// ---------------------------------------------------------------------------
// Decoding.

// Parses a payload of wire type `type`. Unknown types give an UnknownMessage
// (and true). Returns false with a reason in *error when a known type's
// payload has the wrong size or an invalid value (bad enum, non-finite
// velocity, string running past the end).
bool ParseLinkPayload(uint8_t type, const uint8_t* data, size_t n, LinkPayload* out,
                      std::string* error);

// Parses exactly one complete frame (a session record). Checks sync, version,
// both CRCs, the length limit, that the frame size matches, and the payload.
sweepscan::Status ParseLinkFrame(const uint8_t* data, size_t n, LinkMessage* out);

// Sequence accounting for one sender: every frame should carry the previous
// sequence + 1 (mod 2^32).
struct SequenceStats {
  uint64_t frames = 0;
  uint64_t gaps = 0;            // Times a sequence number was skipped.
  uint64_t frames_missing = 0;  // Sum of the skipped counts (frames lost in transit).
  uint64_t restarts = 0;  // Backward jumps (peer restarted or reordered); not counted as loss.
};
class SequenceTracker {
 public:
  // Records one frame's sequence number; returns the number of frames
  // missing just before it (0 for the first frame and after a restart).
  uint64_t Observe(uint32_t sequence);
  const SequenceStats& stats() const { return stats_; }
  void Reset() { have_last_ = false; }

 private:
  SequenceStats stats_;
  bool have_last_ = false;
  uint32_t last_ = 0;
};

struct LinkDecoderStats {
  // bytes_in, bytes_in_frames, frames_ok, bytes_skipped, checksum_errors
  // (header or frame CRC), length_errors (payload_size > max_payload),
  // framing_errors (unsupported version), payload_errors (good CRC, payload
  // does not parse) as for the vendor codecs, same accounting identity:
  // bytes_in == bytes_in_frames + bytes_skipped + BufferedBytes().
  DecoderStats codec;
  uint64_t unknown_types = 0;  // Good frames of an unknown type (delivered as UnknownMessage).
  // Per sender: [0] agent frames, [1] client frames. Frames with another
  // sender byte are payload errors.
  std::array<SequenceStats, 2> sequence{};

  std::string ToString() const;
};

struct LinkDecoderOptions {
  size_t max_payload = kLinkMaxPayload;  // May only be lowered (e.g. on the agent).
  bool keep_raw_frames = false;          // Copy each frame's bytes into LinkMessage::raw.
  // Upper bound of the CRC work of one Feed() call, in bytes checked (0: no
  // bound). When reached, Feed() returns with the rest buffered; call
  // Feed(nullptr, 0, out) again (after serving timers) to go on. Bounds the
  // time a flood of frame candidates can keep the agent's watchdog waiting.
  size_t max_work_per_feed = 0;
};

// Streaming decoder, any chunking. Resync: at each position it looks for the
// sync bytes E7 5C; other bytes are skipped. A candidate is rejected (and the
// search restarts one byte after its first byte, so a good frame that began
// inside a bad one is still found) when: its version is not 1 (framing
// error), its header CRC fails (checksum error), its payload_size exceeds
// max_payload (length error), or its frame CRC fails (checksum error). A frame
// whose CRCs pass but whose payload does not parse, or whose sender byte is
// neither 1 nor 2, is consumed and counted as a payload error, not delivered.
// Memory: at most one frame (<= 64 KiB + 32) plus the chunk being fed.
class LinkDecoder {
 public:
  explicit LinkDecoder(const LinkDecoderOptions& options = LinkDecoderOptions());

  // Appends every message completed by these bytes to *out (oldest first).
  void Feed(const uint8_t* data, size_t n, std::vector<LinkMessage>* out);
  std::vector<LinkMessage> Feed(const std::vector<uint8_t>& bytes) {
    std::vector<LinkMessage> out;
    Feed(bytes.data(), bytes.size(), &out);
    return out;
  }

  const LinkDecoderStats& stats() const { return stats_; }
  size_t BufferedBytes() const { return buffer_.size(); }
  // True when the last Feed() stopped at max_work_per_feed with complete
  // candidates left in the buffer.
  bool work_pending() const { return work_pending_; }
  // Forgets buffered bytes and the sequence history (reconnect). Counters kept.
  void Reset();

 private:
  enum class Parse { kNeedMore, kConsumed, kRejected };
  Parse TryFrame(const uint8_t* p, size_t n, std::vector<LinkMessage>* out);

  LinkDecoderOptions options_;
  StreamBuffer buffer_;
  LinkDecoderStats stats_;
  size_t work_ = 0;  // CRC bytes checked in the current Feed().
  bool work_pending_ = false;
  std::array<SequenceTracker, 2> trackers_;
};

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_LINK_LINK_PROTOCOL_H_
