// The robot agent's serial link (a radio modem on USB) and its lidar port
// over pseudo-terminals: a lost link is opened again when its port returns,
// a line too slow for the telemetry keeps its queue bounded and marks what
// it drops, and LidarMotor switches the X4 adapter's DTR line before the
// scan command. Split from robot_agent_hardening_test.cc (TCP floods and
// robotd's options and config file).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <QCoreApplication>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "hardware/agent/robot_agent.h"
#include "hardware/link/qt_transport.h"
#include "hardware/station/robot_connection.h"
#include "tests/testing/qt_wait.h"
#include "tests/testing/read_available.h"

namespace sweepscan {
namespace hardware {
namespace {

using testing::Pump;
using testing::ReadAvailable;
using testing::WaitFor;

// A serial link (a radio modem on USB) that is lost is opened again when its
// port comes back, as the device ports are: the agent does not sit alive
// with no link, where systemd would never restart it. The port is a name
// (as udev gives one) that points at a pseudo-terminal, then at a new one.
TEST(RobotAgentSerialLinkTest, ALostSerialLinkIsOpenedAgainWhenItsPortReturns) {
  char dir_template[] = "/tmp/sweepscan-link-XXXXXX";
  ASSERT_NE(::mkdtemp(dir_template), nullptr);
  const std::string link = std::string(dir_template) + "/modem";
  int master = -1, slave = -1;
  char name[128];
  ASSERT_EQ(::openpty(&master, &slave, name, nullptr, nullptr), 0);
  ::fcntl(master, F_SETFL, O_NONBLOCK);
  ASSERT_EQ(::symlink(name, link.c_str()), 0);

  RobotAgentConfig config;
  config.link = RobotAgentConfig::LinkKind::kSerial;
  config.link_serial_port = QString::fromStdString(link);
  config.link_baud = 115200;
  config.device_reopen_ms = 100;
  config.agent.require_auth = false;
  config.agent.name = "serial link test agent";
  RobotAgent agent(config);
  QString error;
  ASSERT_TRUE(agent.Start(&error)) << error.toStdString();
  std::string first;
  ASSERT_TRUE(WaitFor([&] { return ReadAvailable(master, &first) > 0; }, 3000))
      << "no Hello on the link";

  ::close(slave);
  ::close(master);  // The modem is gone: the agent's port reads EIO.
  // Its name goes with it, as udev's does: left pointing at the freed
  // /dev/pts/N, the retries would open the next pty of that number, another
  // test's under ctest -j (which made this test fail in CI once).
  ASSERT_EQ(::unlink(link.c_str()), 0);
  ASSERT_TRUE(WaitFor([&] { return !agent.has_client(); }, 3000))
      << "the lost link was not noticed";
  Pump(300);  // A few retries against a port that is not there.
  EXPECT_FALSE(agent.has_client());

  ASSERT_EQ(::openpty(&master, &slave, name, nullptr, nullptr), 0);
  ::fcntl(master, F_SETFL, O_NONBLOCK);
  ASSERT_EQ(::symlink(name, link.c_str()), 0);
  ASSERT_TRUE(WaitFor([&] { return agent.has_client(); }, 3000))
      << "the link's port was not opened again";
  std::string second;
  EXPECT_TRUE(WaitFor([&] { return ReadAvailable(master, &second) > 0; }, 3000))
      << "no Hello on the port that came back";
  // The same greeting as at the start (a new connection's first frame).
  EXPECT_EQ(second.substr(0, 4), first.substr(0, 4));
  agent.Shutdown();
  ::close(slave);
  ::close(master);
  ::unlink(link.c_str());
  ::rmdir(dir_template);
}

// Device bytes at a steady 40 kB/s of lidar bytes (200 every 5 ms): about
// 49 kB/s on the link with the frames' overhead, more than a 115200-baud
// line (11.5 kB/s) carries.
class SteadyDevices : public VirtualDevices {
 public:
  void WriteToDevice(LinkDevice, const uint8_t*, size_t, Time) override {}
  void AdvanceTo(Time now, std::vector<DeviceChunk>* out) override {
    if (!started_) {
      last_ = now;
      started_ = true;
    }
    while (now - last_ >= std::chrono::milliseconds(5)) {
      last_ += std::chrono::milliseconds(5);
      out->push_back({LinkDevice::kLidar, last_, std::vector<uint8_t>(200, 0xA5)});
    }
  }

 private:
  bool started_ = false;
  Time last_;
};

// A serial link (a radio modem) slower than the telemetry, or a reader that
// stalls: the agent's queue for it stays within its bound (one second at the
// line rate) while live telemetry is dropped; Status still goes out, and
// what it alone adds is thrown away at twice the bound. When the reader
// catches up the telemetry resumes with the break flag, so its decoder
// restarts and the hole is reported. QSerialPort's write buffer used to
// grow without bound (17-20 kB/s in the review), Status and acks queued
// behind it.
TEST(RobotAgentSerialLinkTest, ASlowSerialLinkKeepsItsQueueBoundedAndMarksTheDroppedTelemetry) {
  int master = -1, slave = -1;
  char name[128];
  termios raw{};
  ::cfmakeraw(&raw);
  ASSERT_EQ(::openpty(&master, &slave, name, &raw, nullptr), 0);
  ::fcntl(master, F_SETFL, O_NONBLOCK);
  RobotAgentConfig config;
  config.link = RobotAgentConfig::LinkKind::kSerial;
  config.link_serial_port = QString::fromLocal8Bit(name);
  config.link_baud = 9600;  // 960 B/s: the bound's floor, 4 KiB, which Status fills in 4 s.
  config.agent.require_auth = false;
  config.agent.telemetry_buffer = Duration::zero();  // Live from the start: no resume to wait for.
  config.agent.name = "slow serial link test agent";
  RobotAgent agent(config, std::make_unique<SteadyDevices>());
  QString error;
  ASSERT_TRUE(agent.Start(&error)) << error.toStdString();
  const qint64 limit = agent.send_queue_limit();
  EXPECT_EQ(limit, 4096);

  // Nobody reads for 8 s: ~400 kB of telemetry against the pty's buffer
  // (tens of kB, full within 2 s) and the bound.
  qint64 most_queued = 0;
  QElapsedTimer clock;
  clock.start();
  WaitFor(
      [&] {
        most_queued = std::max(most_queued, agent.client_bytes_queued());
        return clock.elapsed() > 8000;
      },
      9000);
  const AgentCounters& counters = agent.core().counters();
  std::printf(
      "figure: serial link not read for 8 s: at most %lld bytes queued (bound %lld), "
      "%llu telemetry chunks dropped, %llu stale bytes thrown away\n",
      static_cast<long long>(most_queued), static_cast<long long>(limit),
      static_cast<unsigned long long>(counters.telemetry_chunks_dropped),
      static_cast<unsigned long long>(agent.link_bytes_discarded()));
  EXPECT_GT(most_queued, limit) << "the link was never congested: the test tests nothing";
  // Twice the bound, plus what one write may add past it before the next check.
  EXPECT_LE(most_queued, 2 * limit + 1024);
  EXPECT_GT(counters.telemetry_chunks_dropped, 0u);
  EXPECT_GE(agent.telemetry_pauses(), 1u);
  EXPECT_GT(agent.link_bytes_discarded(), 0u) << "Status alone reached twice the bound";

  // The reader catches up: Status frames, then telemetry marked as a break.
  std::string bytes;
  LinkDecoder decoder;
  std::vector<LinkMessage> messages;
  size_t status_frames = 0, breaks = 0, telemetry_after_break = 0;
  clock.restart();
  WaitFor(
      [&] {
        bytes.clear();
        ReadAvailable(master, &bytes);
        decoder.Feed(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), &messages);
        for (const LinkMessage& m : messages) {
          if (std::holds_alternative<LinkStatus>(m.payload)) ++status_frames;
          if (const auto* t = std::get_if<Telemetry>(&m.payload)) {
            if (breaks > 0) ++telemetry_after_break;
            if ((t->flags & kTelemetryBreak) != 0) ++breaks;
          }
        }
        messages.clear();
        return clock.elapsed() > 2000 && breaks >= 2 && telemetry_after_break > 20;
      },
      6000);
  EXPECT_GE(status_frames, 10u) << "Status at 10 Hz";
  EXPECT_GE(breaks, 2u)
      << "the telemetry after the first pause (the connection's first chunk is one too)";
  EXPECT_GT(telemetry_after_break, 20u) << "live telemetry resumed";
  agent.Shutdown();
  ::close(slave);
  ::close(master);
}

// Records what the agent does to the lidar: its DTR line and its bytes.
class LidarRecorder : public VirtualDevices {
 public:
  explicit LidarRecorder(std::vector<std::string>* events) : events_(events) {}
  void WriteToDevice(LinkDevice device, const uint8_t* data, size_t n, Time) override {
    if (device != LinkDevice::kLidar) return;
    for (size_t i = 0; i + 1 < n; i += 2) {
      char command[8];
      std::snprintf(command, sizeof(command), "%02X %02X", data[i], data[i + 1]);
      events_->push_back(command);
    }
  }
  void SetLidarDtr(bool on, Time) override { events_->push_back(on ? "DTR on" : "DTR off"); }
  void AdvanceTo(Time, std::vector<DeviceChunk>*) override {}

 private:
  std::vector<std::string>* events_;
};

// The workstation's LidarMotor reaches the X4's motor (its adapter's DTR
// line, as DirectDevice and the vendor's SDK switch it) and not only its
// scan (A5 60 / A5 65): the agent never drove DTR, so the motor spun
// whenever robotd held the port. Through RobotAgent's dispatch (the device
// side recorded; a pty has no DTR to check: TIOCMBIS fails with ENOTTY).
TEST(RobotAgentLidarMotorTest, LidarMotorSwitchesDtrBeforeTheScanCommand) {
  std::vector<std::string> events;
  RobotAgentConfig config;
  config.link = RobotAgentConfig::LinkKind::kPty;
  config.agent.require_auth = false;
  config.agent.name = "lidar motor test agent";
  RobotAgent agent(config, std::make_unique<LidarRecorder>(&events));
  QString error;
  ASSERT_TRUE(agent.Start(&error)) << error.toStdString();
  ASSERT_GE(events.size(), 2u);
  EXPECT_EQ(events[0], "DTR off") << "the motor off at start";
  EXPECT_EQ(events[1], "A5 65");
  RobotConnectionOptions options;
  options.address = "serial:" + agent.pty_path();
  RobotConnection client(options);
  ASSERT_TRUE(client.Start(&error)) << error.toStdString();
  ASSERT_TRUE(WaitFor([&] { return client.authenticated(); }, 5000));
  Pump(300);  // The start-up requests (A5 90, A5 92, 100 ms apart) are out.
  events.clear();
  client.SetLidarMotor(true);
  ASSERT_TRUE(WaitFor([&] { return events.size() >= 2; }, 3000));
  EXPECT_EQ(events, (std::vector<std::string>{"DTR on", "A5 60"}));
  events.clear();
  client.SetLidarMotor(false);
  ASSERT_TRUE(WaitFor([&] { return events.size() >= 2; }, 3000));
  EXPECT_EQ(events, (std::vector<std::string>{"DTR off", "A5 65"}));
  client.Shutdown();
  agent.Shutdown();
}

// An X4 plugged in after the agent started (or plugged in again) got no
// start-up sequence: it was sent once, timed from the agent's start, to a
// port that was not open. The lidar is a name (as udev gives one) that
// appears 0.5 s after the start, pointing at a pseudo-terminal; what the
// agent writes to it is read at the other end.
TEST(RobotAgentLidarMotorTest, ALidarPluggedInAfterTheStartGetsTheStartUpSequence) {
  char dir_template[] = "/tmp/sweepscan-lidar-XXXXXX";
  ASSERT_NE(::mkdtemp(dir_template), nullptr);
  const std::string link = std::string(dir_template) + "/lidar";
  RobotAgentConfig config;
  config.link = RobotAgentConfig::LinkKind::kPty;
  config.agent.require_auth = false;
  config.agent.name = "late lidar test agent";
  config.lidar_port = QString::fromStdString(link);
  config.device_reopen_ms = 100;
  RobotAgent agent(config);
  QString error;
  ASSERT_TRUE(agent.Start(&error)) << error.toStdString();
  Pump(500);  // The start's requests have gone to no port.
  int master = -1, slave = -1;
  char name[128];
  termios raw{};
  ::cfmakeraw(&raw);
  ASSERT_EQ(::openpty(&master, &slave, name, &raw, nullptr), 0);
  ::fcntl(master, F_SETFL, O_NONBLOCK);
  ASSERT_EQ(::symlink(name, link.c_str()), 0);
  std::string bytes;
  WaitFor([&] {
    ReadAvailable(master, &bytes);
    return bytes.size() >= 6;
  }, 3000);
  EXPECT_EQ(bytes, std::string("\xA5\x65\xA5\x90\xA5\x92", 6))
      << "stop, device info, health; got " << bytes.size() << " bytes";
  agent.Shutdown();
  ::close(slave);
  ::close(master);
  ::unlink(link.c_str());
  ::rmdir(dir_template);
}

}  // namespace
}  // namespace hardware
}  // namespace sweepscan

int main(int argc, char** argv) {
  QCoreApplication app(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
