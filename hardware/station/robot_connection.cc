#include "hardware/station/robot_connection.h"

#include <time.h>

#include <QTcpSocket>
#include <QTimer>
#include <algorithm>
#include <chrono>
#include <sstream>

#include "hardware/link/hmac_sha256.h"

namespace sweepscan {
namespace hardware {
namespace {

// The workstation's side of the clock tie: CLOCK_BOOTTIME, which counts a
// suspend. The robot's clock runs on while a laptop sleeps; on
// CLOCK_MONOTONIC (steady_clock) the tie then moved by the sleep's length,
// which beyond 0.5 s passed for a robot reboot (a new clock epoch): the
// positions were dropped, the agent resent its whole buffer as duplicates,
// and later data was shifted by the sleep.
int64_t SteadyNs() {
  timespec ts{};
  clock_gettime(CLOCK_BOOTTIME, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

int64_t RealtimeNs() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

LinkDecoderOptions RecordingDecoderOptions(size_t max_work) {
  LinkDecoderOptions options;
  options.keep_raw_frames = true;  // The session stores each frame's exact bytes.
  options.max_work_per_feed = max_work;
  return options;
}

}  // namespace

bool RobotConnectionOptions::IsValid(QString* error) const {
  auto fail = [error](const QString& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  LinkAddress parsed;
  if (!ParseLinkAddress(address, &parsed, error)) return false;
  if (heartbeat_ms <= 0 || heartbeat_ms > 200) {
    return fail(QStringLiteral("heartbeat period must be 1..200 ms (the agent needs >= 5 Hz)"));
  }
  if (reconnect_initial_ms <= 0 || reconnect_max_ms < reconnect_initial_ms) {
    return fail(QStringLiteral("reconnect backoff must satisfy 0 < initial <= max"));
  }
  if (connect_timeout_ms <= 0) return fail(QStringLiteral("connect timeout must be positive"));
  if (stall_ms != 0 && (stall_ms < 300 || stall_ms > 600000)) {
    return fail(QStringLiteral("stall time must be 0 (off) or 300..600000 ms (the agent sends "
                               "Status every 100 ms)"));
  }
  if (flush_check_ms <= 0 || flush_check_ms > 250) {
    return fail(QStringLiteral("flush check period must be 1..250 ms (durability within 1 s)"));
  }
  if (max_undecoded_bytes < 2 * kLinkMaxFrameSize) {
    return fail(QStringLiteral("max undecoded bytes must hold two frames (%1 B)")
                    .arg(2 * kLinkMaxFrameSize));
  }
  std::string message;
  if (!session_writer.IsValid(&message)) return fail(QString::fromStdString(message));
  if (!decoder.IsValid(&message)) return fail(QString::fromStdString(message));
  return true;
}

const char* LinkHealth::StateName(State state) {
  switch (state) {
    case State::kIdle:
      return "idle";
    case State::kConnecting:
      return "connecting";
    case State::kAuthenticating:
      return "authenticating";
    case State::kConnected:
      return "connected";
    case State::kWaitingToReconnect:
      return "waiting to reconnect";
    case State::kFailed:
      return "failed";
  }
  return "?";
}

std::string LinkHealth::ToString() const {
  std::ostringstream s;
  s << StateName(state) << (last_error.isEmpty() ? "" : " (" + last_error.toStdString() + ")")
    << "; frames " << frames_received << " (" << frames_per_s << "/s), bytes " << bytes_received
    << " (" << bytes_per_s << "/s)";
  static const char* kNames[3] = {"lidar", "imu", "motor"};
  for (int i = 0; i < 3; ++i) {
    s << "; " << kNames[i] << " " << devices[i].frames_per_s << " frames/s "
      << devices[i].bytes_per_s << " B/s";
  }
  s << "; gaps " << sequence_gaps << " (" << frames_missing << " frames), crc " << crc_errors
    << ", length " << length_errors << ", framing " << framing_errors << ", payload "
    << payload_errors << ", floods " << input_floods << "; latency last " << latency_last_ms
    << " ms mean " << latency_mean_ms << " ms max " << latency_max_ms << " ms (" << latency_samples
    << ")";
  if (have_status) {
    s << "; agent watchdog " << static_cast<int>(agent_status.watchdog) << " faults 0x" << std::hex
      << agent_status.fault_bits << std::dec << " battery " << agent_status.battery_voltage_v
      << " V";
  }
  s << "; reconnects " << reconnects;
  if (outages > 0) {
    s << "; outages " << outages << (outage_open ? " (open, " : " (last ") << outage_s << " s, "
      << reconnect_attempts << " attempts: " << outage_reason.toStdString() << ")"
      << "; resent " << late_chunks << " chunks " << late_bytes << " B, breaks " << breaks
      << ", clock epoch " << clock_epoch;
    for (int i = 0; i < 3; ++i) {
      if (data_lost_s[i] > 0.0) s << "; " << kNames[i] << " data lost " << data_lost_s[i] << " s";
    }
  }
  return s.str();
}

RobotConnection::RobotConnection(const RobotConnectionOptions& options, QObject* parent)
    : QObject(parent),
      options_(options),
      decoder_link_(RecordingDecoderOptions(options.max_decode_work_per_read)),
      decoder_(options.decoder) {}

RobotConnection::~RobotConnection() { Shutdown(); }

// Since the loss was noticed, on the tie's clock: a suspend counts.
qint64 RobotConnection::OutageMs() const { return (SteadyNs() - outage_start_ns_) / 1000000; }

Time RobotConnection::WorkstationNow() const {
  // The client's header time: its own clock (SteadyNs), only ever echoed back.
  return TimeFromNanoseconds(SteadyNs());
}

bool RobotConnection::Start(QString* error) {
  if (!options_.IsValid(error)) return false;
  ParseLinkAddress(options_.address, &address_, nullptr);
  if (!options_.session_dir.isEmpty() &&
      !StartRecording(options_.session_dir, options_.session_meta, error)) {
    return false;
  }
  heartbeat_timer_ = new QTimer(this);
  heartbeat_timer_->setTimerType(Qt::PreciseTimer);
  connect(heartbeat_timer_, &QTimer::timeout, this, &RobotConnection::OnHeartbeat);
  heartbeat_timer_->start(options_.heartbeat_ms);
  reconnect_timer_ = new QTimer(this);
  reconnect_timer_->setSingleShot(true);
  connect(reconnect_timer_, &QTimer::timeout, this, &RobotConnection::Connect);
  connect_timeout_ = new QTimer(this);
  connect_timeout_->setSingleShot(true);
  connect(connect_timeout_, &QTimer::timeout, this,
          [this] { OnClosed(QStringLiteral("connect timeout")); });
  rate_timer_ = new QTimer(this);
  connect(rate_timer_, &QTimer::timeout, this, &RobotConnection::OnRateTimer);
  rate_timer_->start(1000);
  rate_clock_.start();
  stall_timer_ = new QTimer(this);
  connect(stall_timer_, &QTimer::timeout, this, &RobotConnection::OnStallCheck);
  if (options_.stall_ms > 0) stall_timer_->start(std::min(200, options_.stall_ms / 4));
  backoff_ms_ = options_.reconnect_initial_ms;
  Connect();
  return true;
}

void RobotConnection::Shutdown() {
  if (stopping_) return;
  stopping_ = true;
  if (authenticated_) SendMessage(Stop{}, true);
  if (heartbeat_timer_ != nullptr) heartbeat_timer_->stop();
  if (reconnect_timer_ != nullptr) reconnect_timer_->stop();
  if (connect_timeout_ != nullptr) connect_timeout_->stop();
  if (rate_timer_ != nullptr) rate_timer_->stop();
  if (stall_timer_ != nullptr) stall_timer_->stop();
  if (stream_ != nullptr) {
    stream_->disconnect(this);
    stream_->Close();
    stream_.reset();
  }
  authenticated_ = false;
  StopRecording();
  SetState(LinkHealth::State::kIdle);
}

bool RobotConnection::StartRecording(const QString& session_dir, const SessionMeta& meta_in,
                                     QString* error) {
  if (session_ != nullptr) StopRecording();
  SessionMeta meta = meta_in;
  ParseLinkAddress(options_.address, &address_, nullptr);
  meta.link = address_.ToString().toStdString();
  if (!health_.agent_name.empty()) meta.agent = health_.agent_name;
  options_.session_meta = meta;
  // This thread sends the heartbeats and the drive script's commands: the
  // disk's syncs go to the writer's own thread (a second-long fdatasync
  // here tripped the robot's watchdog).
  SessionWriterOptions writer = options_.session_writer;
  writer.sync_on_thread = true;
  session_status_ = SessionWriter::Create(session_dir.toStdString(), meta, writer, &session_);
  if (!session_status_.ok()) {
    if (error != nullptr) *error = QString::fromStdString(session_status_.message());
    session_.reset();
    return false;
  }
  // The live decoder restarts at the session's first frame, so that the live
  // log is exactly what DecodeSession will make of the folder (the offline
  // decoder also starts with empty buffers at that frame).
  decoder_ = TelemetryDecoder(options_.decoder);
  log_ = SensorLog();
  // The session's timeline is the robot clock it starts in (epoch 0 of the
  // session; docs/session-format.md, "Recorder events").
  time_shift_ns_ = 0;
  session_epoch_base_ = health_.clock_epoch;
  if (flush_timer_ == nullptr) {
    flush_timer_ = new QTimer(this);
    connect(flush_timer_, &QTimer::timeout, this, &RobotConnection::OnFlushTimer);
  }
  flush_timer_->start(options_.flush_check_ms);
  return true;
}

Status RobotConnection::StopRecording() {
  if (flush_timer_ != nullptr) flush_timer_->stop();
  if (session_ == nullptr) return session_status_;
  const Status closed = session_->Close();
  if (session_status_.ok()) session_status_ = closed;
  health_.session_records = session_->records_appended();
  session_.reset();
  return session_status_;
}

void RobotConnection::SetState(LinkHealth::State state) {
  if (health_.state == state) return;
  health_.state = state;
  emit stateChanged(static_cast<int>(state));
}

void RobotConnection::Connect() {
  if (stopping_) return;
  authenticated_ = false;
  answered_challenge_ = false;
  auth_required_ = false;
  encoder_ = LinkEncoder(LinkSender::kClient);  // Each connection numbers from 0.
  decoder_link_.Reset();
  first_robot_ns_ = -1;
  connection_last_robot_ns_ = 0;
  resume_sent_ = false;
  last_rx_.start();
  if (health_.outage_open) ++health_.reconnect_attempts;
  SetState(LinkHealth::State::kConnecting);
  if (address_.kind == LinkAddress::Kind::kTcp) {
    auto* socket = new QTcpSocket();
    auto stream = std::make_unique<TcpStream>(socket);
    TcpStream* tcp = stream.get();
    stream_ = std::move(stream);
    connect(tcp, &TcpStream::connected, this, &RobotConnection::OnConnected);
    connect(tcp, &ByteStream::bytesReceived, this, &RobotConnection::OnBytes);
    connect(tcp, &ByteStream::closed, this, &RobotConnection::OnClosed);
    connect_timeout_->start(options_.connect_timeout_ms);
    tcp->ConnectTo(address_.host, address_.port);
  } else {
    auto stream = std::make_unique<SerialStream>();
    QString error;
    if (!stream->Open(address_.serial_port, address_.baud, &error)) {
      ScheduleReconnect(error);
      return;
    }
    stream_ = std::move(stream);
    connect(stream_.get(), &ByteStream::bytesReceived, this, &RobotConnection::OnBytes);
    connect(stream_.get(), &ByteStream::closed, this, &RobotConnection::OnClosed);
    OnConnected();
  }
}

void RobotConnection::OnConnected() {
  connect_timeout_->stop();
  ++health_.connects;
  if (health_.connects > 1) ++health_.reconnects;
  SetState(LinkHealth::State::kAuthenticating);
  last_rx_.start();
  Hello hello;
  hello.name = options_.client_name;
  handshake_sent_ns_ = SteadyNs();
  SendMessage(hello, false);
}

void RobotConnection::OnBytes(const QByteArray& bytes) {
  last_rx_.start();
  health_.bytes_received += static_cast<uint64_t>(bytes.size());
  Decode(reinterpret_cast<const uint8_t*>(bytes.constData()), static_cast<size_t>(bytes.size()));
}

void RobotConnection::Decode(const uint8_t* data, size_t n) {
  // A frame decoded in a later slice carries the time it was decoded: the
  // workstation had not seen it before.
  const int64_t receive_ns = RealtimeNs();
  std::vector<LinkMessage> messages;
  decoder_link_.Feed(data, n, &messages);
  bool decoded_telemetry = false;
  for (const LinkMessage& message : messages) {
    ++health_.frames_received;
    if (session_ != nullptr && session_status_.ok()) {
      NoteSessionStatus(session_->Append(message.raw, receive_ns));
    }
    TrackAgentFrame(message);
    if (std::holds_alternative<Telemetry>(message.payload)) {
      const auto& telemetry = std::get<Telemetry>(message.payload);
      bool had_bytes = false;  // of this device, before this chunk
      Time last_bytes_at{};
      if (telemetry.device >= 1 && telemetry.device <= 3) {
        ++health_.devices[telemetry.device - 1].frames;
        health_.devices[telemetry.device - 1].bytes += telemetry.bytes.size();
        // What we hold of this device, for a TelemetryResume after an outage.
        TelemetryResumePosition& pos = positions_[telemetry.device - 1];
        had_bytes = pos.have;
        last_bytes_at = pos.after_time;
        const auto n = static_cast<uint32_t>(telemetry.bytes.size());
        if (!pos.have || telemetry.receive_time > pos.after_time) {
          pos = {true, telemetry.receive_time, n};
        } else if (telemetry.receive_time == pos.after_time) {
          pos.bytes_at_time += n;
        }
      }
      if (telemetry.flags & kTelemetryLate) {
        ++health_.late_chunks;
        health_.late_bytes += telemetry.bytes.size();
      }
      // A break before the device's first bytes (the agent marks a new
      // client's first chunks when no resume joins them) loses nothing.
      if ((telemetry.flags & kTelemetryBreak) && health_.devices[telemetry.device - 1].frames > 1) {
        ++health_.breaks;
        // As the session's decoder counts it (TelemetryDecoder), live.
        if (had_bytes) {
          const double lost = std::max(0.0, ToSeconds(telemetry.receive_time - last_bytes_at));
          health_.data_lost_s[telemetry.device - 1] += lost;
          emit dataLost(telemetry.device, lost);
        }
      }
      if (options_.decode_telemetry) {
        decoder_.AddTelemetry(telemetry);
        decoded_telemetry = true;
      }
      continue;
    }
    HandleMessage(message);
    if (stream_ == nullptr) break;  // Denied: the rest of this connection does not matter.
  }
  if (decoded_telemetry) {
    decoder_.TakeInto(&log_);
    emit telemetryDecoded();
  }
  if (stream_ == nullptr) return;
  if (decoder_link_.BufferedBytes() > options_.max_undecoded_bytes) {
    ++health_.input_floods;
    const QString reason =
        QStringLiteral("%1 MiB from the link wait to be decoded: not frames (forged or corrupt)")
            .arg(decoder_link_.BufferedBytes() / 1048576.0, 0, 'f', 1);
    decoder_link_.Reset();  // The flood's bytes go now, not at the next Connect().
    if (auto* tcp = dynamic_cast<TcpStream*>(stream_.get())) tcp->Abort();
    ScheduleReconnect(reason);
    return;
  }
  if (decoder_link_.work_pending() && !decode_scheduled_) {
    decode_scheduled_ = true;
    QTimer::singleShot(0, this, [this] {
      decode_scheduled_ = false;
      if (stream_ != nullptr) Decode(nullptr, 0);
    });
  }
}

void RobotConnection::HandleMessage(const LinkMessage& message) {
  if (message.header.sender != LinkSender::kAgent) return;
  if (message.header.version < kLinkProtocolVersion) {
    // An old agent: it cannot read our frames. Say so once and stop retrying.
    const auto* result = std::get_if<AuthResult>(&message.payload);
    Fail(result != nullptr && !result->reason.empty()
             ? QString::fromStdString(result->reason)
             : QStringLiteral("the agent speaks protocol version %1, this workstation %2: "
                              "update sweepscan-robotd")
                   .arg(message.header.version)
                   .arg(kLinkProtocolVersion));
    return;
  }
  const LinkPayload& payload = message.payload;
  if (const auto* hello = std::get_if<Hello>(&payload)) {
    health_.agent_name = hello->name;
    auth_required_ = hello->auth_required;
    if (!auth_required_) {
      health_.clock_tie.AddBracket(handshake_sent_ns_, SteadyNs(), ToNanoseconds(message.header.time));
      OnAuthenticated();
    }
    if (session_ != nullptr && session_status_.ok() && hello->name != "") {
      // Record which agent produced the frames; meta.json is rewritten atomically.
      SessionMeta meta = options_.session_meta;
      meta.link = address_.ToString().toStdString();
      meta.agent = hello->name;
      session_->UpdateMeta(meta);
    }
  } else if (const auto* challenge = std::get_if<AuthChallenge>(&payload)) {
    if (answered_challenge_ || authenticated_) return;  // One attempt per connection.
    answered_challenge_ = true;
    AuthResponse response;
    LinkSessionKey session_key;
    if (!MakeLinkAuthResponse(options_.key, *challenge, &response, &session_key)) {
      ScheduleReconnect(QStringLiteral("no random source for the client nonce"));
      return;
    }
    handshake_sent_ns_ = SteadyNs();
    SendMessage(response, false);
    // Every frame after the response carries a tag under the session key
    // (docs/protocol.md, "Frame authentication").
    encoder_.SetSigner(MakeLinkFrameSigner(session_key));
  } else if (const auto* result = std::get_if<AuthResult>(&payload)) {
    if (result->outcome == AuthOutcome::kOk) {
      // The agent stamped AuthResult between our AuthResponse and now.
      health_.clock_tie.AddBracket(handshake_sent_ns_, SteadyNs(),
                                   ToNanoseconds(message.header.time), 0);
      OnAuthenticated();
      return;
    }
    const QString reason = QString::fromStdString(result->reason);
    health_.last_error = QStringLiteral("denied: %1").arg(reason);
    emit authenticationFailed(reason);
    if (reason == QLatin1String("authentication failed") || reason.startsWith("protocol version")) {
      // A wrong key stays wrong (hammering the agent would only lock us
      // out); so does a protocol version the agent does not speak.
      if (stream_ != nullptr) {
        stream_->disconnect(this);
        stream_->Close();
        stream_.release()->deleteLater();  // We are inside its bytesReceived signal.
      }
      authenticated_ = false;
      SetState(LinkHealth::State::kFailed);
      return;
    }
    // "busy", "retry later", timeouts: try again after the backoff.
  } else if (const auto* ack = std::get_if<CommandAck>(&payload)) {
    health_.clock_tie.AddBracket(ToNanoseconds(ack->echo_time), SteadyNs(),
                                 ToNanoseconds(message.header.time));
    const double latency_ms = ToSeconds(WorkstationNow() - ack->echo_time) * 1e3;
    ++health_.latency_samples;
    health_.latency_last_ms = latency_ms;
    latency_sum_ms_ += latency_ms;
    health_.latency_mean_ms = latency_sum_ms_ / static_cast<double>(health_.latency_samples);
    health_.latency_max_ms = std::max(health_.latency_max_ms, latency_ms);
    if (ack->result != AckResult::kAccepted) ++health_.acks_refused;
    if (ack->acked_type == static_cast<uint8_t>(LinkMessageType::kEmergencyStop) &&
        ack->acked_sequence == estop_sequence_) {
      estop_owed_ = false;
    }
  } else if (const auto* status = std::get_if<LinkStatus>(&payload)) {
    health_.have_status = true;
    health_.agent_status = *status;
    emit statusReceived();
  }
}

void RobotConnection::OnClosed(const QString& reason) { ScheduleReconnect(reason); }

void RobotConnection::NoteSessionStatus(const Status& status) {
  const bool was_ok = session_status_.ok();
  session_status_ = status;
  if (was_ok && !status.ok()) emit recordingFailed(QString::fromStdString(status.message()));
}

void RobotConnection::Fail(const QString& reason) {
  health_.last_error = reason;
  emit authenticationFailed(reason);
  if (stream_ != nullptr) {
    stream_->disconnect(this);
    stream_->Close();
    stream_.release()->deleteLater();  // We may be inside its bytesReceived signal.
  }
  const bool was_authenticated = authenticated_;
  authenticated_ = false;
  if (was_authenticated) emit authenticatedChanged(false);
  SetState(LinkHealth::State::kFailed);
}

void RobotConnection::ScheduleReconnect(const QString& reason) {
  if (stopping_) return;
  connect_timeout_->stop();
  if (stream_ != nullptr) {
    stream_->disconnect(this);
    stream_->Close();
    stream_.release()->deleteLater();  // We may be inside one of its signals.
  }
  const bool was_authenticated = authenticated_;
  authenticated_ = false;
  if (was_authenticated) emit authenticatedChanged(false);
  if (health_.state == LinkHealth::State::kFailed) return;
  if (was_authenticated) NoteLinkLost(reason);
  health_.last_error = reason;
  SetState(LinkHealth::State::kWaitingToReconnect);
  reconnect_timer_->start(backoff_ms_);
  backoff_ms_ = std::min(options_.reconnect_max_ms, backoff_ms_ * 2);
}

void RobotConnection::DropLink() {
  if (stream_ == nullptr) return;
  if (auto* tcp = dynamic_cast<TcpStream*>(stream_.get())) tcp->Abort();
  ScheduleReconnect(QStringLiteral("dropped by request"));
}

bool RobotConnection::SendMessage(const LinkPayload& payload, bool require_auth) {
  if (stream_ == nullptr || !stream_->IsOpen()) return false;
  if (require_auth && !authenticated_) return false;
  const std::vector<uint8_t> frame = encoder_.Encode(WorkstationNow(), payload);
  return stream_->Write(frame.data(), frame.size());
}

bool RobotConnection::Drive(double v_mps, double w_radps) {
  return SendMessage(DriveCommand{v_mps, w_radps}, true);
}
bool RobotConnection::StopMotion() { return SendMessage(Stop{}, true); }
// An emergency stop is owed to the robot until the agent says it holds it
// (its CommandAck of the latest stop sent): written into a link
// that has died but is not yet known dead (Wi-Fi gone, TCP still open for
// the 2 s of silence), or pressed while the link is down, it never arrives.
// The watchdog stops the robot during the outage, but after the
// reconnection nothing was latched and the next Drive moved it. So an owed
// stop is sent again right after each authentication.
bool RobotConnection::EmergencyStop() {
  estop_owed_ = true;
  return SendOwedEmergencyStop(false);
}

// Only the agent's answer to the latest stop pays it: a late ack of an
// earlier one (stop, clear, stop on a dying link) must not, and neither
// must a Status sent before a Clear arrived.
bool RobotConnection::SendOwedEmergencyStop(bool require_auth) {
  estop_sequence_ = encoder_.next_sequence();
  return SendMessage(hardware::EmergencyStop{}, require_auth);
}
bool RobotConnection::ClearEmergencyStop() {
  estop_owed_ = false;  // The operator's choice now, whether or not it arrives.
  return SendMessage(hardware::ClearEmergencyStop{}, true);
}
bool RobotConnection::SetLidarMotor(bool on) { return SendMessage(LidarMotor{on}, true); }

void RobotConnection::OnHeartbeat() {
  if (heartbeat_enabled_ && authenticated_) SendMessage(Heartbeat{}, true);
}

void RobotConnection::OnFlushTimer() {
  if (session_ == nullptr || !session_status_.ok()) return;
  NoteSessionStatus(session_->FlushIfDue(std::chrono::steady_clock::now()));
  health_.session_records = session_->records_appended();
}

void RobotConnection::OnRateTimer() {
  const double dt = std::max(1e-3, rate_clock_.restart() * 1e-3);
  for (int i = 0; i < 3; ++i) {
    DeviceRate& d = health_.devices[i];
    d.frames_per_s = static_cast<double>(d.frames - rate_base_[i].frames) / dt;
    d.bytes_per_s = static_cast<double>(d.bytes - rate_base_[i].bytes) / dt;
    rate_base_[i] = d;
  }
  health_.frames_per_s = static_cast<double>(health_.frames_received - frames_base_) / dt;
  health_.bytes_per_s = static_cast<double>(health_.bytes_received - bytes_base_) / dt;
  frames_base_ = health_.frames_received;
  bytes_base_ = health_.bytes_received;
}

void RobotConnection::OnStallCheck() {
  if (stream_ == nullptr || options_.stall_ms <= 0) return;
  // A serial line (a radio link) never disconnects, and our Hello may have
  // gone out while the radio was still down. The agent then never greets
  // us again, though its telemetry arrives (so no stall either), and this
  // link stayed unauthenticated, recording the live bytes straight after
  // the outage's with no resume and no break. Say Hello again each second
  // until the agent answers.
  if (health_.state == LinkHealth::State::kAuthenticating && !authenticated_ &&
      dynamic_cast<SerialStream*>(stream_.get()) != nullptr &&
      SteadyNs() - handshake_sent_ns_ >= 1000000000) {
    Hello hello;
    hello.name = options_.client_name;
    handshake_sent_ns_ = SteadyNs();
    SendMessage(hello, false);
  }
  if (health_.state != LinkHealth::State::kConnected &&
      health_.state != LinkHealth::State::kAuthenticating) {
    return;
  }
  if (last_rx_.elapsed() < options_.stall_ms) return;
  // A stalled link (Wi-Fi behind a wall, a host gone without FIN): TCP
  // would wait minutes; the agent's Status every 100 ms says 2 s is dead.
  const QString reason =
      QStringLiteral("no frame for %1 s").arg(last_rx_.elapsed() * 1e-3, 0, 'f', 1);
  if (auto* tcp = dynamic_cast<TcpStream*>(stream_.get())) tcp->Abort();
  ScheduleReconnect(reason);
}

void RobotConnection::TrackAgentFrame(const LinkMessage& message) {
  if (message.header.sender != LinkSender::kAgent) return;
  const int64_t t = ToNanoseconds(message.header.time);
  if (first_robot_ns_ < 0) first_robot_ns_ = t;
  connection_last_robot_ns_ = std::max(connection_last_robot_ns_, t);
  last_robot_ns_ = std::max(last_robot_ns_, t);
}

void RobotConnection::AppendRecorderEvent(const RecorderEvent& event) {
  if (session_ == nullptr || !session_status_.ok()) return;
  std::vector<uint8_t> frame;
  AppendLinkFrame(LinkSender::kClient, 0, WorkstationNow(), event, &frame);
  NoteSessionStatus(session_->Append(frame, RealtimeNs()));
}

void RobotConnection::NoteLinkLost(const QString& reason) {
  ++health_.outages;
  health_.outage_open = true;
  health_.outage_reason = reason;
  health_.reconnect_attempts = 0;
  health_.outage_s = 0.0;
  // The outage began with the last byte received (a stall is noticed only
  // stall_ms later).
  outage_before_ms_ = last_rx_.isValid() ? last_rx_.elapsed() : 0;
  outage_start_ns_ = SteadyNs();
  tie_before_ = health_.clock_tie;
  robot_before_ns_ = last_robot_ns_;
  RecorderEvent event;
  event.kind = RecorderEventKind::kLinkLost;
  event.epoch = health_.clock_epoch - session_epoch_base_;
  event.workstation_time = WorkstationNow();
  event.robot_time = TimeFromNanoseconds(last_robot_ns_);
  event.reason = reason.toStdString();
  AppendRecorderEvent(event);
  emit linkLost(reason);
}

void RobotConnection::OnAuthenticated() {
  authenticated_ = true;
  health_.last_error.clear();  // Connected now; the outage keeps its reason.
  backoff_ms_ = options_.reconnect_initial_ms;
  const bool after_outage = ever_authenticated_ && health_.outage_open;
  ever_authenticated_ = true;
  QString details;
  if (after_outage) {
    health_.outage_open = false;
    health_.outage_s = (OutageMs() + outage_before_ms_) * 1e-3;
    const ClockTie& tie = health_.clock_tie;
    const bool new_epoch = NewClockEpoch(tie_before_, robot_before_ns_, tie, first_robot_ns_);
    RecorderEvent event;
    event.kind = RecorderEventKind::kLinkRestored;
    if (new_epoch) {
      ++health_.clock_epoch;
      // Robot time of this epoch -> the previous epoch's, through the
      // workstation's clock: t_prev = t + (offset_new - offset_prev).
      if (tie.valid && tie_before_.valid) time_shift_ns_ += tie.offset_ns - tie_before_.offset_ns;
      positions_ = {};  // Nothing of the new clock is held.
      last_robot_ns_ = connection_last_robot_ns_;  // The old clock's times are no reference now.
      decoder_.SetTimeShift(Duration(time_shift_ns_));
      event.new_clock_epoch = true;
    }
    event.epoch = health_.clock_epoch - session_epoch_base_;
    event.workstation_time = WorkstationNow();
    event.robot_time = TimeFromNanoseconds(std::max<int64_t>(first_robot_ns_, 0));
    event.outage = std::chrono::duration_cast<Duration>(
        std::chrono::milliseconds(OutageMs() + outage_before_ms_));
    event.robot_time_shift = Duration(time_shift_ns_);
    event.tie_uncertainty = Duration(tie.valid ? tie.uncertainty_ns : 0);
    event.attempts = health_.reconnect_attempts;
    event.resumed = options_.resume_telemetry;
    AppendRecorderEvent(event);
    const double moved_ms =
        tie.valid && tie_before_.valid ? (tie.offset_ns - tie_before_.offset_ns) * 1e-6 : 0.0;
    details = new_epoch ? QStringLiteral("robot clock reset (new epoch %1, tie +-%2 ms)")
                              .arg(health_.clock_epoch)
                              .arg(tie.uncertainty_ns * 1e-6, 0, 'f', 1)
                        : QStringLiteral("clock tie moved %1 ms +-%2 ms")
                              .arg(moved_ms, 0, 'f', 1)
                              .arg(tie.uncertainty_ns * 1e-6, 0, 'f', 1);
  }
  SetState(LinkHealth::State::kConnected);
  // The agent holds its telemetry until our first command: ask for what it
  // kept while we were away before anything else (docs/protocol.md).
  if (after_outage && options_.resume_telemetry) {
    TelemetryResume resume;
    resume.devices = positions_;
    resume_sent_ = SendMessage(resume, true);
  }
  // After the resume: the agent's first command frame releases its
  // telemetry, and the resume must be that frame.
  if (estop_owed_) SendOwedEmergencyStop(true);
  emit authenticatedChanged(true);
  if (after_outage) emit linkRestored(health_.outage_s, details);
}

LinkHealth RobotConnection::health() const {
  LinkHealth h = health_;
  if (h.outage_open) h.outage_s = (OutageMs() + outage_before_ms_) * 1e-3;
  const LinkDecoderStats& stats = decoder_link_.stats();
  h.sequence_gaps = stats.sequence[0].gaps;
  h.frames_missing = stats.sequence[0].frames_missing;
  h.crc_errors = stats.codec.checksum_errors;
  h.length_errors = stats.codec.length_errors;
  h.framing_errors = stats.codec.framing_errors;
  h.payload_errors = stats.codec.payload_errors;
  h.bytes_skipped = stats.codec.bytes_skipped;
  if (session_ != nullptr) h.session_records = session_->records_appended();
  return h;
}

}  // namespace hardware
}  // namespace sweepscan
