// The robot agent (RobotAgent, the code of sweepscan-robotd) against
// squatting, exhaustion and floods over real loopback TCP (issue 16):
//  - keyless connections that connect and wait never hold the client slot;
//  - a keyless peer that sends Heartbeats and never reads gets nothing back
//    and cannot grow the agent's memory;
//  - a keyed peer that drives and stops reading is dropped (bounded send
//    queue) and the robot stops;
//  - a flood of frame candidates with good header CRCs and bad frame CRCs
//    does not delay the watchdog;
//  - the drives a stalled link held past a watchdog trip, delivered at
//    once, do not start the robot again (a motor board on a pty).
// The agent runs on the test's main thread (its event loop pumped by
// WaitFor); attackers are plain blocking POSIX sockets on their own threads.
// Figures are printed (docs/robot-agent.md, "Measured").
#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <linux/audit.h>
#include <linux/filter.h>
#include <linux/seccomp.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <pty.h>
#include <sys/ioctl.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <QCoreApplication>
#include <QElapsedTimer>
#include <QFile>
#include <QProcess>
#include <QProcessEnvironment>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "hardware/agent/robot_agent.h"
#include "hardware/codecs/motor_board_codec.h"
#include "hardware/link/hmac_sha256.h"
#include "hardware/link/qt_transport.h"
#include "hardware/station/robot_connection.h"
#include "tests/testing/forged_link_frames.h"
#include "tests/testing/qt_wait.h"
#include "tests/testing/read_available.h"

namespace sweepscan {
namespace hardware {
namespace {

const char kKey[] = "hardening test key";
std::vector<uint8_t> KeyBytes() { return std::vector<uint8_t>(kKey, kKey + sizeof(kKey) - 1); }

using testing::Pump;
using testing::ReadAvailable;
using testing::WaitFor;

// Resident memory of this process (agent and test), MiB.
double RssMiB() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  }
  return 0.0;
}

// An agent with no devices fitted (the link is what is under test).
struct Agent {
  Agent() {
    RobotAgentConfig config;
    config.listen_port = 0;
    config.agent.key = KeyBytes();
    config.agent.name = "hardening test agent";
    agent = std::make_unique<RobotAgent>(config);
    QString error;
    started = agent->Start(&error);
    EXPECT_TRUE(started) << error.toStdString();
  }
  std::unique_ptr<RobotAgent> agent;
  bool started = false;
};

// A blocking POSIX client, usable from any thread.
class RawClient {
 public:
  explicit RawClient(uint16_t port, int receive_buffer = 0) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    if (receive_buffer > 0) {
      ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &receive_buffer, sizeof(receive_buffer));
    }
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(port);
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0;
  }
  ~RawClient() { ::close(fd_); }
  bool connected() const { return connected_; }
  // False once the agent closed the connection.
  bool Send(const std::vector<uint8_t>& bytes) {
    size_t done = 0;
    while (done < bytes.size()) {
      const ssize_t k = ::send(fd_, bytes.data() + done, bytes.size() - done, MSG_NOSIGNAL);
      if (k <= 0) return false;
      done += static_cast<size_t>(k);
    }
    return true;
  }
  // Reads until a message satisfies `pred` (or the connection ends).
  bool ReadUntil(const std::function<bool(const LinkMessage&)>& pred, LinkMessage* found) {
    uint8_t buf[4096];
    for (;;) {
      for (LinkMessage& m : pending_) {
        if (pred(m)) {
          *found = m;
          pending_.clear();
          return true;
        }
      }
      pending_.clear();
      const ssize_t k = ::recv(fd_, buf, sizeof(buf), 0);
      if (k <= 0) return false;
      decoder_.Feed(buf, static_cast<size_t>(k), &pending_);
    }
  }
  // The version-2 handshake with the key; after it, encoder() signs.
  bool Authenticate() {
    LinkMessage m;
    if (!ReadUntil([](const LinkMessage& x) { return std::holds_alternative<AuthChallenge>(x.payload); },
                   &m)) {
      return false;
    }
    AuthResponse response;
    LinkSessionKey session;
    if (!MakeLinkAuthResponse(KeyBytes(), std::get<AuthChallenge>(m.payload), &response, &session)) {
      return false;
    }
    Send(encoder_.Encode(Now(), Hello{}));
    Send(encoder_.Encode(Now(), response));
    encoder_.SetSigner(MakeLinkFrameSigner(session));
    if (!ReadUntil([](const LinkMessage& x) { return std::holds_alternative<AuthResult>(x.payload); },
                   &m)) {
      return false;
    }
    return std::get<AuthResult>(m.payload).outcome == AuthOutcome::kOk;
  }
  LinkEncoder& encoder() { return encoder_; }
  static Time Now() {
    return Time(std::chrono::duration_cast<Duration>(
        std::chrono::steady_clock::now().time_since_epoch()));
  }

 private:
  int fd_ = -1;
  bool connected_ = false;
  LinkEncoder encoder_{LinkSender::kClient};
  LinkDecoder decoder_;
  std::vector<LinkMessage> pending_;
};

TEST(RobotAgentHardeningTest, KeylessConnectionsNeverHoldTheClientSlot) {
  // Before: two keyless clients that connected and waited kept the keyed
  // workstation out ("busy") for as long as they liked.
  Agent a;
  ASSERT_TRUE(a.started);
  std::vector<std::unique_ptr<RawClient>> squatters;
  for (int i = 0; i < 20; ++i) {
    squatters.push_back(std::make_unique<RawClient>(a.agent->tcp_port()));
    ASSERT_TRUE(squatters.back()->connected());
  }
  Pump(200);
  EXPECT_LE(a.agent->pending_connections(), 16);
  EXPECT_FALSE(a.agent->has_client());
  RobotConnectionOptions options;
  options.address = QStringLiteral("tcp:127.0.0.1:%1").arg(a.agent->tcp_port());
  options.key = KeyBytes();
  RobotConnection client(options);
  QString error;
  ASSERT_TRUE(client.Start(&error)) << error.toStdString();
  QElapsedTimer timer;
  timer.start();
  ASSERT_TRUE(WaitFor([&] { return client.authenticated(); }, 5000)) << client.health().ToString();
  std::printf("[measured] keyed client authenticated in %lld ms beside 20 keyless connections\n",
              static_cast<long long>(timer.elapsed()));
  EXPECT_TRUE(client.Drive(0.1, 0.0));
  // The squatters are closed at their 2 s deadline.
  ASSERT_TRUE(WaitFor([&] { return a.agent->pending_connections() == 0; }, 4000));
  EXPECT_TRUE(client.authenticated());
}

TEST(RobotAgentHardeningTest, KeylessHeartbeatFloodGetsNoRepliesAndMemoryStaysFlat) {
  // Before: every Heartbeat was acked into an unbounded send buffer: 15 ->
  // 143-533 MiB.
  Agent a;
  ASSERT_TRUE(a.started);
  Pump(100);
  const double before = RssMiB();
  std::atomic<bool> done{false};
  std::atomic<long> sent{0};
  std::thread attacker([&] {
    RawClient c(a.agent->tcp_port(), 4096);
    LinkEncoder encoder(LinkSender::kClient);
    std::vector<uint8_t> burst;
    for (int i = 0; i < 1000; ++i) {
      const auto f = encoder.EncodeHeartbeat(Time());
      burst.insert(burst.end(), f.begin(), f.end());
    }
    while (c.Send(burst)) sent += 1000;  // Never reads; ends when the agent closes.
    done = true;
  });
  double peak = before;
  ASSERT_TRUE(WaitFor([&] {
    peak = std::max(peak, RssMiB());
    return done.load();
  }, 10000));
  attacker.join();
  std::printf("[measured] keyless heartbeat flood: %ld frames sent, RSS %.1f -> peak %.1f MiB\n",
              sent.load(), before, peak);
  EXPECT_GT(sent.load(), 1000);
  EXPECT_LT(peak - before, 64.0);
  EXPECT_EQ(a.agent->pending_connections(), 0);
}

TEST(RobotAgentHardeningTest, KeyedClientThatStopsReadingIsDroppedAndTheRobotStops) {
  // Before: a keyed client sending Drive commands while reading slowly drove
  // the agent to 370-391 MiB.
  Agent a;
  ASSERT_TRUE(a.started);
  Pump(100);
  const double before = RssMiB();
  std::atomic<bool> authenticated{false}, done{false};
  std::atomic<long> sent{0};
  std::thread attacker([&] {
    RawClient c(a.agent->tcp_port(), 4096);
    if (!c.Authenticate()) {
      done = true;
      return;
    }
    authenticated = true;
    for (;;) {  // Drive, never read.
      std::vector<uint8_t> burst;
      for (int i = 0; i < 200; ++i) {
        const auto f = c.encoder().EncodeDrive(RawClient::Now(), 0.2, 0.0);
        burst.insert(burst.end(), f.begin(), f.end());
      }
      if (!c.Send(burst)) break;
      sent += 200;
    }
    done = true;
  });
  double peak = before;
  bool was_driving = false;
  const bool finished = WaitFor([&] {
    peak = std::max(peak, RssMiB());
    was_driving = was_driving || a.agent->core().watchdog_state() == WatchdogState::kArmed;
    return done.load();
  }, 15000);
  attacker.join();
  ASSERT_TRUE(finished);
  ASSERT_TRUE(authenticated.load());
  std::printf("[measured] keyed drive flood, never reading: %ld frames sent, RSS %.1f -> peak %.1f MiB\n",
              sent.load(), before, peak);
  EXPECT_TRUE(was_driving);
  EXPECT_FALSE(a.agent->has_client());
  EXPECT_EQ(a.agent->core().watchdog_state(), WatchdogState::kTripped);  // Stopped at once.
  EXPECT_EQ(a.agent->core().applied_v_mps(), 0.0);
  EXPECT_LT(peak - before, 64.0);
}

// Floods an authenticated link (after one Drive) with forged candidates at
// `bytes_per_s` (0: as fast as the socket takes them); returns the time from
// the last valid frame to the watchdog trip, in ms.
double WatchdogLatencyUnderFlood(double bytes_per_s, bool* dropped, double* megabytes) {
  Agent a;
  EXPECT_TRUE(a.started);
  std::atomic<bool> authenticated{false}, stop{false}, done{false};
  std::atomic<long> flood_bytes{0};
  const std::vector<uint8_t> flood =
      sweepscan::testing::ForgedLinkCandidates(LinkSender::kClient, 1024, 256);  // 28 kB.
  std::thread attacker([&] {
    RawClient c(a.agent->tcp_port());
    if (!c.Authenticate()) {
      done = true;
      return;
    }
    c.Send(c.encoder().EncodeDrive(RawClient::Now(), 0.2, 0.0));
    authenticated = true;
    const auto start = std::chrono::steady_clock::now();
    while (!stop && c.Send(flood)) {
      flood_bytes += static_cast<long>(flood.size());
      if (bytes_per_s > 0) {
        std::this_thread::sleep_until(
            start + std::chrono::duration<double>(static_cast<double>(flood_bytes) / bytes_per_s));
      }
    }
    done = true;
  });
  const bool tripped = WaitFor(
      [&] { return a.agent->core().watchdog_state() == WatchdogState::kTripped; }, 5000);
  *dropped = !a.agent->has_client();
  Pump(200);  // Keep flooding a little after the trip.
  stop = true;
  WaitFor([&] { return done.load(); }, 5000);
  attacker.join();
  EXPECT_TRUE(authenticated.load());
  EXPECT_TRUE(tripped);
  *megabytes = static_cast<double>(flood_bytes.load()) / 1e6;
  return ToSeconds(a.agent->core().last_watchdog_trip_time() -
                   a.agent->core().last_client_frame_time()) *
         1e3;
}

TEST(RobotAgentHardeningTest, WatchdogFiresOnTimeUnderAForgedCandidateFlood) {
  // Before: such a flood (about 37 times the CRC work per byte received)
  // delayed the watchdog to 530-1102 ms. A paced flood the agent keeps up
  // with: the link stays, the watchdog trips on time.
  bool dropped = false;
  double mb = 0.0;
  const double latency_ms = WatchdogLatencyUnderFlood(20e6, &dropped, &mb);
  std::printf("[measured] watchdog under a paced forged-candidate flood (20 MB/s, %.0f MB): %.1f ms%s\n",
              mb, latency_ms, dropped ? " (link dropped)" : "");
  EXPECT_FALSE(dropped);
  EXPECT_GE(latency_ms, 500.0);
  EXPECT_LE(latency_ms, 600.0);  // Aim 550 ms; slack for a loaded 2-core machine.
  EXPECT_GT(mb, 5.0);
}

TEST(RobotAgentHardeningTest, AnOverwhelmingFloodStopsTheRobotNoLaterThanTheWatchdog) {
  // As fast as loopback takes it: the agent either keeps up (watchdog on
  // time) or drops the link when its decode backlog passes 1 MiB, which
  // stops the robot at once. Either way no later than the watchdog period.
  bool dropped = false;
  double mb = 0.0;
  const double latency_ms = WatchdogLatencyUnderFlood(0, &dropped, &mb);
  std::printf("[measured] robot stopped %.1f ms after the last valid frame under a full-speed flood "
              "(%.0f MB)%s\n", latency_ms, mb, dropped ? ", link dropped (decode backlog)" : "");
  EXPECT_LE(latency_ms, 600.0);
}

// A link that stalls past the watchdog (Wi-Fi behind a wall) holds every
// frame, then delivers them at once. Here the client drives, then for 1 s
// makes its frames as it goes on driving (a drive and a heartbeat each
// 100 ms) but holds them, then writes them in one go, then sends only
// heartbeats: the motor board (a pseudo-terminal) hears the watchdog's zero
// during the stall and then only zeros; a drive on time moves it again.
// The held drives used to start it again, at the set-point of before the
// stall, until the client learned of the trip from the Status held with
// them and stopped it.
TEST(RobotAgentStallTest, DrivesAStalledLinkHeldPastTheWatchdogDoNotRestartTheRobot) {
  int master = -1, slave = -1;
  char board[128];
  termios raw{};
  ::cfmakeraw(&raw);
  ASSERT_EQ(::openpty(&master, &slave, board, &raw, nullptr), 0);
  ::fcntl(master, F_SETFL, O_NONBLOCK);
  ::close(slave);
  RobotAgentConfig config;
  config.listen_port = 0;
  config.agent.key = KeyBytes();
  config.motor_port = QString::fromLatin1(board);
  QStringList log;  // Before the agent: its shutdown logs too.
  RobotAgent agent(config);
  QObject::connect(&agent, &RobotAgent::logMessage, [&](const QString& m) { log << m; });
  QString error;
  ASSERT_TRUE(agent.Start(&error)) << error.toStdString();
  const uint16_t port = agent.tcp_port();
  // 1 driving, 2 stalled, 3 the stall's frames written, heartbeats; 4 drives on time.
  std::atomic<int> phase{0};
  std::atomic<bool> moving_again{false}, done{false}, authenticated{false};
  std::thread client([&] {
    RawClient c(port);
    authenticated = c.Authenticate();
    auto& link = c.encoder();
    const auto sleep_ms = [](int ms) {
      std::this_thread::sleep_for(std::chrono::milliseconds(ms));
    };
    phase = 1;
    for (int i = 0; authenticated && i < 6; ++i, sleep_ms(50)) {
      c.Send(link.EncodeDrive(RawClient::Now(), 0.3, 0.0));
    }
    phase = 2;
    std::vector<uint8_t> held;
    for (int i = 0; authenticated && i < 10; ++i) {
      sleep_ms(100);
      for (const auto& frame : {link.EncodeDrive(RawClient::Now(), 0.3, 0.0),
                                link.Encode(RawClient::Now(), LinkPayload{Heartbeat{}})}) {
        held.insert(held.end(), frame.begin(), frame.end());
      }
    }
    c.Send(held);
    phase = 3;
    for (int i = 0; authenticated && i < 5; ++i) {
      sleep_ms(100);
      c.Send(link.Encode(RawClient::Now(), LinkPayload{Heartbeat{}}));
    }
    phase = 4;
    for (int i = 0; authenticated && i < 40 && !moving_again; ++i, sleep_ms(50)) {
      c.Send(link.EncodeDrive(RawClient::Now(), 0.3, 0.0));
    }
    c.Send(link.Encode(RawClient::Now(), LinkPayload{Stop{}}));
    done = true;
  });
  MotorCommandDecoder decoder;
  bool drove = false, stopped_in_stall = false;
  int restarts = 0;  // Non-zero commands after the stall's zero, before phase 4.
  std::string heard;
  const bool finished = WaitFor(
      [&] {
        // The phase first: what is read below was written before it changed.
        const int now_phase = phase;
        std::string bytes;
        ReadAvailable(master, &bytes);
        decoder.Feed(std::vector<uint8_t>(bytes.begin(), bytes.end()), Time());
        for (const MotorCommand& m : decoder.TakeRecords()) {
          const bool zero = m.vx_mps == 0.0 && m.wz_radps == 0.0;
          if (now_phase == 1 && !zero) drove = true;
          if (now_phase == 2 && zero && drove) stopped_in_stall = true;
          if ((now_phase == 2 || now_phase == 3) && !zero && stopped_in_stall) ++restarts;
          if (now_phase == 4 && !zero) moving_again = true;
        }
        return done.load();
      },
      20000);
  client.join();
  ::close(master);
  ASSERT_TRUE(finished);
  ASSERT_TRUE(authenticated.load());
  EXPECT_TRUE(drove);
  EXPECT_TRUE(stopped_in_stall) << "no watchdog zero during the stall";
  EXPECT_EQ(restarts, 0) << "the stall's drives drove the board again";
  EXPECT_TRUE(moving_again.load()) << "a drive on time did not move the robot";
  EXPECT_GE(agent.core().counters().stale_drives, 10u);
  const QStringList refused = log.filter(QStringLiteral("late after the watchdog trip"));
  ASSERT_EQ(refused.size(), 1) << log.join('\n').toStdString();
  std::printf("[measured] %s\n", qPrintable(refused.first()));
}

}  // namespace
}  // namespace hardware
}  // namespace sweepscan

int main(int argc, char** argv) {
  QCoreApplication app(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
