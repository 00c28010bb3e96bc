// The robot agent's logic (sweepscan-robotd and the simulator), without any
// I/O: bytes and times in, bytes out. docs/protocol.md is the contract with
// the workstation; docs/robot-agent.md describes the behaviour in words.
//
//   client link  --OnClientBytes-->  +-----------+  --AgentOutput::to_client-->  client link
//   lidar/IMU/motor board --OnDeviceBytes-->  | AgentCore |  --AgentOutput::to_device-->  device
//   ports timer        --Tick(now)------>  +-----------+
//
// What it does:
//  - per connection: Hello (+ AuthChallenge with a fresh 32-byte CSPRNG nonce
//    when authentication is required), checks the client's AuthResponse =
//    HMAC-SHA256(key, "sweepscan-link-v2" || agent_nonce || client_nonce) in
//    constant time (AgentHandshake); a wrong key gets AuthResult denied and
//    the connection is closed. Until then only Hello, AuthResponse and
//    EmergencyStop act; nothing else is answered. After it, every client
//    frame must carry a tag under the session key (HKDF of the key and both
//    nonces) and a sequence number after the last one accepted; others are
//    dropped and counted (injection, replay, reorder).
//  - device bytes -> Telemetry frames stamped with the robot receive time.
//  - DriveCommand -> clamped to |v| <= v_max, |w| <= w_max (the "commanded"
//    set-point), then ramped with the acceleration limits (the "applied"
//    velocity) and sent to the motor board as EncodeMotorCommand frames at a
//    fixed rate while moving. Stop ramps down; EmergencyStop zeroes at once
//    and latches until ClearEmergencyStop.
//  - watchdog: no valid frame from the authenticated client for
//    options.watchdog while motion is commanded -> zero to the motors at once
//    (no ramp), state tripped, reported in Status. A lost connection trips it
//    at once. The drives a stalled link held past the trip, delivered late
//    by their sender times, do not re-arm it (AgentOptions::stale_drive_after).
//  - CommandAck for every command (echo time for the client's latency), Status
//    at options.status_period and on every change of watchdog / e-stop / auth state.
//  - LidarMotor on/off -> the X4's motor on / off (its adapter's DTR line,
//    AgentOutput::lidar_dtr) and scan start / stop (A5 60 / A5 65); Start()
//    stops both, then sends device info and health requests (A5 90, A5 92).
//
// Deterministic: every input carries the robot time `now` (monotonic,
// non-decreasing across calls); the only non-determinism is the nonce source
// (injectable through AgentOptions::random_source).
//
// Threading: an AgentCore lives on one thread (the agent's I/O thread, see
// RobotAgent); it is not thread-safe.
#ifndef SWEEPSCAN_HARDWARE_AGENT_AGENT_CORE_H_
#define SWEEPSCAN_HARDWARE_AGENT_AGENT_CORE_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/common/time.h"
#include "hardware/agent/telemetry_buffer.h"
#include "hardware/codecs/motor_board_codec.h"
#include "hardware/link/hmac_sha256.h"
#include "hardware/link/link_protocol.h"

namespace sweepscan {
namespace hardware {

inline constexpr Duration kAgentMinWatchdog = std::chrono::milliseconds(100);
inline constexpr Duration kAgentMaxWatchdog = std::chrono::milliseconds(5000);

struct AgentOptions {
  std::string name = "sweepscan-robotd 0.1.0";  // Sent in Hello.
  std::vector<HelloDevice> devices;             // Described in Hello.

  // TCP: true (the default). A serial link may run without authentication
  // (physical access); the client is then authenticated from the start.
  bool require_auth = true;
  std::vector<uint8_t> key;  // Pre-shared key, raw bytes; must not be empty when require_auth.
  // An unauthenticated connection is closed after this long (it never holds
  // the client slot meanwhile: see RobotAgent).
  Duration auth_timeout = std::chrono::seconds(2);
  // Re-send Hello (and a fresh challenge) when the client sends Hello. Needed
  // on a serial link, where the client may open the port after the agent's
  // first Hello went out; off for TCP (the agent speaks first on connect).
  bool hello_on_client_hello = false;

  // 500 ms; within [kAgentMinWatchdog, kAgentMaxWatchdog] (a longer one
  // would leave a robot driving blind; a shorter one trips between the
  // client's 100 ms heartbeats).
  Duration watchdog = kLinkDefaultWatchdog;
  // After a watchdog trip, a DriveCommand that the link delivered later than
  // this after its due time is stale: it was held by the stall that tripped
  // the watchdog (Wi-Fi behind a wall holds every frame, then delivers them
  // at once) and does not start the robot again (docs/protocol.md,
  // "Watchdog"). The due time is the frame's sender time plus the least
  // transit (receive time minus sender time) of the connection's last 5 to
  // 10 s. One client heartbeat period. A drive in the same read as a frame
  // that late is stale too, however little late itself: the rest of the
  // burst, sent before the client could know of the trip. Only until a
  // frame comes on time: the stall is over then.
  Duration stale_drive_after = std::chrono::milliseconds(100);
  double v_max_mps = 0.5;                    // |commanded v| <= v_max.
  double w_max_radps = 1.5;                  // |commanded w| <= w_max.
  double accel_max_mps2 = 1.0;               // Ramp of applied v (speeding up and slowing down).
  double alpha_max_radps2 = 3.0;             // Ramp of applied w.
  Duration motor_period = std::chrono::milliseconds(50);    // 20 Hz motor commands while moving.
  Duration status_period = std::chrono::milliseconds(100);  // 10 Hz Status.
  Duration device_silent_after = std::chrono::seconds(1);   // Status fault bits 0..2.
  double low_battery_v = 0.0;  // Fault bit 3 below this voltage; 0 disables.
  // Delay between the start-up requests to the lidar (A5 90, then A5 92): the
  // X4 answers one request at a time.
  Duration lidar_request_spacing = std::chrono::milliseconds(100);
  // The agent's limit on client frames (clients send only small messages:
  // the largest is a Hello with a 255-byte name). Lower = less CRC work per
  // byte of a flood of forged candidates.
  size_t max_client_payload = 288;
  // CRC work (bytes checked) per OnClientBytes / ContinueClientBytes call:
  // the rest waits (client_work_pending()), so timers keep their time.
  size_t max_client_work_per_call = 256 * 1024;
  // Client bytes waiting to be decoded beyond this: the connection is
  // dropped ("input flood"; a real client sends a few hundred bytes/s).
  size_t max_client_backlog = 1 << 20;
  // Buffering across outages (docs/robot-agent.md): the last
  // `telemetry_buffer` of device bytes are kept (0 = none; at most 60 s) in
  // at most telemetry_buffer_max_bytes (0 = the default bound of
  // telemetry_buffer.h, at most 1.31 MB + 64 KiB for 10 s), and a client
  // that sends TelemetryResume gets what it missed. After a client is
  // adopted (or a serial client says Hello) its telemetry waits for its
  // first command frame (at most resume_wait), so what it asks to be resent
  // goes out before the live bytes. The wait only delays (the held bytes
  // follow), so it is long enough for a round trip over a poor Wi-Fi link
  // right after the handshake; a 1 s wait lost whole outages there.
  Duration telemetry_buffer = std::chrono::seconds(10);
  size_t telemetry_buffer_max_bytes = 0;
  Duration resume_wait = std::chrono::seconds(5);
  // The lidar's motor (and scan) off once no valid frame has come from an
  // authenticated client for this long (the client left, or its link is
  // half-open): an X4 spinning between sessions wears its motor and drains
  // the battery. 0 = never. It must outlast what a returning client is
  // resent (telemetry_buffer, plus resume_wait and a reconnection), or the
  // resume would find no lidar bytes: IsValid refuses less than
  // telemetry_buffer + resume_wait. A client turns it on again with
  // LidarMotor, as the app and `record` do at every authentication.
  Duration lidar_idle_off = std::chrono::seconds(30);
  // Nonce source; null = FillRandomBytes (/dev/urandom). Tests may inject one.
  std::function<bool(uint8_t*, size_t)> random_source;

  bool IsValid(std::string* error) const;
};

// What one call produced. Callers send to_client on the link, then close the
// connection if close_client is set (and call OnClientDisconnected), and
// write to_device[LinkDeviceIndex(device)] to each device port.
struct AgentOutput {
  std::vector<uint8_t> to_client;
  std::array<std::vector<uint8_t>, 3> to_device;  // lidar, imu, motor board.
  // The X4's motor is powered through its USB adapter's DTR line (as the
  // workstation's DirectDevice and the vendor's SDK drive it): when set, the
  // lidar port's DTR is to be set to this, before to_device[0] is written.
  std::optional<bool> lidar_dtr;
  bool close_client = false;
  std::string close_reason;     // Why, for the log ("authentication failed", "input flood").
  bool auth_failure = false;    // The close is a failed authentication (address lockout).
  std::vector<std::string> log;  // Lines for the agent's log (the lidar's idle stop).

  bool empty() const {
    return to_client.empty() && to_device[0].empty() && to_device[1].empty() &&
           to_device[2].empty() && !lidar_dtr.has_value() && !close_client && log.empty();
  }
  void Clear();
};

// 0, 1, 2 for lidar, IMU, motor board; requires a valid device.
inline size_t LinkDeviceIndex(LinkDevice device) { return static_cast<size_t>(device) - 1; }

// Counters beyond those in Status, for tests and logs.
struct AgentCounters {
  uint64_t connections = 0;
  uint64_t auth_ok = 0;
  uint64_t auth_denied = 0;
  uint64_t motor_commands_sent = 0;
  uint64_t telemetry_frames_sent = 0;
  uint64_t status_frames_sent = 0;
  uint64_t client_frames_from_wrong_sender = 0;  // Good frames whose sender byte is "agent".
  // After the handshake: frames refused because they were unsigned, carried
  // a wrong tag, or repeated / went back in sequence (replay, reorder, injection).
  uint64_t frames_unsigned = 0;
  // Buffering across outages.
  uint64_t resumes = 0;             // TelemetryResume requests served.
  uint64_t resume_breaks = 0;       // Devices whose bytes after the client's position were lost.
  uint64_t chunks_resent = 0;       // Buffered chunks sent after a resume.
  uint64_t bytes_resent = 0;
  uint64_t frames_bad_tag = 0;
  uint64_t frames_replayed = 0;
  uint64_t old_protocol_refused = 0;  // Peers speaking protocol version 1.
  uint64_t input_floods = 0;          // Connections dropped for a decode backlog.
  // Live Telemetry chunks not sent while the link was congested (kept in
  // the buffer; the device's next chunk sent carries the break flag).
  uint64_t telemetry_chunks_dropped = 0;
  uint64_t lidar_idle_stops = 0;  // Lidar motor turned off for want of a client.
  // DriveCommands refused after a watchdog trip: the link held them
  // (options.stale_drive_after).
  uint64_t stale_drives = 0;
};

// One connection's authentication, before it may become the client (TCP):
// Hello and AuthChallenge go out; AuthResponse is checked; EmergencyStop is
// noted (stopping is always allowed); nothing else is answered (no acks, no
// Status, no Telemetry). It ends authenticated (the session key derived from
// both nonces, handed to AgentCore::AdoptClient), or denied with one
// AuthResult (wrong key, protocol version 1, deadline, input flood) after
// which the connection is closed. Work per call is bounded like AgentCore's.
class AgentHandshake {
 public:
  enum class State { kPending, kAuthenticated, kDenied };

  // Appends Hello and AuthChallenge (fresh nonce) to *out.
  AgentHandshake(const AgentOptions& options, Time now, std::vector<uint8_t>* out);
  // Bytes from the connection (nullptr, 0: go on with pending work).
  State OnBytes(const uint8_t* data, size_t n, Time now, std::vector<uint8_t>* out);
  // The authentication deadline.
  State Tick(Time now, std::vector<uint8_t>* out);

  State state() const { return state_; }
  bool work_pending() const { return decoder_.work_pending(); }
  const std::string& denial() const { return denial_; }
  bool auth_failure() const { return auth_failure_; }  // Denied for a wrong key.
  // An EmergencyStop arrived since the last call (clears the flag).
  bool TakeEmergencyStop() {
    const bool e = estop_;
    estop_ = false;
    return e;
  }

  // kAuthenticated: what AgentCore::AdoptClient takes over.
  const LinkSessionKey& session_key() const { return session_key_; }
  uint32_t next_agent_sequence() const { return encoder_.next_sequence(); }
  uint32_t last_client_sequence() const { return last_client_sequence_; }
  const std::string& client_name() const { return client_name_; }
  LinkDecoder& decoder() { return decoder_; }
  std::vector<LinkMessage>& pending_messages() { return pending_; }
  const LinkDecoderStats& stats() const { return decoder_.stats(); }

 private:
  void Deny(Time now, const std::string& reason, std::vector<uint8_t>* out,
            uint8_t version = kLinkProtocolVersion);

  AgentOptions options_;
  LinkDecoder decoder_;
  LinkEncoder encoder_{LinkSender::kAgent};
  State state_ = State::kPending;
  Time connected_at_;
  LinkNonce nonce_{};
  LinkSessionKey session_key_{};
  uint32_t last_client_sequence_ = 0;
  std::string client_name_;
  std::string denial_;
  bool auth_failure_ = false;
  bool estop_ = false;
  std::vector<LinkMessage> pending_;
};

// "protocol version 1 is not supported: ..." in a version-1 frame, so an old
// client can show why it is refused (docs/protocol.md, "Versioning").
std::vector<uint8_t> EncodeOldVersionRefusal(Time now, uint8_t version, const std::string& reason);

class AgentCore {
 public:
  explicit AgentCore(const AgentOptions& options);

  // Once, before anything else but the ports' first opens (RobotAgent opens
  // the motor board's before it): lidar start-up requests, first motor zero.
  void Start(Time now, AgentOutput* out);
  bool started() const { return started_; }

  // A client connected (TCP accept, or the serial link opened): new encoder
  // sequence, Hello, and AuthChallenge with a fresh nonce when required.
  void OnClientConnected(Time now, AgentOutput* out);
  // A connection authenticated by its own AgentHandshake (RobotAgent runs
  // one per pending TCP connection) becomes the client: AuthResult ok,
  // Status, then the frames it sent after its AuthResponse. False (nothing
  // done) while another client is connected.
  bool AdoptClient(AgentHandshake* handshake, Time now, AgentOutput* out);
  // Counts a pending connection's failed handshake (auth_denied, ...).
  void NoteDeniedHandshake(const AgentHandshake& handshake);
  // EmergencyStop from a connection that has not authenticated (stopping is
  // always allowed; no ack).
  void EmergencyStopFromUnauthenticated(Time now, AgentOutput* out);
  // Decode work left over by the per-call bound; RobotAgent calls
  // ContinueClientBytes() soon (after serving its timers).
  bool client_work_pending() const;
  void ContinueClientBytes(Time now, AgentOutput* out) { OnClientBytes(nullptr, 0, now, out); }
  // The connection is gone: trips the watchdog at once if motion was commanded.
  void OnClientDisconnected(Time now, AgentOutput* out);
  // Bytes from the client link, any chunking.
  void OnClientBytes(const uint8_t* data, size_t n, Time now, AgentOutput* out);
  // Bytes read from a device port: forwarded as Telemetry (once authenticated).
  void OnDeviceBytes(LinkDevice device, const uint8_t* data, size_t n, Time now, AgentOutput* out);
  // A device port failed (or recovered): Status fault bit 5.
  void SetDevicePortError(LinkDevice device, bool error, Time now, AgentOutput* out);
  // A device port was opened (at start or again after it was lost): the
  // motor board gets the command in force at once (zero at rest), so that a
  // board that kept a crashed agent's last velocity, or was plugged in
  // again, stops without waiting for a drive command. Start() queues its
  // zero before the ports are open, so this is the one that reaches it.
  // The lidar's DTR line gets the motor's state (opening a tty raises DTR,
  // which would spin the X4's motor), and the X4 its start-up sequence
  // again, as at Start() (an X4 plugged in after the agent started, or
  // plugged in again, got none): stop, device info, health, then scan if
  // its motor is on.
  void OnDevicePortOpened(LinkDevice device, Time now, AgentOutput* out);
  // The link cannot take more for now (a serial line or radio slower than
  // the telemetry, or a reader that stalled; a connection that cannot be
  // dropped): while paused, live Telemetry is not sent, only kept in the
  // buffer, and each device's next chunk sent carries the break flag, so
  // the client's decoder restarts and its recording reports the hole.
  // Everything else (Status, acks, Hello) still goes out.
  void SetTelemetryPaused(bool paused) { telemetry_paused_ = paused; }
  bool telemetry_paused() const { return telemetry_paused_; }
  // Bytes already given to the link were thrown away (its queue): each
  // device's next chunk carries the break flag.
  void NoteTelemetryLost() { pending_break_.fill(true); }
  // The agent is going away: zero to the motors, whatever was commanded.
  void StopForShutdown(Time now, AgentOutput* out) { HardStop(now, out); }
  // Call often (every <= 10-20 ms): watchdog, ramps, motor and Status cadence,
  // start-up requests, auth timeout. The watchdog reacts within one tick.
  void Tick(Time now, AgentOutput* out);

  const TelemetryBuffer& telemetry_buffer() const { return buffer_; }
  // State, as it would go out in the next Status.
  LinkStatus status(Time now) const;
  bool client_connected() const { return client_connected_; }
  bool emergency_stop_latched() const { return estop_latched_; }
  bool client_authenticated() const { return client_connected_ && authenticated_; }
  WatchdogState watchdog_state() const { return watchdog_; }
  double applied_v_mps() const { return applied_v_; }
  double applied_w_radps() const { return applied_w_; }
  const AgentCounters& counters() const { return counters_; }
  const AgentOptions& options() const { return options_; }
  const std::string& client_name() const { return client_name_; }
  // Robot times of the last valid frame of the authenticated client and of
  // the last watchdog trip (for measuring the watchdog under load).
  Time last_client_frame_time() const { return last_client_frame_; }
  Time last_watchdog_trip_time() const { return last_trip_; }

 private:
  // Hello, then AuthChallenge with a fresh nonce (or Status when no auth is needed).
  void SendGreeting(Time now, AgentOutput* out);
  void Send(Time now, const LinkPayload& payload, AgentOutput* out);
  void SendStatus(Time now, AgentOutput* out);
  void Ack(Time now, const LinkMessage& message, AckResult result, AgentOutput* out);
  void Deny(Time now, const std::string& reason, AgentOutput* out);
  void HandleMessage(const LinkMessage& message, Time now, AgentOutput* out);
  void HandleAuthResponse(const AuthResponse& response, Time now, AgentOutput* out);
  // Signed, valid tag, sequence after the last accepted one (after auth).
  bool FrameAuthentic(const LinkMessage& message);
  void HandleHandshakeState(AgentHandshake::State state, Time now, AgentOutput* out);
  // Zero to the motors at once (e-stop and watchdog).
  void HardStop(Time now, AgentOutput* out);
  void SendMotorCommand(Time now, AgentOutput* out);
  // A client was adopted: hold its telemetry until it says where it is.
  void HoldTelemetry(Time now);
  // The client's first command frame: resend after its position (resume
  // non-null), or send what was read since it was adopted; then live.
  void ReleaseTelemetry(const TelemetryResume* resume, Time now, AgentOutput* out);
  void SendTelemetryPiece(Time now, const TelemetryBuffer::Piece& piece, AgentOutput* out);
  // A5 65 now; A5 90 and A5 92 from Tick, lidar_request_spacing apart;
  // then A5 60 if the motor is on.
  void BeginLidarStartup(Time now, AgentOutput* out);
  void TickLidar(Time now, AgentOutput* out);
  // How late the link delivered a client frame sent at `sent` (sender
  // clock) and received `now`: its transit beyond the least of the last 5
  // to 10 s (two windows of 5 s; a stall up to 5 s is measured in full).
  Duration NoteClientTransit(Time now, Time sent);
  void UpdateRamp(Time now);
  void UpdateWatchdogArming();
  bool MotionCommanded() const;

  AgentOptions options_;
  LinkDecoder decoder_;
  LinkEncoder encoder_{LinkSender::kAgent};
  MotorFeedbackDecoder motor_feedback_;

  // Connection.
  bool client_connected_ = false;
  bool closing_ = false;  // Denied: ignore the rest of this connection's bytes.
  bool authenticated_ = false;
  bool auth_attempted_ = false;
  std::unique_ptr<AgentHandshake> handshake_;  // While authenticating (single-connection use).
  bool frame_auth_ = false;  // Every client frame must carry a valid tag (authenticated TCP).
  LinkSessionKey session_key_{};
  uint32_t last_client_sequence_ = 0;
  Time connected_at_;
  Time last_client_frame_;  // Last valid frame from the authenticated client.
  // NoteClientTransit's windows: the least transit of the current one
  // (since transit_window_start_) and of the one before. Reset per connection.
  bool have_transit_ = false;
  Time transit_window_start_;
  Duration least_transit_now_{};
  Duration least_transit_before_{};
  bool stale_drive_logged_ = false;  // Since the last trip.
  bool on_time_since_trip_ = false;  // A frame not held by a stall came since the last trip.
  // The receive time of the last frame later than stale_drive_after (the
  // frames of one read share it).
  bool have_late_read_ = false;
  Time late_read_time_;
  std::string client_name_;

  // Motion. commanded_* is the clamped set-point, applied_* the ramped value.
  double commanded_v_ = 0.0;
  double commanded_w_ = 0.0;
  double applied_v_ = 0.0;
  double applied_w_ = 0.0;
  bool estop_latched_ = false;
  WatchdogState watchdog_ = WatchdogState::kIdle;
  bool have_ramp_time_ = false;
  Time last_ramp_time_;
  bool motor_zero_sent_ = true;  // The last motor frame sent was zero.
  bool have_motor_send_ = false;
  Time last_motor_send_;

  // Devices.
  bool started_ = false;
  Time start_time_;
  Time lidar_startup_at_;
  int lidar_requests_sent_ = 0;  // Start-up requests: 0, 1 (A5 90 sent), 2 (A5 92 sent).
  bool lidar_scan_after_startup_ = false;  // A5 60 after the requests (a port that reopened).
  // Start()'s A5 65 is still in the caller's output: a port opened before
  // the caller's next Tick (RobotAgent opens them right after Start) gets it.
  bool lidar_startup_in_output_ = false;
  bool lidar_motor_on_ = false;
  Time lidar_motor_on_since_;
  std::array<bool, 3> have_device_bytes_{};
  std::array<Time, 3> last_device_bytes_{};
  std::array<uint64_t, 3> device_bytes_{};
  std::array<bool, 3> port_error_{};
  float battery_v_ = 0.0f;
  bool motor_stop_flag_ = false;
  TelemetryBuffer buffer_;
  bool telemetry_held_ = false;
  uint64_t held_from_serial_ = 0;
  Time held_since_;
  std::array<bool, 3> pending_break_{};  // Next chunk of the device carries kTelemetryBreak.
  bool telemetry_paused_ = false;        // SetTelemetryPaused.

  // Status bookkeeping.
  bool have_status_time_ = false;
  Time last_status_;
  uint32_t frames_received_ = 0;
  uint32_t commands_refused_ = 0;
  uint32_t watchdog_trips_ = 0;
  Time last_trip_;
  AgentCounters counters_;
};

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_AGENT_AGENT_CORE_H_
