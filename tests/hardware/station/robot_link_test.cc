// End to end: the simulated robot (SimDevices in kCommanded mode behind
// RobotAgent, the code of sweepscan-sim) and the workstation
// (RobotConnection) over loopback TCP and over a real pseudo-terminal. The
// workstation drives, records a session, and the session reloads and decodes
// into scans, IMU and wheel records; a quiet or dropped link stops the
// simulated robot within the watchdog time; a wrong key is refused and the
// robot does not move; a recorder killed with SIGKILL leaves a session that
// reloads with everything older than one second.
//
// Runs on one thread with a QCoreApplication; waits pump the event loop with
// generous timeouts (a loaded 2-core machine), bounds are tight only where the
// protocol demands them (watchdog).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <QCoreApplication>
#include <QDir>
#include <QElapsedTimer>
#include <QFile>
#include <QHostAddress>
#include <QProcess>
#include <QTcpSocket>
#include <QTemporaryDir>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "core/cloud/reconstruct.h"
#include "core/scenario/scenario.h"
#include "core/session/session.h"
#include "core/sim/world.h"
#include "hardware/agent/robot_agent.h"
#include "hardware/emulation/sim_devices.h"
#include "hardware/emulation/simulate_session.h"
#include "hardware/link/telemetry_decoder.h"
#include "hardware/station/robot_connection.h"
#include "tests/testing/qt_wait.h"
#include "tests/testing/scenario_file.h"

namespace sweepscan {
namespace hardware {
namespace {

using Adapter = SimDevicesAdapter<SimDevices, TimedBytes>;

const char kKey[] = "test key: 0123456789abcdef";

std::vector<uint8_t> KeyBytes(const std::string& s = kKey) {
  return std::vector<uint8_t>(s.begin(), s.end());
}

using testing::WaitFor;
using testing::Pump;

sim::SimConfig LabWorld() { return sweepscan::testing::ScenarioFile("lab.json"); }

// The simulated robot of sweepscan-sim, in-process.
struct SimRobot {
  explicit SimRobot(RobotAgentConfig::LinkKind link, int auth_failure_delay_ms = 1000) {
    RobotAgentConfig config;
    config.link = link;
    config.listen_port = 0;  // Any free port: tests run in parallel.
    config.agent.key = KeyBytes();
    config.agent.name = "sweepscan-sim test";
    config.auth_failure_delay_ms = auth_failure_delay_ms;
    auto sim = std::make_unique<SimDevices>(LabWorld(), SimDevices::Mode::kCommanded);
    auto adapter = std::make_unique<Adapter>(std::move(sim));
    adapter_ = adapter.get();
    agent = std::make_unique<RobotAgent>(config, std::move(adapter));
    QString error;
    started = agent->Start(&error);
    EXPECT_TRUE(started) << error.toStdString();
  }
  SimDevices& sim() const { return *adapter_->sim(); }
  QString Address() const {
    if (!agent->pty_path().isEmpty()) return "serial:" + agent->pty_path();
    return QStringLiteral("tcp:127.0.0.1:%1").arg(agent->tcp_port());
  }
  double Speed() const { return std::abs(sim().CurrentTwist().v); }

  std::unique_ptr<RobotAgent> agent;
  bool started = false;

 private:
  Adapter* adapter_ = nullptr;
};

RobotConnectionOptions ClientOptions(const QString& address, const QString& session_dir = {}) {
  RobotConnectionOptions options;
  options.address = address;
  options.key = KeyBytes();
  options.session_dir = session_dir;
  options.session_meta.notes = "robot_link_test";
  return options;
}

class RobotLinkTest : public ::testing::TestWithParam<RobotAgentConfig::LinkKind> {};

// Drive a short path, record, reload and decode.
TEST_P(RobotLinkTest, DrivesAPathAndRecordsASessionThatDecodes) {
  SimRobot robot(GetParam());
  ASSERT_TRUE(robot.started);
  QTemporaryDir tmp;
  const QString dir = tmp.path() + "/drive.sweepscan";
  RobotConnection client(ClientOptions(robot.Address(), dir));
  QString error;
  ASSERT_TRUE(client.Start(&error)) << error.toStdString();
  ASSERT_TRUE(WaitFor([&] { return client.authenticated(); }, 10000)) << client.health().ToString();
  EXPECT_TRUE(client.SetLidarMotor(true));
  Pump(300);
  // A gentle arc, 2 s, re-sent at 5 Hz as an operator's joystick would.
  QElapsedTimer drive;
  drive.start();
  while (drive.elapsed() < 2000) {
    client.Drive(0.2, 0.2);
    Pump(200);
  }
  EXPECT_GT(robot.Speed(), 0.1);
  EXPECT_EQ(robot.agent->core().watchdog_state(), WatchdogState::kArmed);
  client.StopMotion();
  ASSERT_TRUE(WaitFor([&] { return robot.Speed() < 1e-3; }, 5000));
  Pump(500);

  const LinkHealth health = client.health();
  EXPECT_EQ(health.state, LinkHealth::State::kConnected);
  EXPECT_EQ(health.crc_errors, 0u);
  EXPECT_EQ(health.frames_missing, 0u);
  EXPECT_GT(health.latency_samples, 10u);
  EXPECT_GT(health.latency_mean_ms, 0.0);
  EXPECT_LT(health.latency_mean_ms, 1000.0);
  EXPECT_TRUE(health.have_status);
  EXPECT_GT(health.devices[0].bytes, 1000u);  // lidar
  EXPECT_GT(health.devices[1].frames, 50u);   // imu
  EXPECT_GT(health.devices[2].frames, 10u);   // motor board
  const SensorLog& live = client.log();
  EXPECT_GT(live.scans.size(), 5u);
  EXPECT_GT(live.imu.size(), 100u);
  EXPECT_GT(live.wheels.size(), 20u);
  client.Shutdown();
  ASSERT_TRUE(client.session_status().ok()) << client.session_status().message();

  // Reload and decode the recording; it must hold what the live decoder saw.
  SensorLog log;
  SessionDecodeInfo info;
  const Status decoded = DecodeSession(dir.toStdString(), &log, &info);
  ASSERT_TRUE(decoded.ok()) << decoded.message();
  EXPECT_EQ(info.frames_refused, 0u);
  EXPECT_FALSE(info.frames.truncated_tail);
  EXPECT_EQ(info.link.sequence[0].frames_missing, 0u);
  EXPECT_EQ(info.meta.agent, "sweepscan-sim test");
  EXPECT_EQ(log.scans.size(), live.scans.size());
  EXPECT_EQ(log.imu.size(), live.imu.size());
  EXPECT_EQ(log.wheels.size(), live.wheels.size());
  // The wheels reached the commanded arc: v = 0.2 m/s -> both near 0.2 m/s
  // give or take w * wheel_distance / 2.
  double max_mean = 0.0;
  for (const auto& w : log.wheels) max_mean = std::max(max_mean, 0.5 * (w.left_mps + w.right_mps));
  EXPECT_NEAR(max_mean, 0.2, 0.03);
  std::fprintf(stderr, "%s\nlatency mean %.3f ms max %.3f ms over %llu acks\n",
               health.ToString().c_str(), health.latency_mean_ms, health.latency_max_ms,
               static_cast<unsigned long long>(health.latency_samples));
}

// The client goes quiet mid-drive (no heartbeat, no drive; the connection
// stays up): the agent commands zero within the watchdog period plus a tick.
TEST_P(RobotLinkTest, QuietLinkMidDriveStopsTheRobotWithinTheWatchdogTime) {
  SimRobot robot(GetParam());
  ASSERT_TRUE(robot.started);
  RobotConnection client(ClientOptions(robot.Address()));
  QString error;
  ASSERT_TRUE(client.Start(&error)) << error.toStdString();
  ASSERT_TRUE(WaitFor([&] { return client.authenticated(); }, 10000));
  client.Drive(0.3, 0.0);
  ASSERT_TRUE(WaitFor([&] { return robot.Speed() > 0.2; }, 5000));
  client.SetHeartbeatEnabled(false);
  // The last frame the agent will see: this Drive (stamped by the agent on
  // arrival, which is after `sent`).
  client.Drive(0.3, 0.0);
  const Time sent = robot.agent->Now();
  Time tripped_at;
  ASSERT_TRUE(WaitFor(
      [&] {
        if (robot.agent->core().watchdog_state() != WatchdogState::kTripped) return false;
        tripped_at = robot.agent->Now();
        return true;
      },
      5000));
  const Duration reaction = tripped_at - sent;
  // 500 ms watchdog + one 10 ms tick, + 40 ms for a late timer on a loaded machine.
  EXPECT_LE(reaction, std::chrono::milliseconds(550)) << ToSeconds(reaction);
  EXPECT_GE(reaction, std::chrono::milliseconds(480)) << ToSeconds(reaction);
  EXPECT_EQ(robot.agent->core().applied_v_mps(), 0.0);
  // The simulated board got the zero: its twist decays with its own lag.
  EXPECT_TRUE(WaitFor([&] { return robot.Speed() < 1e-3; }, 2000)) << robot.Speed();
  EXPECT_TRUE(WaitFor(
      [&] {
        return client.health().have_status &&
               client.health().agent_status.watchdog == WatchdogState::kTripped;
      },
      2000));
  EXPECT_EQ(client.health().agent_status.watchdog_trips, 1u);
}

// The end-to-end check: the simulator drives a scripted path in real
// time, the workstation records it over the link, and the recording's
// reconstruction matches `sweepscan-cli simulate`'s (SimulateSession, the
// same world as fast as possible) within numerical noise. The path starts
// with the robot standing still so the workstation is connected and the
// lidar spinning before anything moves.
TEST_P(RobotLinkTest, ScriptedDriveReconstructsLikeSimulate) {
  sim::SimConfig config = LabWorld();
  config.path = {{0.0, 0.0, 1.5}, {0.2, 0.0, 2.0}, {0.0, 0.3, 1.5}};
  RobotAgentConfig agent_config;
  agent_config.link = GetParam();
  agent_config.listen_port = 0;
  agent_config.agent.key = KeyBytes();
  agent_config.agent.name = "sweepscan-sim test";
  auto adapter = std::make_unique<Adapter>(std::make_unique<SimDevices>(config, SimDevices::Mode::kScripted));
  Adapter* sim = adapter.get();
  RobotAgent agent(agent_config, std::move(adapter));
  QString error;
  ASSERT_TRUE(agent.Start(&error)) << error.toStdString();
  const QString address = agent.pty_path().isEmpty() ? QStringLiteral("tcp:127.0.0.1:%1").arg(agent.tcp_port())
                                                     : "serial:" + agent.pty_path();
  QTemporaryDir tmp;
  const QString dir = tmp.path() + "/live.sweepscan";
  RobotConnection client(ClientOptions(address, dir));
  ASSERT_TRUE(client.Start(&error)) << error.toStdString();
  ASSERT_TRUE(WaitFor([&] { return client.authenticated(); }, 10000)) << client.health().ToString();
  EXPECT_TRUE(client.SetLidarMotor(true));
  ASSERT_TRUE(WaitFor([&] { return sim->sim()->finished(); }, 20000));
  Pump(500);
  client.Shutdown();
  ASSERT_TRUE(client.session_status().ok()) << client.session_status().message();

  SensorLog live;
  SessionDecodeInfo info;
  ASSERT_TRUE(DecodeSession(dir.toStdString(), &live, &info).ok());
  EXPECT_EQ(info.frames_refused, 0u);
  SensorLog fast;
  {
    SimulateSessionReport report;
    ASSERT_TRUE(SimulateSession(config, tmp.path().toStdString() + "/fast.sweepscan", SimulateSessionOptions(), &report).ok());
    ASSERT_TRUE(DecodeSession(tmp.path().toStdString() + "/fast.sweepscan", &fast, &info).ok());
  }
  // The client connects while the agent already streams, so the live
  // recording may lack the first IMU and wheel records (more often on a busy
  // machine). The EKF remembers its first readings for a while (at a slow
  // start the tilt averages seconds of them, ekf.h), so a missing first
  // reading would move the whole 5 s cloud by a few tenths of a millimetre.
  // Both logs therefore start at the live one's first IMU and wheel record:
  // from there they must hold the same records and give the same cloud.
  ASSERT_FALSE(live.imu.empty());
  ASSERT_FALSE(live.wheels.empty());
  const Time start = std::max(live.imu.front().time, live.wheels.front().time);
  for (SensorLog* log : {&live, &fast}) {
    const auto before = [start](const auto& m) { return m.time < start; };
    log->imu.erase(std::remove_if(log->imu.begin(), log->imu.end(), before), log->imu.end());
    log->wheels.erase(std::remove_if(log->wheels.begin(), log->wheels.end(), before), log->wheels.end());
  }
  EXPECT_LE(fast.imu.size() - live.imu.size(), 1u);
  ReconstructionOptions options;
  ReconstructionResult a, b;
  ASSERT_TRUE(Reconstruct(live, config.geometry, options, nullptr, &a).ok());
  ASSERT_TRUE(Reconstruct(fast, config.geometry, options, nullptr, &b).ok());
  // Match points by sample time; the live recording may have missed the
  // first revolution while the lidar spun up.
  std::map<int64_t, const CloudPoint*> by_time;
  for (const CloudPoint& p : b.points) by_time[p.time_ns] = &p;
  std::vector<double> d;
  for (const CloudPoint& p : a.points) {
    const auto it = by_time.find(p.time_ns);
    if (it != by_time.end()) d.push_back(std::hypot(p.x - it->second->x, p.y - it->second->y, p.z - it->second->z));
  }
  ASSERT_GT(d.size(), 0.8 * b.points.size()) << a.points.size() << " live points, " << b.points.size() << " fast";
  std::sort(d.begin(), d.end());
  std::fprintf(stderr, "live vs simulate: %zu of %zu points matched; median %.4f mm, max %.4f mm\n", d.size(),
               b.points.size(), 1e3 * d[d.size() / 2], 1e3 * d.back());
  EXPECT_LT(d[d.size() / 2], 1e-4);
  EXPECT_LT(d.back(), 2e-3);
}

INSTANTIATE_TEST_SUITE_P(TcpAndPty, RobotLinkTest,
                         ::testing::Values(RobotAgentConfig::LinkKind::kTcp,
                                           RobotAgentConfig::LinkKind::kPty),
                         [](const auto& info) {
                           return info.param == RobotAgentConfig::LinkKind::kTcp ? "Tcp" : "Pty";
                         });

TEST(RobotLinkTcpTest, DroppedConnectionStopsTheRobotAtOnceAndTheClientReconnects) {
  SimRobot robot(RobotAgentConfig::LinkKind::kTcp);
  ASSERT_TRUE(robot.started);
  RobotConnection client(ClientOptions(robot.Address()));
  QString error;
  ASSERT_TRUE(client.Start(&error));
  ASSERT_TRUE(WaitFor([&] { return client.authenticated(); }, 10000));
  client.Drive(0.3, 0.2);
  ASSERT_TRUE(WaitFor([&] { return robot.Speed() > 0.2; }, 5000));
  const Time dropped = robot.agent->Now();
  client.DropLink();
  ASSERT_TRUE(WaitFor(
      [&] { return robot.agent->core().watchdog_state() == WatchdogState::kTripped; }, 5000));
  EXPECT_LE(robot.agent->Now() - dropped, std::chrono::milliseconds(500));
  EXPECT_TRUE(WaitFor([&] { return robot.Speed() < 1e-3; }, 2000));
  // The connection comes back by itself (backoff) and authenticates again.
  ASSERT_TRUE(WaitFor([&] { return client.authenticated(); }, 10000)) << client.health().ToString();
  EXPECT_EQ(client.health().reconnects, 1u);
  // Still stopped until a new Drive.
  Pump(300);
  EXPECT_LT(robot.Speed(), 1e-3);
}

TEST(RobotLinkTcpTest, WrongKeyIsRefusedAndTheRobotDoesNotMove) {
  SimRobot robot(RobotAgentConfig::LinkKind::kTcp);
  ASSERT_TRUE(robot.started);
  RobotConnectionOptions options = ClientOptions(robot.Address());
  options.key = KeyBytes("not the key");
  RobotConnection client(options);
  QString error;
  ASSERT_TRUE(client.Start(&error));
  QString reason;
  QObject::connect(&client, &RobotConnection::authenticationFailed,
                   [&](const QString& r) { reason = r; });
  ASSERT_TRUE(WaitFor([&] { return client.health().state == LinkHealth::State::kFailed; }, 10000))
      << client.health().ToString();
  EXPECT_EQ(reason, QStringLiteral("authentication failed"));
  EXPECT_FALSE(client.authenticated());
  EXPECT_FALSE(client.Drive(0.5, 0.0));  // The client itself refuses to send.
  Pump(1000);
  EXPECT_EQ(robot.Speed(), 0.0);
  EXPECT_EQ(robot.agent->core().counters().auth_denied, 1u);
  EXPECT_FALSE(robot.agent->has_client());
  EXPECT_EQ(robot.agent->core().applied_v_mps(), 0.0);
}

// The lockout table of failed authentications keeps only the addresses
// inside the delay: one entry per address that ever failed grew without
// bound (an agent listening where an attacker has many addresses, IPv6).
// Wrong keys from four loopback addresses, then one more after the delay.
TEST(RobotLinkTcpTest, TheFailedAuthenticationLockoutForgetsAddressesAfterItsDelay) {
  // A 5 s delay: the four handshakes fit in it on a loaded machine.
  SimRobot robot(RobotAgentConfig::LinkKind::kTcp, 5000);
  ASSERT_TRUE(robot.started);
  const auto fail_from = [&](const QString& address) {
    QTcpSocket socket;
    ASSERT_TRUE(socket.bind(QHostAddress(address)));
    socket.connectToHost(QStringLiteral("127.0.0.1"), robot.agent->tcp_port());
    LinkDecoder decoder;
    std::vector<LinkMessage> received;
    const AuthChallenge* challenge = nullptr;
    ASSERT_TRUE(WaitFor(
        [&] {
          const QByteArray bytes = socket.readAll();
          decoder.Feed(reinterpret_cast<const uint8_t*>(bytes.constData()), bytes.size(),
                       &received);
          for (const LinkMessage& m : received) {
            if (const auto* c = std::get_if<AuthChallenge>(&m.payload)) challenge = c;
          }
          return challenge != nullptr;
        },
        5000));
    AuthResponse response;
    LinkSessionKey session;
    ASSERT_TRUE(MakeLinkAuthResponse(KeyBytes("not the key"), *challenge, &response, &session));
    LinkEncoder encoder(LinkSender::kClient);
    const std::vector<uint8_t> frame = encoder.Encode(Time(), response);
    socket.write(reinterpret_cast<const char*>(frame.data()), frame.size());
    ASSERT_TRUE(WaitFor([&] { return socket.state() == QAbstractSocket::UnconnectedState; }, 5000));
  };
  for (const char* address : {"127.0.0.2", "127.0.0.3", "127.0.0.4", "127.0.0.5"})
    fail_from(address);
  EXPECT_EQ(robot.agent->auth_failures_remembered(), 4);
  Pump(5100);  // auth_failure_delay_ms
  fail_from(QStringLiteral("127.0.0.6"));
  EXPECT_EQ(robot.agent->auth_failures_remembered(), 1);
  EXPECT_EQ(robot.agent->core().counters().auth_denied, 5u);
}

// On a serial (radio) link nothing tells the workstation that its Hello was
// lost: the agent, which never heard it, never greets again, though its
// telemetry may flow. The workstation says Hello again each second until
// the agent answers. Here the test plays the agent on a pty and ignores
// the first two Hellos.
TEST(RobotLinkSerialTest, AHelloLostOnTheRadioIsSaidAgainUntilTheAgentAnswers) {
  PtyMasterStream agent_end;
  QString error;
  ASSERT_TRUE(agent_end.Open(&error)) << error.toStdString();
  LinkDecoder decoder;
  std::vector<QElapsedTimer> hellos;
  QObject::connect(&agent_end, &ByteStream::bytesReceived, [&](const QByteArray& bytes) {
    std::vector<LinkMessage> received;
    decoder.Feed(reinterpret_cast<const uint8_t*>(bytes.constData()), bytes.size(), &received);
    for (const LinkMessage& m : received) {
      if (std::holds_alternative<Hello>(m.payload)) hellos.emplace_back().start();
    }
  });
  RobotConnection client(ClientOptions("serial:" + agent_end.SlavePath()));
  ASSERT_TRUE(client.Start(&error)) << error.toStdString();
  // The agent's telemetry flows meanwhile: no stall, no reconnection.
  LinkEncoder encoder(LinkSender::kAgent);
  QElapsedTimer clock;
  clock.start();
  while (hellos.size() < 3 && clock.elapsed() < 6000) {
    Telemetry t;
    t.device = 1;
    t.receive_time = TimeFromNanoseconds(clock.nsecsElapsed());
    t.bytes = {0xA5, 0x5A};
    const std::vector<uint8_t> frame = encoder.Encode(t.receive_time, t);
    agent_end.Write(frame.data(), frame.size());
    Pump(100);
  }
  ASSERT_EQ(hellos.size(), 3u) << "the workstation said Hello only " << hellos.size() << " times";
  EXPECT_FALSE(client.authenticated());
  Hello hello;
  hello.name = "fake agent";
  hello.auth_required = false;
  const std::vector<uint8_t> frame =
      encoder.Encode(TimeFromNanoseconds(clock.nsecsElapsed()), hello);
  agent_end.Write(frame.data(), frame.size());
  EXPECT_TRUE(WaitFor([&] { return client.authenticated(); }, 3000));
  const size_t said = hellos.size();
  Pump(1500);
  EXPECT_EQ(hellos.size(), said) << "no more Hellos once the agent has answered";
  client.Shutdown();
}

// The emergency stop owed to the robot is paid only by the agent's ack of
// the latest stop: stop, clear, stop on a dying link, and the first stop's
// late ack must not cancel the second. The test plays the agent on a pty.
TEST(RobotLinkSerialTest, OnlyTheLatestEmergencyStopsAckPaysWhatIsOwed) {
  PtyMasterStream agent_end;
  QString error;
  ASSERT_TRUE(agent_end.Open(&error)) << error.toStdString();
  LinkDecoder decoder;
  std::vector<uint32_t> stops;  // the sequences of the client's EmergencyStop frames
  QObject::connect(&agent_end, &ByteStream::bytesReceived, [&](const QByteArray& bytes) {
    std::vector<LinkMessage> received;
    decoder.Feed(reinterpret_cast<const uint8_t*>(bytes.constData()), bytes.size(), &received);
    for (const LinkMessage& m : received) {
      if (std::holds_alternative<EmergencyStop>(m.payload)) stops.push_back(m.header.sequence);
    }
  });
  RobotConnection client(ClientOptions("serial:" + agent_end.SlavePath()));
  ASSERT_TRUE(client.Start(&error)) << error.toStdString();
  LinkEncoder encoder(LinkSender::kAgent);
  const auto say = [&](const LinkPayload& payload) {
    const std::vector<uint8_t> frame = encoder.Encode(Time(), payload);
    agent_end.Write(frame.data(), frame.size());
  };
  Hello hello;
  hello.name = "fake agent";
  say(hello);
  ASSERT_TRUE(WaitFor([&] { return client.authenticated(); }, 3000));
  client.EmergencyStop();
  client.ClearEmergencyStop();
  client.EmergencyStop();
  ASSERT_TRUE(WaitFor([&] { return stops.size() == 2; }, 3000));
  EXPECT_TRUE(client.emergency_stop_owed());
  const auto ack = [&](uint32_t sequence) {
    CommandAck a;
    a.acked_sequence = sequence;
    a.acked_type = static_cast<uint8_t>(LinkMessageType::kEmergencyStop);
    say(a);
    Pump(200);
  };
  ack(stops[0]);  // late: the first stop's
  EXPECT_TRUE(client.emergency_stop_owed()) << "an earlier stop's ack cancelled the latest";
  ack(stops[1]);
  EXPECT_FALSE(client.emergency_stop_owed());
  client.Shutdown();
}

TEST(RobotLinkTcpTest, UnauthenticatedRawClientCannotDrive) {
  // A client that skips the handshake and just sends Drive frames.
  SimRobot robot(RobotAgentConfig::LinkKind::kTcp);
  ASSERT_TRUE(robot.started);
  QTcpSocket socket;
  socket.connectToHost(QStringLiteral("127.0.0.1"), robot.agent->tcp_port());
  ASSERT_TRUE(WaitFor([&] { return socket.state() == QAbstractSocket::ConnectedState; }, 5000));
  LinkEncoder encoder(LinkSender::kClient);
  LinkDecoder decoder;
  std::vector<LinkMessage> received;
  const auto drain = [&] {
    const QByteArray bytes = socket.readAll();
    decoder.Feed(reinterpret_cast<const uint8_t*>(bytes.constData()), bytes.size(), &received);
  };
  QObject::connect(&socket, &QTcpSocket::readyRead, drain);
  drain();  // The greeting may have arrived before the connection above.
  for (int i = 0; i < 10; ++i) {
    const auto frame = encoder.EncodeDrive(Time(), 0.5, 0.5);
    socket.write(reinterpret_cast<const char*>(frame.data()), frame.size());
    Pump(50);
  }
  Pump(500);
  drain();
  // Nothing beyond the greeting: no acks, no Status, no Telemetry (issue 16:
  // acks to a keyless peer that never reads used to fill the agent's memory).
  ASSERT_EQ(received.size(), 2u);
  EXPECT_TRUE(std::holds_alternative<Hello>(received[0].payload));
  EXPECT_TRUE(std::holds_alternative<AuthChallenge>(received[1].payload));
  EXPECT_EQ(robot.Speed(), 0.0);
  // Closed at the 2 s authentication deadline, with the reason.
  ASSERT_TRUE(WaitFor([&] {
    drain();
    return received.size() >= 3u;
  }, 5000));
  ASSERT_EQ(received.size(), 3u);
  const auto* result = std::get_if<AuthResult>(&received[2].payload);
  ASSERT_NE(result, nullptr);
  EXPECT_EQ(result->reason, "authentication timeout");
}

TEST(RobotLinkTcpTest, SecondClientIsRefusedAsBusy) {
  SimRobot robot(RobotAgentConfig::LinkKind::kTcp);
  ASSERT_TRUE(robot.started);
  RobotConnection first(ClientOptions(robot.Address()));
  QString error;
  ASSERT_TRUE(first.Start(&error));
  ASSERT_TRUE(WaitFor([&] { return first.authenticated(); }, 10000));
  RobotConnection second(ClientOptions(robot.Address()));
  QString reason;
  QObject::connect(&second, &RobotConnection::authenticationFailed,
                   [&](const QString& r) { reason = r; });
  ASSERT_TRUE(second.Start(&error));
  ASSERT_TRUE(WaitFor([&] { return !reason.isEmpty(); }, 10000));
  EXPECT_EQ(reason, QStringLiteral("busy"));
  EXPECT_TRUE(first.authenticated());
  EXPECT_FALSE(second.authenticated());
}

// --- The sweepscan-sim executable ---------------------------------------

// Starts sweepscan-sim with `args`, returns the first stdout line (where to connect).
QString StartSimProcess(QProcess* process, const QStringList& args) {
  process->setProgram(QStringLiteral(SWEEPSCAN_SIM));
  process->setArguments(args);
  process->setProcessChannelMode(QProcess::SeparateChannels);
  process->start();
  if (!process->waitForStarted(10000)) return {};
  WaitFor([&] { return process->canReadLine() || process->state() != QProcess::Running; }, 20000);
  return QString::fromLocal8Bit(process->readLine()).trimmed();
}

class SimExecutableTest : public ::testing::TestWithParam<bool> {};  // true: --pty.

TEST_P(SimExecutableTest, WorkstationDrivesTheSimulatorProcess) {
  QTemporaryDir tmp;
  const QString key_file = tmp.path() + "/key";
  {
    QFile f(key_file);
    ASSERT_TRUE(f.open(QIODevice::WriteOnly));
    f.write(kKey);
    f.write("\n");  // A trailing newline is not part of the key.
  }
  const QString scenario = QStringLiteral(SWEEPSCAN_SOURCE_DIR "/resources/scenarios/lab.json");
  QProcess process;
  const bool pty = GetParam();
  const QStringList args =
      pty ? QStringList{"--scenario", scenario, "--pty"}
          : QStringList{"--scenario", scenario, "--listen", "127.0.0.1:0", "--key-file", key_file};
  const QString first_line = StartSimProcess(&process, args);
  ASSERT_FALSE(first_line.isEmpty()) << process.readAllStandardError().toStdString();
  QString address;
  if (pty) {
    ASSERT_TRUE(first_line.startsWith("/dev/")) << first_line.toStdString();
    address = "serial:" + first_line;
  } else {
    ASSERT_TRUE(first_line.startsWith("listening on ")) << first_line.toStdString();
    address = "tcp:" + first_line.mid(13);
  }
  RobotConnection client(ClientOptions(address));
  QString error;
  ASSERT_TRUE(client.Start(&error)) << error.toStdString();
  ASSERT_TRUE(WaitFor([&] { return client.authenticated(); }, 15000)) << client.health().ToString();
  client.SetLidarMotor(true);
  client.Drive(0.25, 0.0);
  ASSERT_TRUE(WaitFor(
      [&] {
        const LinkHealth h = client.health();
        return h.have_status && h.agent_status.applied_v_mps > 0.2 && client.log().scans.size() > 2;
      },
      15000))
      << client.health().ToString();
  EXPECT_TRUE(client.health().agent_status.client_authenticated);
  EXPECT_NE(client.health().agent_name.find("sweepscan-sim"), std::string::npos);
  // The wheels report the simulated motion.
  ASSERT_TRUE(WaitFor(
      [&] {
        const auto& wheels = client.log().wheels;
        return !wheels.empty() && wheels.back().left_mps > 0.2;
      },
      10000));
  client.Shutdown();
  process.terminate();  // SIGTERM: leaves through the event loop.
  EXPECT_TRUE(process.waitForFinished(10000));
  EXPECT_EQ(process.exitStatus(), QProcess::NormalExit);
  EXPECT_EQ(process.exitCode(), 0);
}

INSTANTIATE_TEST_SUITE_P(TcpAndPty, SimExecutableTest, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? "Pty" : "Tcp"; });

TEST(SimExecutableOptionsTest, RefusesBadOptionsWithAClearMessage) {
  QProcess process;
  process.start(QStringLiteral(SWEEPSCAN_SIM), {"--scenario", "/nonexistent.json", "--pty"});
  ASSERT_TRUE(process.waitForFinished(20000));
  EXPECT_EQ(process.exitCode(), 2);
  EXPECT_TRUE(process.readAllStandardError().contains("nonexistent.json"));
  process.start(
      QStringLiteral(SWEEPSCAN_SIM),
      {"--scenario", QStringLiteral(SWEEPSCAN_SOURCE_DIR "/resources/scenarios/lab.json")});
  ASSERT_TRUE(process.waitForFinished(20000));
  EXPECT_EQ(process.exitCode(), 2);
  EXPECT_TRUE(process.readAllStandardError().contains("--key-file"));
}

// --- SIGKILL of the recording process -----------------------------------

int64_t RealtimeNs() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

std::string g_self;  // This binary, re-run as the recorder.

TEST(RobotLinkTcpTest, RecorderKilledWithSigkillLeavesASessionWithEverythingOlderThanOneSecond) {
  SimRobot robot(RobotAgentConfig::LinkKind::kTcp);
  ASSERT_TRUE(robot.started);
  QTemporaryDir tmp;
  const std::string dir = (tmp.path() + "/killed.sweepscan").toStdString();
  const std::string key_file = (tmp.path() + "/key").toStdString();
  {
    QFile f(QString::fromStdString(key_file));
    ASSERT_TRUE(f.open(QIODevice::WriteOnly));
    f.write(kKey);
  }
  const std::string address = robot.Address().toStdString();
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // A fresh process image: no Qt state shared with the parent.
    execl(g_self.c_str(), g_self.c_str(), "--record-child", address.c_str(), dir.c_str(),
          key_file.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  // Let it connect, authenticate, start the lidar and record for a while.
  const bool recording = WaitFor(
      [&] {
        return robot.agent->core().client_authenticated() &&
               robot.agent->core().status(robot.agent->Now()).lidar_motor_on;
      },
      15000);
  Pump(2500);
  const int64_t killed_at_ns = RealtimeNs();
  kill(child, SIGKILL);
  int wstatus = 0;
  waitpid(child, &wstatus, 0);
  ASSERT_TRUE(recording);
  ASSERT_TRUE(WIFSIGNALED(wstatus));

  Session session;
  const Status loaded = LoadSession(dir, FramesLoadOptions(), &session);
  ASSERT_TRUE(loaded.ok()) << loaded.message();
  ASSERT_GT(session.records.size(), 100u);
  const int64_t newest_ns = session.records.back().receive_time_ns;
  // The agent streamed continuously (IMU at hundreds of Hz): the newest
  // record on disk is less than a second older than the kill.
  EXPECT_GE(newest_ns, killed_at_ns - 1000000000LL)
      << "newest record " << (killed_at_ns - newest_ns) * 1e-9 << " s before the kill";
  // And nothing before it is missing: agent sequence numbers are contiguous.
  SensorLog log;
  SessionDecodeInfo info;
  const Status decoded = DecodeSession(dir, &log, &info);
  ASSERT_TRUE(decoded.ok()) << decoded.message();
  EXPECT_EQ(info.link.sequence[0].frames_missing, 0u);
  EXPECT_EQ(info.frames_refused, 0u);
  EXPECT_GT(log.imu.size(), 100u);
  EXPECT_GT(log.scans.size(), 3u);
}

// The child side: record until killed.
int RunRecorderChild(int argc, char** argv) {
  if (argc != 5) return 2;
  QCoreApplication app(argc, argv);
  RobotConnectionOptions options;
  options.address = QString::fromLocal8Bit(argv[2]);
  options.session_dir = QString::fromLocal8Bit(argv[3]);
  QFile key(QString::fromLocal8Bit(argv[4]));
  if (!key.open(QIODevice::ReadOnly)) return 3;
  const QByteArray bytes = key.readAll();
  options.key.assign(bytes.begin(), bytes.end());
  RobotConnection client(options);
  QString error;
  if (!client.Start(&error)) {
    std::fprintf(stderr, "recorder: %s\n", qPrintable(error));
    return 4;
  }
  QObject::connect(&client, &RobotConnection::authenticatedChanged, [&](bool ok) {
    if (ok) client.SetLidarMotor(true);
  });
  return app.exec();
}

}  // namespace
}  // namespace hardware
}  // namespace sweepscan

int main(int argc, char** argv) {
  if (argc >= 2 && std::strcmp(argv[1], "--record-child") == 0) {
    return sweepscan::hardware::RunRecorderChild(argc, argv);
  }
  QCoreApplication app(argc, argv);
  sweepscan::hardware::g_self = QCoreApplication::applicationFilePath().toStdString();
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
