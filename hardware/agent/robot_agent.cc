#include "hardware/agent/robot_agent.h"

#include <QHostAddress>
#include <QStringList>
#include <QTcpServer>
#include <QTcpSocket>
#include <QTimer>
#include <algorithm>
#include <chrono>

namespace sweepscan {
namespace hardware {
namespace {

constexpr LinkDevice kDevices[3] = {LinkDevice::kLidar, LinkDevice::kImu, LinkDevice::kMotorBoard};

// What a second client gets while one is connected (docs/protocol.md,
// "One client at a time"): our Hello and a denial, on its own sequence.
std::vector<uint8_t> Refusal(const AgentOptions& options, Time now, const std::string& reason) {
  LinkEncoder encoder(LinkSender::kAgent);
  Hello hello;
  hello.auth_required = options.require_auth;
  hello.name = options.name;
  hello.devices = options.devices;
  std::vector<uint8_t> bytes = encoder.Encode(now, hello);
  const std::vector<uint8_t> denied = encoder.Encode(now, AuthResult{AuthOutcome::kDenied, reason});
  bytes.insert(bytes.end(), denied.begin(), denied.end());
  return bytes;
}

AgentOptions AdjustedOptions(const RobotAgentConfig& config) {
  AgentOptions options = config.agent;
  if (config.link != RobotAgentConfig::LinkKind::kTcp) {
    // A serial line has no connect event and no way to close: the client may
    // open it at any time, so the agent repeats its Hello when the client
    // greets, and physical access stands in for the key (docs/protocol.md).
    options.require_auth = false;
    options.hello_on_client_hello = true;
  }
  return options;
}

}  // namespace

bool RobotAgentConfig::IsValid(QString* error) const {
  std::string agent_error;
  AgentOptions adjusted = agent;
  if (link != LinkKind::kTcp) adjusted.require_auth = false;
  if (!adjusted.IsValid(&agent_error)) {
    if (error != nullptr) *error = QString::fromStdString(agent_error);
    return false;
  }
  auto fail = [error](const QString& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (link == LinkKind::kSerial && link_serial_port.isEmpty()) {
    return fail(QStringLiteral("serial link without a port"));
  }
  if (link == LinkKind::kTcp && QHostAddress(listen_address).isNull()) {
    return fail(QStringLiteral("listen address '%1' is not an IP address").arg(listen_address));
  }
  if (tick_ms <= 0 || tick_ms > 100) return fail(QStringLiteral("tick period must be 1..100 ms"));
  if (!(sim_time_scale >= 1.0 && sim_time_scale <= 1000.0)) {
    return fail(QStringLiteral("simulation time scale must be 1..1000"));
  }
  if (sim_step_ms <= 0 || sim_step_ms > 100) {
    return fail(QStringLiteral("simulator step must be 1..100 ms"));
  }
  if (lidar_baud <= 0 || imu_baud <= 0 || motor_baud <= 0 || link_baud <= 0) {
    return fail(QStringLiteral("baud rates must be positive"));
  }
  return true;
}

RobotAgent::RobotAgent(const RobotAgentConfig& config, std::unique_ptr<VirtualDevices> sim,
                       QObject* parent)
    : QObject(parent),
      config_(config),
      sim_(std::move(sim)),
      core_(std::make_unique<AgentCore>(AdjustedOptions(config))) {}

RobotAgent::~RobotAgent() { Shutdown(); }

Time RobotAgent::Now() const {
  if (sim_ != nullptr) {
    const double elapsed_ns = static_cast<double>(clock_.nsecsElapsed()) * config_.sim_time_scale;
    return Time(config_.sim_clock_origin) + Duration(static_cast<int64_t>(elapsed_ns));
  }
  return Time(
      std::chrono::duration_cast<Duration>(std::chrono::steady_clock::now().time_since_epoch()));
}

bool RobotAgent::Start(QString* error, const std::function<bool()>& stop_requested) {
  if (!config_.IsValid(error)) return false;
  clock_.start();

  switch (config_.link) {
    case RobotAgentConfig::LinkKind::kTcp: {
      server_ = new QTcpServer(this);
      if (!server_->listen(QHostAddress(config_.listen_address), config_.listen_port)) {
        if (error != nullptr) {
          *error = QStringLiteral("cannot listen on %1:%2: %3")
                       .arg(config_.listen_address)
                       .arg(config_.listen_port)
                       .arg(server_->errorString());
        }
        return false;
      }
      connect(server_, &QTcpServer::newConnection, this, &RobotAgent::OnNewTcpConnection);
      break;
    }
    case RobotAgentConfig::LinkKind::kSerial: {
      auto* stream = new SerialStream(this);
      if (!stream->Open(config_.link_serial_port, config_.link_baud, error)) {
        delete stream;
        return false;
      }
      // A radio modem that glitches or is plugged in again: its port is
      // opened again (DropClient starts this), as the devices' are.
      link_reopen_timer_ = new QTimer(this);
      connect(link_reopen_timer_, &QTimer::timeout, this, &RobotAgent::OpenSerialLink);
      AttachClient(stream);
      break;
    }
    case RobotAgentConfig::LinkKind::kPty: {
      pty_ = std::make_unique<PtyMasterStream>();
      if (!pty_->Open(error)) return false;
      AttachClient(pty_.get());
      break;
    }
  }

  if (sim_ == nullptr) {
    // The motor board first: a stop asked for while the others open (a USB
    // adapter's open can take seconds) then finds it open, and the
    // shutdown sends it its zero. The lidar last, right after the core's
    // start: the start's bytes (the board's zero, the lidar's start-up
    // sequence) wait in the output until the lidar's open dispatches them;
    // dispatched by an earlier open, the lidar's would go to a port not
    // open yet. Qt sends none of them before the event loop runs anyway.
    const QString* port[3] = {&config_.lidar_port, &config_.imu_port, &config_.motor_port};
    QStringList not_opened;
    bool stop = false;
    for (const int i : {2, 1, 0}) {
      stop = stop || (stop_requested && stop_requested());
      if (stop) {
        if (!port[i]->isEmpty()) not_opened << *port[i];
        continue;
      }
      if (i == 0) core_->Start(Now(), &out_);
      OpenDevice(i);
    }
    if (!core_->started()) core_->Start(Now(), &out_);
    if (!not_opened.isEmpty()) {
      stopped_during_start_ = true;
      Dispatch(&out_);
      emit logMessage(QStringLiteral("stop asked for during start-up: %1 not opened")
                          .arg(not_opened.join(QStringLiteral(", "))));
      return true;  // The caller shuts the agent down.
    }
    reopen_timer_ = new QTimer(this);
    connect(reopen_timer_, &QTimer::timeout, this, [this] {
      for (int i = 0; i < 3; ++i) {
        if (devices_[i] == nullptr || !devices_[i]->IsOpen()) OpenDevice(i);
      }
    });
    reopen_timer_->start(config_.device_reopen_ms);
  } else {
    core_->Start(Now(), &out_);
    sim_timer_ = new QTimer(this);
    sim_timer_->setTimerType(Qt::PreciseTimer);
    connect(sim_timer_, &QTimer::timeout, this, &RobotAgent::OnSimStep);
    sim_timer_->start(config_.sim_step_ms);
  }
  Dispatch(&out_);

  tick_timer_ = new QTimer(this);
  tick_timer_->setTimerType(Qt::PreciseTimer);
  connect(tick_timer_, &QTimer::timeout, this, &RobotAgent::OnTick);
  tick_timer_->start(config_.tick_ms);
  return true;
}

void RobotAgent::Shutdown() {
  shutting_down_ = true;
  if (tick_timer_ != nullptr) tick_timer_->stop();
  if (sim_timer_ != nullptr) sim_timer_->stop();
  if (reopen_timer_ != nullptr) reopen_timer_->stop();
  if (link_reopen_timer_ != nullptr) link_reopen_timer_->stop();
  if (client_ != nullptr) DropClient(QStringLiteral("agent shutting down"));
  while (!pending_.empty()) ClosePending(0, QString());
  if (server_ != nullptr) server_->close();
  // Zero to the motors whatever was commanded, and wait until it has left
  // the port: the event loop that would send a queued write has ended, and
  // a board that holds its last command would keep driving.
  core_->StopForShutdown(Now(), &out_);
  Dispatch(&out_);
  // Bounded (a wedged adapter would otherwise hold the stop until systemd
  // kills the agent), and said when the bound was hit.
  for (SerialStream*& device : devices_) {
    if (device != nullptr && device->IsOpen()) {
      QString why;
      if (!device->Drain(kShutdownDrainMs, &why)) {
        emit logMessage(QStringLiteral("shutting down: %1").arg(why));
      }
      device->Close();
    }
  }
}

void RobotAgent::OpenSerialLink() {
  auto* stream = new SerialStream(this);
  QString error;
  if (!stream->Open(config_.link_serial_port, config_.link_baud, &error)) {
    delete stream;
    if (!link_failed_) emit logMessage(error);  // Once, not every retry.
    link_failed_ = true;
    return;
  }
  if (link_failed_) emit logMessage(QStringLiteral("%1 reopened").arg(config_.link_serial_port));
  link_failed_ = false;
  link_reopen_timer_->stop();
  AttachClient(stream);
}

quint16 RobotAgent::tcp_port() const { return server_ != nullptr ? server_->serverPort() : 0; }

QString RobotAgent::pty_path() const { return pty_ != nullptr ? pty_->SlavePath() : QString(); }

void RobotAgent::OpenDevice(int index) {
  const QString* port[3] = {&config_.lidar_port, &config_.imu_port, &config_.motor_port};
  const qint32 baud[3] = {config_.lidar_baud, config_.imu_baud, config_.motor_baud};
  if (port[index]->isEmpty()) return;  // Not fitted.
  if (devices_[index] == nullptr) {
    devices_[index] = new SerialStream(this);
    const LinkDevice device = kDevices[index];
    connect(devices_[index], &ByteStream::bytesReceived, this, [this, device](const QByteArray& b) {
      UpdateTelemetryPause();
      core_->OnDeviceBytes(device, reinterpret_cast<const uint8_t*>(b.constData()),
                           static_cast<size_t>(b.size()), Now(), &out_);
      Dispatch(&out_);
    });
    connect(devices_[index], &ByteStream::closed, this, [this, device](const QString& reason) {
      emit logMessage(QStringLiteral("%1 port lost: %2")
                          .arg(LinkDeviceName(static_cast<uint8_t>(device)), reason));
      device_failed_[LinkDeviceIndex(device)] = true;
      core_->SetDevicePortError(device, true, Now(), &out_);
      Dispatch(&out_);
    });
  }
  QString error;
  const bool ok = devices_[index]->Open(*port[index], baud[index], &error);
  // Log transitions only: a missing adapter is retried every second.
  if (!ok && !device_failed_[index]) emit logMessage(error);
  if (ok && device_failed_[index]) emit logMessage(QStringLiteral("%1 reopened").arg(*port[index]));
  device_failed_[index] = !ok;
  core_->SetDevicePortError(kDevices[index], !ok, Now(), &out_);
  if (ok) core_->OnDevicePortOpened(kDevices[index], Now(), &out_);
  Dispatch(&out_);
}

void RobotAgent::OnNewTcpConnection() {
  while (QTcpSocket* socket = server_->nextPendingConnection()) {
    const QString peer = socket->peerAddress().toString();
    const qint64 now_ms = clock_.elapsed();
    QString refusal;
    if (client_ != nullptr && !ClientSilent()) {
      refusal = QStringLiteral("busy");
    } else if (last_auth_failure_ms_.contains(peer) &&
               now_ms - last_auth_failure_ms_.value(peer) < config_.auth_failure_delay_ms) {
      refusal = QStringLiteral("too many failed attempts, retry later");
    }
    if (!refusal.isEmpty()) {
      const auto bytes = Refusal(core_->options(), Now(), refusal.toStdString());
      socket->write(reinterpret_cast<const char*>(bytes.data()), static_cast<qint64>(bytes.size()));
      socket->disconnectFromHost();
      connect(socket, &QTcpSocket::disconnected, socket, &QObject::deleteLater);
      emit logMessage(QStringLiteral("refused %1: %2").arg(peer, refusal));
      continue;
    }
    socket->setReadBufferSize(config_.socket_read_buffer_bytes);
    if (!core_->options().require_auth) {
      // An open TCP link (no key configured on purpose): the client at once.
      client_peer_ = peer;
      AttachClient(new TcpStream(socket, this));
      continue;
    }
    if (static_cast<int>(pending_.size()) >= config_.max_pending_connections) {
      ClosePending(0, QStringLiteral("too many connections authenticating"));
    }
    auto* stream = new TcpStream(socket, this);
    Pending p;
    p.stream = stream;
    p.peer = peer;
    std::vector<uint8_t> bytes;
    p.handshake = std::make_unique<AgentHandshake>(core_->options(), Now(), &bytes);
    connect(stream, &ByteStream::bytesReceived, this,
            [this, stream](const QByteArray& b) { OnPendingBytes(stream, b); });
    connect(stream, &ByteStream::closed, this, [this, stream](const QString&) {
      for (size_t i = 0; i < pending_.size(); ++i) {
        if (pending_[i].stream == stream) {
          ClosePending(i, QString());
          return;
        }
      }
    });
    pending_.push_back(std::move(p));
    HandlePending(pending_.size() - 1, pending_.back().handshake->state(), &bytes);
  }
}

void RobotAgent::OnPendingBytes(TcpStream* stream, const QByteArray& received) {
  for (size_t i = 0; i < pending_.size(); ++i) {
    if (pending_[i].stream != stream) continue;
    std::vector<uint8_t> bytes;
    const auto state = pending_[i].handshake->OnBytes(
        reinterpret_cast<const uint8_t*>(received.constData()),
        static_cast<size_t>(received.size()), Now(), &bytes);
    HandlePending(i, state, &bytes);
    return;
  }
}

void RobotAgent::HandlePending(size_t index, AgentHandshake::State state,
                               std::vector<uint8_t>* bytes) {
  Pending& p = pending_[index];
  if (p.handshake->TakeEmergencyStop()) {
    core_->EmergencyStopFromUnauthenticated(Now(), &out_);
    Dispatch(&out_);
  }
  if (!bytes->empty()) p.stream->Write(bytes->data(), bytes->size());
  bytes->clear();
  if (state == AgentHandshake::State::kDenied) {
    const QString reason = QString::fromStdString(p.handshake->denial());
    core_->NoteDeniedHandshake(*p.handshake);
    if (p.handshake->auth_failure()) NoteAuthFailure(p.peer);
    // Let the denial reach the peer, then close.
    TcpStream* stream = p.stream;
    const QString peer = p.peer;
    pending_.erase(pending_.begin() + static_cast<std::ptrdiff_t>(index));
    stream->disconnect(this);
    if (QTcpSocket* socket = stream->socket()) {
      socket->disconnectFromHost();
      connect(socket, &QTcpSocket::disconnected, stream, &QObject::deleteLater);
      QTimer::singleShot(1000, stream, [stream] { stream->Abort(); stream->deleteLater(); });
    } else {
      stream->deleteLater();
    }
    emit logMessage(QStringLiteral("refused %1: %2").arg(peer, reason));
    return;
  }
  if (state == AgentHandshake::State::kAuthenticated) {
    Pending done = std::move(p);
    pending_.erase(pending_.begin() + static_cast<std::ptrdiff_t>(index));
    done.stream->disconnect(this);
    if (client_ != nullptr && ClientSilent()) {
      emit logMessage(QStringLiteral("%1 silent for %2 ms: replaced by %3")
                          .arg(client_peer_)
                          .arg(ToSeconds(Now() - core_->last_client_frame_time()) * 1e3, 0, 'f', 0)
                          .arg(done.peer));
      if (auto* tcp = qobject_cast<TcpStream*>(client_)) tcp->Abort();
      DropClient(QStringLiteral("replaced by a new connection (silent link)"));
    }
    if (client_ != nullptr) {
      // Another connection authenticated first.
      LinkEncoder encoder(LinkSender::kAgent, done.handshake->next_agent_sequence());
      const auto denied = encoder.Encode(Now(), AuthResult{AuthOutcome::kDenied, "busy"});
      done.stream->Write(denied.data(), denied.size());
      if (QTcpSocket* socket = done.stream->socket()) socket->disconnectFromHost();
      done.stream->deleteLater();
      return;
    }
    client_ = done.stream;
    client_peer_ = done.peer;
    connect(done.stream, &ByteStream::bytesReceived, this, &RobotAgent::OnClientBytes);
    connect(done.stream, &ByteStream::closed, this,
            [this](const QString& reason) { DropClient(reason); });
    core_->AdoptClient(done.handshake.get(), Now(), &out_);
    emit clientConnected(client_peer_);
    Dispatch(&out_);
    return;
  }
  if (p.handshake->work_pending()) ScheduleContinue();
}

void RobotAgent::ClosePending(size_t index, const QString& reason) {
  if (index >= pending_.size()) return;
  TcpStream* stream = pending_[index].stream;
  const QString peer = pending_[index].peer;
  pending_.erase(pending_.begin() + static_cast<std::ptrdiff_t>(index));
  stream->disconnect(this);
  stream->Abort();
  stream->deleteLater();
  if (!reason.isEmpty()) emit logMessage(QStringLiteral("closed %1: %2").arg(peer, reason));
}

void RobotAgent::TickPending() {
  const Time now = Now();
  for (size_t i = 0; i < pending_.size();) {
    std::vector<uint8_t> bytes;
    const auto state = pending_[i].handshake->Tick(now, &bytes);
    const size_t before = pending_.size();
    HandlePending(i, state, &bytes);
    if (pending_.size() == before) ++i;
  }
}

// Decode work the per-call bound left over: continue from the event loop, so
// timers (the watchdog tick) run in between.
void RobotAgent::ScheduleContinue() {
  if (continue_scheduled_) return;
  continue_scheduled_ = true;
  QTimer::singleShot(0, this, [this] {
    continue_scheduled_ = false;
    if (client_ != nullptr && core_->client_work_pending()) {
      core_->ContinueClientBytes(Now(), &out_);
      Dispatch(&out_);
    }
    for (size_t i = 0; i < pending_.size(); ++i) {
      if (!pending_[i].handshake->work_pending()) continue;
      std::vector<uint8_t> bytes;
      const auto state = pending_[i].handshake->OnBytes(nullptr, 0, Now(), &bytes);
      HandlePending(i, state, &bytes);
      break;  // Indices may have moved; the next round takes the others.
    }
    bool more = client_ != nullptr && core_->client_work_pending();
    for (const Pending& p : pending_) more = more || p.handshake->work_pending();
    if (more) ScheduleContinue();
  });
}

// A peer that stopped reading lets the queue grow past max_send_queue_bytes.
// A release of held telemetry (a resume's resend, or the live bytes held
// for it) is one write of up to the whole buffer, which Qt queues at once:
// that burst, as written, is allowed on top until the queue drains below
// the limit again. The allowance was the buffer's size in memory, but on
// the link each chunk costs more than its 22 bytes in the buffer (the
// frame, its tag, the telemetry header): a full 60 s buffer of short reads
// went over it, the client was dropped before a byte left, and each
// reconnection asked for the same bytes again.
bool RobotAgent::SendQueueFull(ByteStream* stream) const {
  return stream->BytesQueued() > send_queue_limit() + burst_allowance_;
}

qint64 RobotAgent::send_queue_limit() const {
  // A pty (sweepscan-sim --pty) is bounded as a serial line at link_baud:
  // it queues as one does, and its reader is the workstation's QSerialPort.
  if (config_.link == RobotAgentConfig::LinkKind::kTcp) return config_.max_send_queue_bytes;
  const qint64 line_bytes =
      static_cast<qint64>(config_.link_baud) / 10 * config_.serial_send_queue_ms / 1000;
  return std::min(config_.max_send_queue_bytes, std::max<qint64>(4096, line_bytes));
}

// QSerialPort queues whatever is written, without bound: a link slower than
// the telemetry (a radio modem at 115200 baud against ~40 kB/s, or a reader
// that stalls) grew it by 17-20 kB/s for as long as it lasted, and Status
// and acks waited behind it. A serial link cannot be dropped as a TCP peer
// is, so the telemetry gives way; the rest of the protocol keeps its time.
void RobotAgent::UpdateTelemetryPause() {
  if (config_.link == RobotAgentConfig::LinkKind::kTcp || client_ == nullptr) {
    core_->SetTelemetryPaused(false);
    return;
  }
  qint64 queued = client_->BytesQueued();
  if (queued <= send_queue_limit()) burst_allowance_ = 0;  // What a burst queued has drained.
  if (queued > 2 * send_queue_limit() + burst_allowance_) {
    // Nothing is read at all (Status and acks alone grew it this far): what
    // waits is stale; a reader that comes back gets the present instead.
    const qint64 discarded = client_->DiscardQueued();
    if (link_bytes_discarded_ == 0) {
      emit logMessage(QStringLiteral("%1 takes nothing: %2 queued bytes thrown away")
                          .arg(client_peer_)
                          .arg(discarded));
    }
    link_bytes_discarded_ += static_cast<uint64_t>(discarded);
    core_->NoteTelemetryLost();  // Telemetry queued before the pause went with it.
    queued = client_->BytesQueued();
  }
  if (!core_->telemetry_paused() && SendQueueFull(client_)) {
    core_->SetTelemetryPaused(true);
    if (telemetry_pauses_++ == 0) {
      emit logMessage(
          QStringLiteral("%1 takes the telemetry slower than it comes (%2 bytes queued): "
                         "telemetry dropped while the link is congested")
              .arg(client_peer_)
              .arg(queued));
    }
  } else if (core_->telemetry_paused() && queued <= send_queue_limit() / 2) {
    core_->SetTelemetryPaused(false);
  }
}

bool RobotAgent::ClientSilent() const {
  return client_ != nullptr && Now() - core_->last_client_frame_time() >=
                                   std::chrono::milliseconds(config_.client_takeover_after_ms);
}

void RobotAgent::AttachClient(ByteStream* stream) {
  client_ = stream;
  burst_allowance_ = 0;
  core_->SetTelemetryPaused(false);
  if (client_peer_.isEmpty()) client_peer_ = stream->Describe();
  connect(stream, &ByteStream::bytesReceived, this, &RobotAgent::OnClientBytes);
  connect(stream, &ByteStream::closed, this, [this](const QString& reason) { DropClient(reason); });
  core_->OnClientConnected(Now(), &out_);
  emit clientConnected(client_peer_);
  Dispatch(&out_);
}

// The lockout table keeps only failures inside the delay: an agent listening
// on a network with many addresses (IPv6) would otherwise keep one entry
// per address that ever failed, for as long as it runs.
void RobotAgent::NoteAuthFailure(const QString& peer) {
  const qint64 now_ms = clock_.elapsed();
  for (auto it = last_auth_failure_ms_.begin(); it != last_auth_failure_ms_.end();) {
    it = now_ms - it.value() >= config_.auth_failure_delay_ms ? last_auth_failure_ms_.erase(it)
                                                              : std::next(it);
  }
  last_auth_failure_ms_.insert(peer, now_ms);
}

void RobotAgent::DropClient(const QString& reason) {
  burst_allowance_ = 0;
  if (client_ == nullptr) return;
  ByteStream* stream = client_;
  client_ = nullptr;
  const QString peer = client_peer_;
  client_peer_.clear();
  core_->OnClientDisconnected(Now(), &out_);
  stream->disconnect(this);
  stream->Close();
  if (stream != pty_.get()) stream->deleteLater();
  emit clientDisconnected(peer, reason);
  Dispatch(&out_);
  if (link_reopen_timer_ != nullptr && !shutting_down_) {
    link_reopen_timer_->start(config_.device_reopen_ms);
  }
}

void RobotAgent::OnClientBytes(const QByteArray& bytes) {
  core_->OnClientBytes(reinterpret_cast<const uint8_t*>(bytes.constData()),
                       static_cast<size_t>(bytes.size()), Now(), &out_);
  Dispatch(&out_);
  if (client_ != nullptr && core_->client_work_pending()) ScheduleContinue();
}

void RobotAgent::OnTick() {
  UpdateTelemetryPause();  // A drained queue resumes the telemetry with no output due.
  core_->Tick(Now(), &out_);
  Dispatch(&out_);
  TickPending();
}

void RobotAgent::OnSimStep() {
  std::vector<DeviceChunk> chunks;
  sim_->AdvanceTo(Now(), &chunks);
  UpdateTelemetryPause();
  for (const DeviceChunk& chunk : chunks) {
    // An emulated read returns the moment its last byte arrived, so the
    // receive time is the chunk's own time (not this timer's lateness).
    core_->OnDeviceBytes(chunk.device, chunk.bytes.data(), chunk.bytes.size(), chunk.time, &out_);
  }
  Dispatch(&out_);
}

void RobotAgent::Dispatch(AgentOutput* out) {
  if (out->empty()) return;
  for (const std::string& line : out->log) emit logMessage(QString::fromStdString(line));
  out->log.clear();
  if (out->lidar_dtr.has_value()) {
    // The X4's motor, before the lidar's bytes (A5 60 wants it spinning).
    // On a pseudo-terminal (sweepscan-sim --device-ptys) the ioctl fails
    // with ENOTTY, which SerialStream ignores.
    if (sim_ != nullptr) {
      sim_->SetLidarDtr(*out->lidar_dtr, Now());
    } else if (devices_[0] != nullptr && devices_[0]->IsOpen()) {
      devices_[0]->SetDataTerminalReady(*out->lidar_dtr);
    }
  }
  for (int i = 0; i < 3; ++i) {
    std::vector<uint8_t>& bytes = out->to_device[i];
    if (bytes.empty()) continue;
    if (sim_ != nullptr) {
      sim_->WriteToDevice(kDevices[i], bytes.data(), bytes.size(), Now());
    } else if (devices_[i] != nullptr && devices_[i]->IsOpen()) {
      devices_[i]->Write(bytes.data(), bytes.size());
    }
  }
  const bool close = out->close_client;
  const bool auth_failure = out->auth_failure;
  const QString close_reason = QString::fromStdString(out->close_reason);
  if (client_ != nullptr && !out->to_client.empty()) {
    const qint64 limit = send_queue_limit();
    if (client_->BytesQueued() <= limit) burst_allowance_ = 0;  // What a burst queued has drained.
    const auto size = static_cast<qint64>(out->to_client.size());
    if (size > limit) burst_allowance_ = std::max(burst_allowance_, size);
    client_->Write(out->to_client.data(), out->to_client.size());
  }
  out->Clear();
  UpdateTelemetryPause();
  if (!close && client_ != nullptr && config_.link == RobotAgentConfig::LinkKind::kTcp &&
      SendQueueFull(client_)) {
    // The peer stopped reading: drop it (the watchdog trips at once, so a
    // robot it was driving stops) instead of queueing without bound.
    if (auto* tcp = qobject_cast<TcpStream*>(client_)) tcp->Abort();
    DropClient(QStringLiteral("peer stopped reading (send queue over %1 bytes)")
                   .arg(config_.max_send_queue_bytes));
    return;
  }
  if (close && client_ != nullptr) {
    if (config_.link == RobotAgentConfig::LinkKind::kTcp) {
      if (auth_failure) NoteAuthFailure(client_peer_);
      DropClient(close_reason.isEmpty() ? QStringLiteral("denied") : close_reason);
    } else {
      // A serial line cannot be closed: start the session over.
      core_->OnClientDisconnected(Now(), out);
      core_->OnClientConnected(Now(), out);
      Dispatch(out);
    }
  }
}

}  // namespace hardware
}  // namespace sweepscan
