// The robot agent as a Qt object: AgentCore (the logic) wired to real byte
// streams. Used by sweepscan-robotd (serial device ports) and sweepscan-sim
// (SimDevices, the byte-exact device emulations, advanced in real time).
//
//   devices: three SerialStreams (X4 128000, HI219 115200, motor board 115200)
//            or a SimDevices advanced from a timer;
//   link:    a QTcpServer (127.0.0.1 unless told otherwise). Each new
//            connection authenticates on its own (AgentHandshake, deadline
//            2 s, no answers beyond the challenge); only an authenticated
//            one becomes the client, so keyless connections never hold the
//            slot. While a client is connected, new connections get
//            AuthResult denied "busy". Or a serial port, or the master of a
//            pseudo-terminal (sweepscan-sim --pty). Every connection has a
//            bounded send queue (a TCP peer that stops reading is dropped; a
//            serial link too slow for the telemetry loses telemetry, marked
//            as breaks, instead) and a bounded read buffer; decode work per event is bounded, so
//            the tick timer (watchdog) keeps its time under any input;
//   timer:   Tick() every tick_period (watchdog, ramps, motor and Status cadence).
//
// Robot clock: CLOCK_MONOTONIC (std::chrono::steady_clock) for real devices;
// for the simulator, the time since Start() plus sim_clock_origin (1 s),
// the simulated world's own clock, so telemetry times equal simulated times.
//
// Threading: a RobotAgent, its streams, its SimDevices and its AgentCore all
// live on the thread that created it (the agent's I/O thread, in the
// executables the main thread, which does nothing else). Nothing blocks:
// reads are event driven, writes queued or non-blocking.
#ifndef SWEEPSCAN_HARDWARE_AGENT_ROBOT_AGENT_H_
#define SWEEPSCAN_HARDWARE_AGENT_ROBOT_AGENT_H_

#include <QElapsedTimer>
#include <QHash>
#include <QObject>
#include <QString>
#include <array>
#include <functional>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/common/time.h"
#include "hardware/agent/agent_core.h"
#include "hardware/link/qt_transport.h"

class QTcpServer;
class QTimer;

namespace sweepscan {
namespace hardware {

// Devices emulated in-process instead of serial ports (the simulator). An
// interface so sweepscan-robotd does not link the simulated world (PCL,
// Ceres); SimDevicesAdapter below plugs hardware/emulation/sim_devices.h in.
struct DeviceChunk {
  LinkDevice device = LinkDevice::kLidar;
  Time time;  // Robot time at which the agent can read these bytes.
  std::vector<uint8_t> bytes;
};
class VirtualDevices {
 public:
  virtual ~VirtualDevices() = default;
  virtual void WriteToDevice(LinkDevice device, const uint8_t* data, size_t n, Time now) = 0;
  // The lidar port's DTR line (the X4's motor on its USB adapter), set
  // before the bytes written with it. Ignored by default: the simulator's
  // X4 scans on A5 60 alone, as SimulateSession (the reference the link
  // tests compare with) drives it.
  virtual void SetLidarDtr(bool /*on*/, Time /*now*/) {}
  // Appends everything the devices sent up to `now`, in time order.
  virtual void AdvanceTo(Time now, std::vector<DeviceChunk>* out) = 0;
};

// Adapter for hardware::SimDevices (a template so this header need not
// include the simulator):
//   RobotAgent agent(config, std::make_unique<SimDevicesAdapter<SimDevices, TimedBytes>>(
//                                std::move(sim)));
template <typename Sim, typename Chunk>
class SimDevicesAdapter : public VirtualDevices {
 public:
  explicit SimDevicesAdapter(std::unique_ptr<Sim> sim) : sim_(std::move(sim)) {}
  void WriteToDevice(LinkDevice device, const uint8_t* data, size_t n, Time now) override {
    sim_->WriteToDevice(device, data, n, now);
  }
  void AdvanceTo(Time now, std::vector<DeviceChunk>* out) override {
    chunks_.clear();
    sim_->AdvanceTo(now, &chunks_);
    for (auto& chunk : chunks_) out->push_back({chunk.device, chunk.time, std::move(chunk.bytes)});
  }
  Sim* sim() const { return sim_.get(); }

 private:
  std::unique_ptr<Sim> sim_;
  std::vector<Chunk> chunks_;  // Reused between steps.
};

struct RobotAgentConfig {
  AgentOptions agent;  // require_auth is forced off for serial and pty links.

  enum class LinkKind { kTcp, kSerial, kPty };
  LinkKind link = LinkKind::kTcp;
  QString listen_address = QStringLiteral("127.0.0.1");  // kTcp.
  quint16 listen_port = 5600;                            // kTcp; 0 = any free port.
  QString link_serial_port;                              // kSerial.
  qint32 link_baud = 921600;                             // kSerial (kPty: its queue's bound).

  // Device ports (ignored with a SimDevices). An empty path means "not
  // fitted": no Telemetry for it, and its silence is reported in Status.
  QString lidar_port;
  QString imu_port;
  QString motor_port;
  qint32 lidar_baud = 128000;
  qint32 imu_baud = 115200;
  qint32 motor_baud = 115200;
  int device_reopen_ms = 1000;  // Retry a failed device port this often.

  int tick_ms = 10;     // AgentCore::Tick cadence (the watchdog's resolution).
  int sim_step_ms = 5;  // SimDevices::AdvanceTo cadence.
  // Robot time at Start() with virtual devices: sim::SimWorld::kStartTimeS
  // (1 s; not included here to keep the simulator out of sweepscan-robotd).
  Duration sim_clock_origin = std::chrono::seconds(1);
  // With virtual devices: robot seconds per wall-clock second (soak tests
  // stream an hour of scanning in minutes). 1 = real time.
  double sim_time_scale = 1.0;
  // After a denied authentication, further connections from the same
  // address are refused for this long (slows down key guessing).
  int auth_failure_delay_ms = 1000;
  // Connections still authenticating, at most (the oldest is closed when a
  // new one arrives beyond this). They never hold the client slot.
  int max_pending_connections = 16;
  // Bytes queued for a peer that does not read them: beyond this the peer is
  // dropped (and the robot stopped if it was driving). ~30 s of telemetry.
  // A release of held telemetry (a resume's resend) adds what it wrote on
  // top, until the queue drains below this again.
  qint64 max_send_queue_bytes = 1 << 20;
  // A serial link cannot drop a peer that reads slower than the telemetry
  // comes (a radio modem, a low line rate): its queue is bounded instead to
  // this many milliseconds at the link's line rate (link_baud / 10 bytes a
  // second, 8N1; at least 4 KiB, at most max_send_queue_bytes). Beyond it
  // (plus a release of held telemetry, as above) live telemetry is dropped,
  // each device's next chunk marked as a break, until the queue has drained
  // to half of it; Status and acks still go out. A reader that takes
  // nothing at all would still let those grow (~1 kB/s): at twice the bound
  // the queue is thrown away, so what a returning reader gets is at most
  // about two seconds old.
  int serial_send_queue_ms = 1000;
  // A client that has sent nothing for this long while another connection
  // authenticates with the key is taken to be gone (a half-open link: its
  // host vanished without FIN, or its Wi-Fi dropped) and is replaced,
  // instead of refusing the new one as "busy" until TCP gives up minutes later.
  int client_takeover_after_ms = 1000;
  // Qt's read buffer per agent socket: bounds the bytes one read hands to
  // the decoder, hence the work between two watchdog ticks.
  qint64 socket_read_buffer_bytes = 64 * 1024;

  bool IsValid(QString* error) const;
};

class RobotAgent : public QObject {
  Q_OBJECT
 public:
  // `devices` (optional) replaces the device ports.
  explicit RobotAgent(const RobotAgentConfig& config,
                      std::unique_ptr<VirtualDevices> devices = nullptr, QObject* parent = nullptr);
  ~RobotAgent() override;

  // Opens the devices (a device that fails to open is retried and reported
  // as a port error; the agent still runs) and the link. False with a
  // message when the link cannot be served (port in use, bad address).
  // `stop_requested` (optional) is asked before each device port opens
  // (sweepscan-robotd: a quit signal came during a slow open): once it
  // says true the rest are not opened; if any was left, Start() returns
  // with stopped_during_start() set (and its timers not started) and the
  // caller is to call Shutdown() (the motor board, opened first, gets its
  // zero there).
  bool Start(QString* error, const std::function<bool()>& stop_requested = nullptr);
  bool stopped_during_start() const { return stopped_during_start_; }
  void Shutdown();

  quint16 tcp_port() const;  // The listening port (useful with listen_port 0).
  QString pty_path() const;  // kPty: the slave path for the workstation.
  Time Now() const;          // The robot clock.
  const AgentCore& core() const { return *core_; }
  VirtualDevices* virtual_devices() const { return sim_.get(); }  // Null for real devices.
  // Addresses whose last failed authentication is within the delay (the
  // lockout table; pruned as failures come).
  int auth_failures_remembered() const { return last_auth_failure_ms_.size(); }
  bool has_client() const { return client_ != nullptr; }
  int pending_connections() const { return static_cast<int>(pending_.size()); }
  // Bytes written to the client's link that it has not taken yet (0 on a pty).
  qint64 client_bytes_queued() const { return client_ != nullptr ? client_->BytesQueued() : 0; }
  // The bound on client_bytes_queued() (before a release's burst allowance).
  qint64 send_queue_limit() const;
  // Times live telemetry was paused for a congested serial link, and the
  // bytes thrown away from its queue at twice the bound.
  uint64_t telemetry_pauses() const { return telemetry_pauses_; }
  uint64_t link_bytes_discarded() const { return link_bytes_discarded_; }

 signals:
  void clientConnected(const QString& peer);
  void clientDisconnected(const QString& peer, const QString& reason);
  void logMessage(const QString& message);

 private:
  struct Pending {
    TcpStream* stream = nullptr;
    QString peer;
    std::unique_ptr<AgentHandshake> handshake;
  };
  void OnNewTcpConnection();
  void OnPendingBytes(TcpStream* stream, const QByteArray& bytes);
  void HandlePending(size_t index, AgentHandshake::State state, std::vector<uint8_t>* bytes);
  void ClosePending(size_t index, const QString& reason);
  void TickPending();
  void ScheduleContinue();
  bool SendQueueFull(ByteStream* stream) const;
  // kSerial: pauses live telemetry while the link's queue is over its bound
  // and resumes it once the queue has drained to half (AgentCore::SetTelemetryPaused).
  void UpdateTelemetryPause();
  // The client has sent nothing for client_takeover_after_ms.
  bool ClientSilent() const;
  void AttachClient(ByteStream* stream);
  void DropClient(const QString& reason);
  void NoteAuthFailure(const QString& peer);
  void OnClientBytes(const QByteArray& bytes);
  void OnTick();
  void OnSimStep();
  void OpenDevice(int index);
  // kSerial: opens the link's port again after it was lost (retried every
  // device_reopen_ms until it opens).
  void OpenSerialLink();
  void Dispatch(AgentOutput* out);
  static constexpr int kShutdownDrainMs = 200;

  RobotAgentConfig config_;
  std::unique_ptr<VirtualDevices> sim_;
  std::unique_ptr<AgentCore> core_;
  QElapsedTimer clock_;  // Sim clock origin.
  QTcpServer* server_ = nullptr;
  ByteStream* client_ = nullptr;  // The one connected client (owned, child of this).
  QString client_peer_;
  std::unique_ptr<PtyMasterStream> pty_;
  std::array<SerialStream*, 3> devices_{};
  std::array<bool, 3> device_failed_{};  // Open failed or port lost (logged once).
  QTimer* tick_timer_ = nullptr;
  QTimer* link_reopen_timer_ = nullptr;  // kSerial.
  bool link_failed_ = false;             // Reopening the serial link failed (logged once).
  bool shutting_down_ = false;
  bool stopped_during_start_ = false;
  QTimer* sim_timer_ = nullptr;
  QTimer* reopen_timer_ = nullptr;
  // Peer address -> clock_ ms of its last failed authentication, within
  // auth_failure_delay_ms (NoteAuthFailure prunes the older ones).
  QHash<QString, qint64> last_auth_failure_ms_;
  // A burst of released telemetry queued at once, allowed on top of
  // max_send_queue_bytes until the queue drains below it (SendQueueFull).
  qint64 burst_allowance_ = 0;
  uint64_t telemetry_pauses_ = 0;
  uint64_t link_bytes_discarded_ = 0;
  std::vector<Pending> pending_;                // Connections still authenticating.
  bool continue_scheduled_ = false;             // Decode work left by the per-call bound.
  AgentOutput out_;
};

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_AGENT_ROBOT_AGENT_H_
