// The workstation's end of the robot link: connects over TCP or a serial
// port, answers the agent's challenge with the pre-shared key, keeps the
// agent's watchdog fed (Heartbeat at 10 Hz), sends Drive / Stop /
// EmergencyStop / LidarMotor on request, reconnects with exponential backoff
// after the link drops, records every received frame to a session
// (SessionWriter, workstation receive times, durable at least once a second)
// and decodes Telemetry into a live SensorLog (TelemetryDecoder).
//
// Outages (docs/robot-agent.md, "Outages and reconnection"): a link that
// delivers nothing for stall_ms (2 s; the agent sends Status at 10 Hz) is
// dropped and reconnected like a closed one. After a reconnection the client
// sends TelemetryResume with the last device bytes it holds, so the agent
// resends what it buffered meanwhile before the live bytes; the clock tie
// is re-estimated and a robot reboot becomes a new clock epoch; a recording
// goes on in the same session, with a RecorderEvent frame at the loss and at
// the restoration (docs/session-format.md, "Recorder events"). The robot
// stays stopped (its watchdog tripped) until the operator drives again:
// nothing here re-sends motion.
//
// Link health (health()): per-device frames/s and bytes/s over the last
// second, sequence gaps (frames lost in transit), CRC / length / framing
// errors, round-trip latency from CommandAck echo times, the agent's last
// Status, reconnect count.
//
// Threading: a RobotConnection lives on the thread that created it (the
// workstation's I/O thread) and is used only there. It decodes telemetry on
// that thread too; a GUI would move log() batches to the processing thread.
#ifndef SWEEPSCAN_HARDWARE_STATION_ROBOT_CONNECTION_H_
#define SWEEPSCAN_HARDWARE_STATION_ROBOT_CONNECTION_H_

#include <QElapsedTimer>
#include <QObject>
#include <QString>
#include <array>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "core/robot/sensor_data.h"
#include "core/session/session.h"
#include "hardware/link/link_protocol.h"
#include "hardware/link/qt_transport.h"
#include "hardware/link/telemetry_decoder.h"
#include "hardware/station/clock_tie.h"

class QTimer;

namespace sweepscan {
namespace hardware {

struct RobotConnectionOptions {
  QString address = QStringLiteral("tcp:127.0.0.1:5600");  // See ParseLinkAddress.
  std::vector<uint8_t> key;  // Pre-shared key; needed when the agent asks for authentication.
  std::string client_name = "sweepscan 0.1.0";
  int heartbeat_ms = 100;  // 10 Hz; the protocol asks for >= 5 Hz.
  int reconnect_initial_ms = 200;
  // At most 1 s between attempts: after a Wi-Fi outage the link is back
  // within a second of returning (the agent refuses a wrong key for 1 s
  // anyway, so faster attempts would gain nothing).
  int reconnect_max_ms = 1000;
  int connect_timeout_ms = 3000;
  int stall_ms = 2000;          // No byte for this long: drop and reconnect. 0 = never.
  bool resume_telemetry = true;  // Ask the agent for what it buffered during an outage.
  // Session recording: empty = do not record.
  QString session_dir;
  SessionMeta session_meta;  // link and agent are filled in.
  SessionWriterOptions session_writer;
  int flush_check_ms = 200;  // How often FlushIfDue runs (with the writer's 500 ms interval:
                             // everything older than 1 s is on disk).
  TelemetryDecoderOptions decoder;
  bool decode_telemetry = true;
  // What bytes that are not frames may cost the I/O thread: a flood of
  // forged frame candidates (from someone on the Wi-Fi's path, or a broken
  // robot) each announce up to 64 KiB and fail their CRC only once it has
  // all been read, so 28 bytes of input can cost 64 KiB of CRC work and a
  // megabyte of them seconds. At most this much CRC work a read; the rest
  // is decoded after the thread's other events (the heartbeat, the drive
  // the robot's watchdog waits for). More bytes waiting than
  // max_undecoded_bytes: the link is dropped and reconnected.
  size_t max_decode_work_per_read = 4u << 20;
  size_t max_undecoded_bytes = 64u << 20;

  bool IsValid(QString* error) const;
};

struct DeviceRate {
  uint64_t frames = 0;        // Telemetry frames since Start().
  uint64_t bytes = 0;         // Device bytes carried.
  double frames_per_s = 0.0;  // Over the last second.
  double bytes_per_s = 0.0;
};

struct LinkHealth {
  enum class State {
    kIdle,
    kConnecting,
    kAuthenticating,
    kConnected,
    kWaitingToReconnect,
    kFailed
  };
  State state = State::kIdle;
  QString last_error;
  uint64_t connects = 0;              // Successful transport connections.
  uint64_t reconnects = 0;            // Connections after the first.
  std::array<DeviceRate, 3> devices;  // lidar, imu, motor board.
  uint64_t frames_received = 0;
  uint64_t bytes_received = 0;
  double frames_per_s = 0.0;
  double bytes_per_s = 0.0;
  uint64_t sequence_gaps = 0;   // Agent frames: times a sequence number was skipped.
  uint64_t frames_missing = 0;  // Sum of skipped counts = frames dropped in transit.
  uint64_t crc_errors = 0;
  uint64_t length_errors = 0;
  uint64_t framing_errors = 0;
  uint64_t payload_errors = 0;
  uint64_t bytes_skipped = 0;
  uint64_t input_floods = 0;  // Links dropped for more than max_undecoded_bytes waiting.
  // Round trip (CommandAck echo time -> now), milliseconds.
  uint64_t latency_samples = 0;
  double latency_last_ms = 0.0;
  double latency_mean_ms = 0.0;
  double latency_max_ms = 0.0;
  uint64_t acks_refused = 0;  // CommandAcks with a result other than accepted.
  bool have_status = false;
  LinkStatus agent_status;  // Last Status from the agent.
  std::string agent_name;   // From its Hello.
  uint64_t session_records = 0;
  // Outages: times the authenticated link was lost, the one going on.
  uint64_t outages = 0;
  bool outage_open = false;
  double outage_s = 0.0;        // The open outage so far, or the last one's length.
  QString outage_reason;        // Why the last outage began.
  uint32_t reconnect_attempts = 0;  // Of the open (or last) outage.
  // After reconnections: chunks the agent resent from its buffer, and
  // devices whose bytes were lost (the agent's buffer did not reach back).
  uint64_t late_chunks = 0;
  uint64_t late_bytes = 0;
  uint64_t breaks = 0;
  // Per device (lidar, IMU, motor board): seconds of its data lost in
  // outages, between its last bytes before a break and the first after (the
  // robot's clock; a break across a robot reboot counts no seconds). What
  // `info` lists per gap as data_lost_s, known here as the first bytes after
  // each outage arrive.
  std::array<double, 3> data_lost_s{};
  uint32_t clock_epoch = 0;     // Robot clock epochs seen (reboots) since Start().
  ClockTie clock_tie;           // Workstation - robot, now.

  static const char* StateName(State state);
  std::string ToString() const;
};

class RobotConnection : public QObject {
  Q_OBJECT
 public:
  explicit RobotConnection(const RobotConnectionOptions& options, QObject* parent = nullptr);
  ~RobotConnection() override;

  // Creates the session (if any) and starts connecting. False with a message
  // for bad options or a session that cannot be created.
  bool Start(QString* error);
  // Sends Stop if connected, closes the link and the session (flushed).
  void Shutdown();

  // Commands (sent only when authenticated; false otherwise).
  bool Drive(double v_mps, double w_radps);
  bool StopMotion();
  // Also sent before authentication: stopping is always allowed. Owed until
  // the agent says it holds it, and sent again after each reconnection
  // until then (a stop pressed during an outage is latched when it ends).
  bool EmergencyStop();
  bool ClearEmergencyStop();
  bool emergency_stop_owed() const { return estop_owed_; }
  bool SetLidarMotor(bool on);
  // Stops sending Heartbeats (tests: a client that goes quiet).
  void SetHeartbeatEnabled(bool enabled) { heartbeat_enabled_ = enabled; }
  // Drops the transport like a pulled cable; reconnects after the backoff.
  void DropLink();

  // Records every frame received from now on to a new session folder
  // (`session_dir` must not exist), closing any session being recorded. The
  // live decoder and log() restart empty at the same frame, so log() equals
  // what DecodeSession makes of the folder. False with a message if the
  // folder cannot be created.
  bool StartRecording(const QString& session_dir, const SessionMeta& meta, QString* error);
  // Closes the session (flushed, meta.json final); returns the session's status.
  Status StopRecording();
  bool recording() const { return session_ != nullptr; }

  bool authenticated() const { return authenticated_; }
  LinkHealth health() const;
  // Everything decoded so far (grows while connected).
  const SensorLog& log() const { return log_; }
  SensorLog* mutable_log() { return &log_; }
  const TelemetryDecoder& decoder() const { return decoder_; }
  Status session_status() const { return session_status_; }

 signals:
  void stateChanged(int state);  // A LinkHealth::State.
  void authenticatedChanged(bool authenticated);
  void authenticationFailed(const QString& reason);
  // The authenticated link was lost (stalled, closed, reset); reconnecting.
  void linkLost(const QString& reason);
  // Authenticated again after an outage of `outage_s`; `details` says what
  // was resent, lost, and how the clock tie moved (for the status bar / log).
  void linkRestored(double outage_s, const QString& details);
  void statusReceived();  // health().agent_status updated.
  // After an outage, `device`'s (1..3, LinkDevice) first bytes say that
  // `seconds` of its data before them were lost (the agent's buffer did not
  // reach back that far); health().data_lost_s holds the sums.
  void dataLost(int device, double seconds);
  // Writing the session failed (disk full, a pulled drive, a file size
  // limit): nothing more is recorded. Once per recording; StopRecording()
  // returns the same error.
  void recordingFailed(const QString& error);
  void telemetryDecoded();

 private:
  void Connect();
  void OnConnected();
  void OnBytes(const QByteArray& bytes);
  // Decodes what the link decoder holds with these bytes added (none: the
  // rest of a read cut short by max_decode_work_per_read).
  void Decode(const uint8_t* data, size_t n);
  void OnClosed(const QString& reason);
  void HandleMessage(const LinkMessage& message);
  // A final failure (old agent): state failed, no retry.
  void Fail(const QString& reason);
  void ScheduleReconnect(const QString& reason);
  void SetState(LinkHealth::State state);
  bool SendMessage(const LinkPayload& payload, bool require_auth);
  void OnHeartbeat();
  void OnFlushTimer();
  // Keeps a session write's status; the first failure emits recordingFailed.
  void NoteSessionStatus(const Status& status);
  void OnRateTimer();
  void OnStallCheck();
  Time WorkstationNow() const;
  qint64 OutageMs() const;
  bool SendOwedEmergencyStop(bool require_auth);
  // The authenticated link came up (first time or after an outage).
  void OnAuthenticated();
  // The authenticated link went down: outage bookkeeping and the session's event.
  void NoteLinkLost(const QString& reason);
  void AppendRecorderEvent(const RecorderEvent& event);
  void TrackAgentFrame(const LinkMessage& message);

  RobotConnectionOptions options_;
  LinkAddress address_;
  std::unique_ptr<ByteStream> stream_;
  LinkEncoder encoder_{LinkSender::kClient};
  LinkDecoder decoder_link_;
  TelemetryDecoder decoder_;
  SensorLog log_;
  std::unique_ptr<SessionWriter> session_;
  Status session_status_;

  LinkHealth health_;
  bool authenticated_ = false;
  bool auth_required_ = false;
  bool answered_challenge_ = false;
  bool heartbeat_enabled_ = true;
  bool decode_scheduled_ = false;  // A Decode(nullptr, 0) is queued.
  bool stopping_ = false;
  int backoff_ms_ = 0;
  double latency_sum_ms_ = 0.0;
  QTimer* heartbeat_timer_ = nullptr;
  QTimer* reconnect_timer_ = nullptr;
  QTimer* connect_timeout_ = nullptr;
  QTimer* flush_timer_ = nullptr;
  QTimer* rate_timer_ = nullptr;
  QTimer* stall_timer_ = nullptr;
  QElapsedTimer last_rx_;  // Since the last byte received on this connection.
  // Outage bookkeeping.
  bool ever_authenticated_ = false;
  int64_t outage_start_ns_ = 0;  // SteadyNs() when the loss was noticed (OutageMs).
  qint64 outage_before_ms_ = 0;  // Silence before the loss was noticed.
  int64_t last_robot_ns_ = 0;       // Latest agent header time seen (this epoch).
  int64_t connection_last_robot_ns_ = 0;  // The same, on this connection.
  int64_t robot_before_ns_ = 0;     // last_robot_ns_ when the link was lost.
  ClockTie tie_before_;             // The tie when the link was lost.
  int64_t time_shift_ns_ = 0;       // This epoch's robot time -> the recording's first epoch's.
  uint32_t session_epoch_base_ = 0;  // health_.clock_epoch when the recording began.
  int64_t handshake_sent_ns_ = 0;   // Workstation time we sent our last handshake frame.
  int64_t first_robot_ns_ = -1;     // First agent header time on this connection.
  std::array<TelemetryResumePosition, 3> positions_{};  // What we hold of each device.
  bool resume_sent_ = false;
  bool estop_owed_ = false;      // EmergencyStop() not yet acknowledged by the agent
  uint32_t estop_sequence_ = 0;  // the latest EmergencyStop frame's sequence
  // Counters at the last rate sample, for per-second rates.
  std::array<DeviceRate, 3> rate_base_{};
  uint64_t frames_base_ = 0;
  uint64_t bytes_base_ = 0;
  QElapsedTimer rate_clock_;
};

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_STATION_ROBOT_CONNECTION_H_
