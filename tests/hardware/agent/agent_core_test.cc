// AgentCore, driven by explicit times: authentication, refusal of
// unauthenticated commands, limits and ramps, e-stop latch, watchdog,
// telemetry wrapping, Status cadence, lidar commands. The buffering across
// outages: telemetry_buffer_test.cc.
#include "hardware/agent/agent_core.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "hardware/codecs/motor_board_codec.h"
#include "hardware/codecs/x4_codec.h"
#include "hardware/link/hmac_sha256.h"
#include "tests/hardware/agent/agent_harness.h"
#include "tests/testing/forged_link_frames.h"

namespace sweepscan {
namespace hardware {
namespace {

using std::chrono::milliseconds;
using agent_testing::AgentHarness;
using agent_testing::Key;
using agent_testing::Ms;
using agent_testing::TestOptions;

TEST(AgentOptionsTest, Validation) {
  std::string error;
  EXPECT_TRUE(TestOptions().IsValid(&error)) << error;
  AgentOptions no_key = TestOptions();
  no_key.key.clear();
  EXPECT_FALSE(no_key.IsValid(&error));
  no_key.require_auth = false;
  EXPECT_TRUE(no_key.IsValid(&error)) << error;
  AgentOptions bad = TestOptions();
  bad.v_max_mps = -1;
  EXPECT_FALSE(bad.IsValid(&error));
  bad = TestOptions();
  bad.watchdog = Duration::zero();
  EXPECT_FALSE(bad.IsValid(&error));
  bad = TestOptions();
  bad.accel_max_mps2 = std::nan("");
  EXPECT_FALSE(bad.IsValid(&error));
  bad = TestOptions();
  bad.motor_period = milliseconds(600);
  EXPECT_FALSE(bad.IsValid(&error));
}

TEST(AgentCoreTest, GreetsWithHelloAndAFreshChallengePerConnection) {
  AgentHarness h(TestOptions());
  h.Start(Ms(0));
  h.Connect(Ms(10));
  ASSERT_GE(h.received.size(), 2u);
  const auto* hello = std::get_if<Hello>(&h.received[0].payload);
  ASSERT_NE(hello, nullptr);
  EXPECT_TRUE(hello->auth_required);
  EXPECT_EQ(hello->devices.size(), 3u);
  EXPECT_EQ(h.received[0].header.sequence, 0u);
  const AuthChallenge first = *h.LastChallenge();
  h.agent.OnClientDisconnected(Ms(20), &h.out);
  h.Collect();
  h.Connect(Ms(30));
  const AuthChallenge second = *h.LastChallenge();
  EXPECT_NE(first.nonce, second.nonce);
  // No telemetry or status before authentication.
  const uint8_t bytes[] = {1, 2, 3};
  h.agent.OnDeviceBytes(LinkDevice::kImu, bytes, 3, Ms(40), &h.out);
  h.Tick(Ms(200));
  EXPECT_TRUE(h.All<Telemetry>().empty());
  EXPECT_TRUE(h.All<LinkStatus>().empty());
}

TEST(AgentCoreTest, RightKeyAuthenticatesAndDrives) {
  const AgentOptions options = TestOptions();
  AgentHarness h(options);
  h.Start(Ms(0));
  h.Connect(Ms(0));
  h.Authenticate(Ms(5), options.key);
  const auto results = h.All<AuthResult>();
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].outcome, AuthOutcome::kOk);
  EXPECT_FALSE(h.closed);
  EXPECT_TRUE(h.agent.client_authenticated());
  h.Send(Ms(10), DriveCommand{0.2, 0.0});
  const auto acks = h.All<CommandAck>();
  ASSERT_EQ(acks.size(), 1u);
  EXPECT_EQ(acks[0].result, AckResult::kAccepted);
  EXPECT_EQ(acks[0].acked_type, static_cast<uint8_t>(LinkMessageType::kDriveCommand));
  EXPECT_EQ(acks[0].echo_time, Ms(10));
  h.TickRange(Ms(10), Ms(400));
  EXPECT_TRUE(h.AnyNonZeroMotorCommand());
  EXPECT_NEAR(h.agent.applied_v_mps(), 0.2, 1e-12);
  EXPECT_EQ(h.agent.watchdog_state(), WatchdogState::kArmed);
}

TEST(AgentCoreTest, WrongKeyIsDeniedClosedAndNeverMoves) {
  AgentHarness h(TestOptions());
  h.Start(Ms(0));
  h.Connect(Ms(0));
  // Commands before authentication: no effect and no answer.
  h.Send(Ms(1), DriveCommand{0.3, 0.5});
  h.Send(Ms(2), LidarMotor{true});
  h.Send(Ms(3), Heartbeat{});
  EXPECT_TRUE(h.All<CommandAck>().empty());
  EXPECT_TRUE(h.lidar_bytes.size() <= 2u);  // Only the start-up stop (A5 65).
  h.Authenticate(Ms(5), Key("wrong key"));
  const auto results = h.All<AuthResult>();
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].outcome, AuthOutcome::kDenied);
  EXPECT_TRUE(h.closed);
  EXPECT_FALSE(h.agent.client_authenticated());
  // Anything after the denial on this connection is ignored.
  const size_t before = h.received.size();
  h.Send(Ms(6), DriveCommand{0.3, 0.0});
  EXPECT_EQ(h.received.size(), before);
  h.TickRange(Ms(6), Ms(1000));
  EXPECT_FALSE(h.AnyNonZeroMotorCommand());
  EXPECT_EQ(h.agent.applied_v_mps(), 0.0);
  EXPECT_TRUE(h.All<Telemetry>().empty());
}

TEST(AgentCoreTest, SecondAuthResponseOnTheSameConnectionIsDenied) {
  const AgentOptions options = TestOptions();
  AgentHarness h(options);
  h.Start(Ms(0));
  h.Connect(Ms(0));
  h.Authenticate(Ms(1), options.key);
  h.Send(Ms(2), AuthResponse{});
  const auto results = h.All<AuthResult>();
  ASSERT_EQ(results.size(), 2u);
  EXPECT_EQ(results[1].outcome, AuthOutcome::kDenied);
  EXPECT_TRUE(h.closed);
}

TEST(AgentCoreTest, ReplayedResponseFailsOnANewNonce) {
  const AgentOptions options = TestOptions();
  AgentHarness h(options);
  h.Start(Ms(0));
  h.Connect(Ms(0));
  const AuthChallenge old = *h.LastChallenge();
  AuthResponse recorded;
  LinkSessionKey unused;
  ASSERT_TRUE(MakeLinkAuthResponse(options.key, old, &recorded, &unused));
  h.agent.OnClientDisconnected(Ms(1), &h.out);
  h.Connect(Ms(2));
  h.Send(Ms(3), recorded);
  EXPECT_EQ(h.All<AuthResult>().back().outcome, AuthOutcome::kDenied);
}

TEST(AgentCoreTest, UnauthenticatedClientIsDroppedAfterTheAuthTimeout) {
  AgentHarness h(TestOptions());
  h.Start(Ms(0));
  h.Connect(Ms(0));
  h.TickRange(Ms(0), Ms(1900), milliseconds(100));
  EXPECT_FALSE(h.closed);
  h.Tick(Ms(2000));
  EXPECT_TRUE(h.closed);
  EXPECT_EQ(h.All<AuthResult>().back().reason, "authentication timeout");
}

TEST(AgentCoreTest, EmergencyStopIsAcceptedEvenUnauthenticated) {
  AgentHarness h(TestOptions());
  h.Start(Ms(0));
  h.Connect(Ms(0));
  h.Send(Ms(1), EmergencyStop{});
  EXPECT_TRUE(h.All<CommandAck>().empty());  // Acts, but no answer before authentication.
  EXPECT_TRUE(h.agent.status(Ms(1)).emergency_stop_latched);
}

class AuthenticatedAgentTest : public ::testing::Test {
 protected:
  AuthenticatedAgentTest() : h_(TestOptions()) {
    h_.Start(Ms(0));
    h_.Connect(Ms(0));
    h_.Authenticate(Ms(0), TestOptions().key);
  }
  // Ticks every 10 ms and sends a Heartbeat every 100 ms (a healthy client).
  void RunWithHeartbeats(Time from, Time to) {
    for (Time t = from; t <= to; t += milliseconds(10)) {
      if ((t - from) % milliseconds(100) == Duration::zero()) h_.Send(t, Heartbeat{});
      h_.Tick(t);
    }
  }
  AgentHarness h_;
};

TEST_F(AuthenticatedAgentTest, VelocityLimitsClampTheSetPoint) {
  h_.Send(Ms(10), DriveCommand{3.0, -7.0});
  const LinkStatus s = h_.agent.status(Ms(10));
  EXPECT_EQ(s.commanded_v_mps, 0.5);
  EXPECT_EQ(s.commanded_w_radps, -1.0);
  RunWithHeartbeats(Ms(10), Ms(2000));
  EXPECT_NEAR(h_.agent.applied_v_mps(), 0.5, 1e-12);
  EXPECT_NEAR(h_.agent.applied_w_radps(), -1.0, 1e-12);
  for (const auto& c : h_.motor_commands) {
    EXPECT_LE(std::abs(c.vx_mps), 0.5 + 1e-3);
    EXPECT_LE(std::abs(c.wz_radps), 1.0 + 1e-3);
  }
}

TEST_F(AuthenticatedAgentTest, AccelerationIsRampedAndCommandsGoOutAt20Hz) {
  h_.Send(Ms(100), DriveCommand{0.5, 0.0});
  h_.motor_commands.clear();
  RunWithHeartbeats(Ms(100), Ms(1100));
  // 1 m/s^2 from 0 to 0.5 m/s takes 0.5 s; wire resolution is 1 mm/s.
  ASSERT_GE(h_.motor_commands.size(), 19u);
  EXPECT_LE(h_.motor_commands.size(), 22u);
  double previous = 0.0;
  for (const auto& c : h_.motor_commands) {
    EXPECT_LE(c.vx_mps - previous, 1.0 * 0.05 + 1e-3);  // <= a_max * motor period.
    EXPECT_GE(c.vx_mps, previous - 1e-9);
    previous = c.vx_mps;
  }
  EXPECT_NEAR(h_.motor_commands.back().vx_mps, 0.5, 1e-3);
}

TEST_F(AuthenticatedAgentTest, StopRampsDownAndEndsWithAZeroCommand) {
  h_.Send(Ms(0), DriveCommand{0.4, 0.0});
  RunWithHeartbeats(Ms(0), Ms(1000));
  h_.Send(Ms(1000), Stop{});
  h_.motor_commands.clear();
  RunWithHeartbeats(Ms(1000), Ms(1200));
  // After 0.2 s of 1 m/s^2: 0.2 m/s.
  EXPECT_NEAR(h_.agent.applied_v_mps(), 0.2, 0.011);
  RunWithHeartbeats(Ms(1200), Ms(2000));
  EXPECT_EQ(h_.agent.applied_v_mps(), 0.0);
  ASSERT_FALSE(h_.motor_commands.empty());
  EXPECT_EQ(h_.motor_commands.back().vx_mps, 0.0);
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kIdle);
}

TEST_F(AuthenticatedAgentTest, EmergencyStopZeroesAtOnceAndLatchesUntilCleared) {
  h_.Send(Ms(0), DriveCommand{0.4, 0.5});
  RunWithHeartbeats(Ms(0), Ms(1000));
  h_.motor_commands.clear();
  h_.Send(Ms(1000), EmergencyStop{});
  // Zero is sent in the same call, without waiting for a tick.
  ASSERT_EQ(h_.motor_commands.size(), 1u);
  EXPECT_EQ(h_.motor_commands[0].vx_mps, 0.0);
  EXPECT_EQ(h_.motor_commands[0].wz_radps, 0.0);
  EXPECT_TRUE(h_.All<LinkStatus>().back().emergency_stop_latched);
  h_.Send(Ms(1010), DriveCommand{0.2, 0.0});
  EXPECT_EQ(h_.All<CommandAck>().back().result, AckResult::kEmergencyStopLatched);
  RunWithHeartbeats(Ms(1010), Ms(1500));
  EXPECT_FALSE(h_.AnyNonZeroMotorCommand());
  h_.Send(Ms(1500), ClearEmergencyStop{});
  EXPECT_EQ(h_.All<CommandAck>().back().result, AckResult::kAccepted);
  RunWithHeartbeats(Ms(1500), Ms(1800));
  EXPECT_FALSE(h_.AnyNonZeroMotorCommand());  // Still until the next Drive.
  h_.Send(Ms(1800), DriveCommand{0.2, 0.0});
  EXPECT_EQ(h_.All<CommandAck>().back().result, AckResult::kAccepted);
  RunWithHeartbeats(Ms(1800), Ms(2000));
  EXPECT_TRUE(h_.AnyNonZeroMotorCommand());
  EXPECT_GE(h_.agent.status(Ms(2000)).commands_refused, 1u);
}

TEST_F(AuthenticatedAgentTest, WatchdogStopsWithinThePeriodOfTheLastFrame) {
  h_.Send(Ms(0), DriveCommand{0.4, 0.3});
  RunWithHeartbeats(Ms(0), Ms(1000));  // Last heartbeat at 1000 ms.
  ASSERT_GT(h_.agent.applied_v_mps(), 0.3);
  const Time last_frame = Ms(1000);
  Time stopped_at;
  bool stopped = false;
  for (Time t = Ms(1010); t <= Ms(2000); t += milliseconds(10)) {
    h_.motor_commands.clear();
    h_.Tick(t);
    if (!stopped && !h_.motor_commands.empty() && h_.motor_commands.back().vx_mps == 0.0 &&
        h_.motor_commands.back().wz_radps == 0.0) {
      stopped = true;
      stopped_at = t;
    }
  }
  ASSERT_TRUE(stopped);
  EXPECT_LE(stopped_at - last_frame, milliseconds(500) + milliseconds(10));
  EXPECT_GE(stopped_at - last_frame, milliseconds(500));  // Not before the period.
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kTripped);
  const LinkStatus s = h_.All<LinkStatus>().back();
  EXPECT_EQ(s.watchdog, WatchdogState::kTripped);
  EXPECT_EQ(s.watchdog_trips, 1u);
  EXPECT_EQ(s.applied_v_mps, 0.0);
  // A new Drive re-arms it.
  h_.Send(Ms(2000), DriveCommand{0.1, 0.0});
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kArmed);
}

// A link that stalls past the watchdog (Wi-Fi behind a wall) holds the
// client's frames and then delivers them at once. The watchdog stopped the
// robot; the drives the link held, 650 ms to 50 ms late, do not start it
// again, whether over stale_drive_after late or in the same read as those
// that are. Once a frame has come on time, drives do again. They used to
// re-arm it with the set-point of before the stall until the client, told
// of the trip by the Status the stall also held, stopped it.
TEST_F(AuthenticatedAgentTest, DrivesAStallHeldPastAWatchdogTripDoNotRestartTheRobot) {
  h_.Send(Ms(0), DriveCommand{0.3, 0.0});
  RunWithHeartbeats(Ms(0), Ms(500));
  ASSERT_GT(h_.agent.applied_v_mps(), 0.2);
  // Nothing arrives after 500 ms; the client drives on at 10 Hz meanwhile.
  std::vector<uint8_t> held;
  for (int ms = 600; ms <= 1200; ms += 100) {
    for (const auto& frame : {h_.client.EncodeDrive(Ms(ms), 0.3, 0.0),
                              h_.client.Encode(Ms(ms), LinkPayload{Heartbeat{}})}) {
      held.insert(held.end(), frame.begin(), frame.end());
    }
  }
  h_.TickRange(Ms(510), Ms(1240));
  ASSERT_EQ(h_.agent.watchdog_state(), WatchdogState::kTripped);
  ASSERT_FALSE(h_.motor_commands.empty());
  ASSERT_EQ(h_.motor_commands.back().vx_mps, 0.0);
  h_.motor_commands.clear();
  const size_t acks_before = h_.All<CommandAck>().size();
  h_.SendBytes(Ms(1250), held);
  h_.TickRange(Ms(1250), Ms(1500));
  EXPECT_FALSE(h_.AnyNonZeroMotorCommand());
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kTripped);
  EXPECT_EQ(h_.agent.counters().stale_drives, 7u);
  const std::vector<CommandAck> acks = h_.All<CommandAck>();
  size_t refused = 0;
  for (size_t i = acks_before; i < acks.size(); ++i) {
    if (acks[i].acked_type == static_cast<uint8_t>(LinkMessageType::kDriveCommand)) {
      EXPECT_EQ(acks[i].result, AckResult::kInvalid);
      ++refused;
    }
  }
  EXPECT_EQ(refused, 7u);
  // A frame on time ends the stall: a drive delayed later (150 ms, in a
  // read of its own) is not the stall's, and drives again.
  h_.SendBytes(Ms(1505), h_.client.Encode(Ms(1500), LinkPayload{Heartbeat{}}));
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kTripped);
  h_.SendBytes(Ms(1750), h_.client.EncodeDrive(Ms(1600), 0.3, 0.0));
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kArmed);
  h_.TickRange(Ms(1760), Ms(1850));
  EXPECT_TRUE(h_.AnyNonZeroMotorCommand());
  EXPECT_EQ(h_.agent.counters().stale_drives, 7u);
}

TEST_F(AuthenticatedAgentTest, HeartbeatsKeepTheWatchdogFedAndAreAcked) {
  h_.Send(Ms(0), DriveCommand{0.2, 0.0});
  RunWithHeartbeats(Ms(0), Ms(3000));
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kArmed);
  EXPECT_NEAR(h_.agent.applied_v_mps(), 0.2, 1e-12);
  size_t heartbeat_acks = 0;
  for (const auto& ack : h_.All<CommandAck>()) {
    if (ack.acked_type == static_cast<uint8_t>(LinkMessageType::kHeartbeat)) ++heartbeat_acks;
  }
  EXPECT_EQ(heartbeat_acks, 31u);
}

TEST_F(AuthenticatedAgentTest, CorruptFramesDoNotFeedTheWatchdog) {
  h_.Send(Ms(0), DriveCommand{0.2, 0.0});
  RunWithHeartbeats(Ms(0), Ms(500));
  std::vector<uint8_t> frame = h_.client.EncodeHeartbeat(Ms(600));
  frame.back() ^= 0xFF;  // Frame CRC broken.
  for (Time t = Ms(510); t <= Ms(1010); t += milliseconds(10)) {
    h_.agent.OnClientBytes(frame.data(), frame.size(), t, &h_.out);
    h_.Tick(t);
  }
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kTripped);
  EXPECT_GT(h_.agent.status(Ms(1010)).frames_rejected, 0u);
}

TEST_F(AuthenticatedAgentTest, DisconnectTripsTheWatchdogAtOnce) {
  h_.Send(Ms(0), DriveCommand{0.3, 0.0});
  RunWithHeartbeats(Ms(0), Ms(500));
  h_.motor_commands.clear();
  h_.agent.OnClientDisconnected(Ms(505), &h_.out);
  h_.Collect();
  ASSERT_EQ(h_.motor_commands.size(), 1u);
  EXPECT_EQ(h_.motor_commands[0].vx_mps, 0.0);
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kTripped);
}

TEST_F(AuthenticatedAgentTest, DeviceBytesBecomeTelemetryWithTheReceiveTime) {
  h_.Send(Ms(1), Heartbeat{});  // The client's first command opens the telemetry (below).
  const uint8_t bytes[] = {0xAA, 0x55, 0x01, 0x02};
  h_.agent.OnDeviceBytes(LinkDevice::kLidar, bytes, sizeof(bytes), Ms(42), &h_.out);
  h_.Collect();
  const auto telemetry = h_.All<Telemetry>();
  ASSERT_EQ(telemetry.size(), 1u);
  EXPECT_EQ(telemetry[0].device, 1);
  EXPECT_EQ(telemetry[0].receive_time, Ms(42));
  EXPECT_EQ(telemetry[0].bytes, std::vector<uint8_t>(bytes, bytes + 4));
  EXPECT_EQ(h_.agent.status(Ms(42)).device_bytes[0], 4u);
  // Reads beyond one frame's capacity are split, all with the same time.
  std::vector<uint8_t> big(kLinkMaxTelemetryBytes + 100, 0x11);
  h_.agent.OnDeviceBytes(LinkDevice::kImu, big.data(), big.size(), Ms(50), &h_.out);
  h_.Collect();
  const auto all = h_.All<Telemetry>();
  ASSERT_EQ(all.size(), 3u);
  EXPECT_EQ(all[1].bytes.size() + all[2].bytes.size(), big.size());
  EXPECT_EQ(all[2].receive_time, Ms(50));
}

TEST_F(AuthenticatedAgentTest, MotorFeedbackGivesBatteryAndStatusAt10Hz) {
  MotorFeedback feedback;
  feedback.voltage_v = 11.7;
  const auto bytes = EncodeMotorFeedback(feedback);
  h_.agent.OnDeviceBytes(LinkDevice::kMotorBoard, bytes.data(), bytes.size(), Ms(5), &h_.out);
  h_.Collect();
  const size_t before = h_.All<LinkStatus>().size();
  RunWithHeartbeats(Ms(10), Ms(1000));
  const auto statuses = h_.All<LinkStatus>();
  EXPECT_GE(statuses.size() - before, 9u);
  EXPECT_LE(statuses.size() - before, 11u);
  EXPECT_NEAR(statuses.back().battery_voltage_v, 11.7, 1e-3);
  EXPECT_TRUE(statuses.back().client_authenticated);
}

TEST_F(AuthenticatedAgentTest, SilentDevicesAreReportedAsFaults) {
  RunWithHeartbeats(Ms(10), Ms(1500));
  const uint32_t faults = h_.All<LinkStatus>().back().fault_bits;
  EXPECT_TRUE(faults & kFaultImuSilent);
  EXPECT_TRUE(faults & kFaultMotorBoardSilent);
  EXPECT_FALSE(faults & kFaultLidarSilent);  // The lidar motor is off.
}

TEST_F(AuthenticatedAgentTest, LidarStartUpRequestsAndMotorCommands) {
  RunWithHeartbeats(Ms(0), Ms(300));
  // Start: A5 65 (stop), then A5 90 (device info), A5 92 (health), spaced.
  const std::vector<uint8_t> startup = {0xA5, 0x65, 0xA5, 0x90, 0xA5, 0x92};
  EXPECT_EQ(h_.lidar_bytes, startup);
  h_.lidar_bytes.clear();
  h_.Send(Ms(310), LidarMotor{true});
  EXPECT_EQ(h_.lidar_bytes, (std::vector<uint8_t>{0xA5, 0x60}));
  EXPECT_TRUE(h_.agent.status(Ms(310)).lidar_motor_on);
  h_.lidar_bytes.clear();
  h_.Send(Ms(320), LidarMotor{false});
  EXPECT_EQ(h_.lidar_bytes, (std::vector<uint8_t>{0xA5, 0x65}));
}

// The X4's motor is powered through its USB adapter's DTR line, which the
// workstation's DirectDevice sets and the vendor's SDK switches; opening a
// tty raises DTR, so the agent left the motor spinning whenever it held the
// port and LidarMotor off stopped the scan only. Now: off at start, on
// with LidarMotor on (before A5 60, RobotAgent sets it first), off with
// LidarMotor off, and the state in force again whenever the lidar's port
// (re)opens, with the start-up sequence and A5 60 after it for an X4
// plugged back in while on.
TEST_F(AuthenticatedAgentTest, LidarMotorSwitchesTheAdaptersDtrLine) {
  RunWithHeartbeats(Ms(0), Ms(300));
  EXPECT_EQ(h_.lidar_dtr, std::vector<bool>{false}) << "the motor off at start";
  h_.agent.OnDevicePortOpened(LinkDevice::kLidar, Ms(300), &h_.out);
  h_.Collect();
  EXPECT_EQ(h_.lidar_dtr, (std::vector<bool>{false, false})) << "and when its port opens";
  RunWithHeartbeats(Ms(310), Ms(600));
  EXPECT_EQ(h_.lidar_bytes, (std::vector<uint8_t>{0xA5, 0x65, 0xA5, 0x90, 0xA5, 0x92, 0xA5, 0x65,
                                                  0xA5, 0x90, 0xA5, 0x92}))
      << "the start-up sequence again, no scan with the motor off";
  h_.lidar_bytes.clear();
  h_.lidar_dtr.clear();
  h_.Send(Ms(610), LidarMotor{true});
  EXPECT_EQ(h_.lidar_dtr, std::vector<bool>{true});
  EXPECT_EQ(h_.lidar_bytes, (std::vector<uint8_t>{0xA5, 0x60}));
  // Unplugged and plugged in again while on: DTR raised, the start-up
  // sequence, then scanning again.
  h_.lidar_bytes.clear();
  h_.agent.OnDevicePortOpened(LinkDevice::kLidar, Ms(615), &h_.out);
  h_.Collect();
  EXPECT_EQ(h_.lidar_dtr, (std::vector<bool>{true, true}));
  RunWithHeartbeats(Ms(620), Ms(1000));
  EXPECT_EQ(h_.lidar_bytes, (std::vector<uint8_t>{0xA5, 0x65, 0xA5, 0x90, 0xA5, 0x92, 0xA5, 0x60}));
  h_.lidar_bytes.clear();
  h_.Send(Ms(1010), LidarMotor{false});
  EXPECT_EQ(h_.lidar_dtr, (std::vector<bool>{true, true, false}));
  EXPECT_EQ(h_.lidar_bytes, (std::vector<uint8_t>{0xA5, 0x65}));
}

// An X4 plugged in after the agent started got nothing: the start-up
// sequence was sent once, timed from the start, to a port not yet open.
// Now a port that opens later gets stop, device info and health, spaced as
// at the start (the sequence Start() queued is not sent twice to a port
// opened with it).
TEST(AgentCoreTest, ALidarPortOpenedLateGetsTheStartUpSequence) {
  AgentHarness h(TestOptions());
  h.Start(Ms(0));
  h.agent.OnDevicePortOpened(LinkDevice::kLidar, Ms(0), &h.out);  // Opened with the start.
  h.Collect();
  h.TickRange(Ms(10), Ms(500));
  const std::vector<uint8_t> startup = {0xA5, 0x65, 0xA5, 0x90, 0xA5, 0x92};
  EXPECT_EQ(h.lidar_bytes, startup);
  h.lidar_bytes.clear();
  h.agent.OnDevicePortOpened(LinkDevice::kLidar, Ms(4000), &h.out);  // Plugged in later.
  h.Collect();
  EXPECT_EQ(h.lidar_bytes, (std::vector<uint8_t>{0xA5, 0x65})) << "stop at once";
  h.TickRange(Ms(4010), Ms(4090));
  EXPECT_EQ(h.lidar_bytes.size(), 2u) << "device info 100 ms later, not before";
  h.TickRange(Ms(4100), Ms(4500));
  EXPECT_EQ(h.lidar_bytes, startup);
}

// The X4 spun on after the workstation left, for as long as robotd ran. Now
// its motor goes off once no client has said anything for lidar_idle_off,
// and a client's LidarMotor turns it on again; a talking client keeps it.
TEST(AgentCoreTest, TheLidarMotorGoesOffWhenNoClientHasSpokenForTheIdleTime) {
  AgentOptions options = TestOptions();
  options.lidar_idle_off = std::chrono::seconds(30);
  AgentHarness h(options);
  h.Start(Ms(0));
  h.Connect(Ms(0));
  h.Authenticate(Ms(0), options.key);
  h.Send(Ms(1000), LidarMotor{true});
  for (int t = 1100; t <= 40000; t += 100) {  // A client heartbeating: on all along.
    h.Send(Ms(t), Heartbeat{});
    h.Tick(Ms(t));
  }
  EXPECT_TRUE(h.agent.status(Ms(40000)).lidar_motor_on);
  h.agent.OnClientDisconnected(Ms(40000), &h.out);
  h.Collect();
  h.lidar_bytes.clear();
  h.lidar_dtr.clear();
  h.TickRange(Ms(40010), Ms(69990), milliseconds(20));
  EXPECT_TRUE(h.agent.status(Ms(69990)).lidar_motor_on) << "within the idle time";
  EXPECT_TRUE(h.lidar_dtr.empty());
  h.TickRange(Ms(70000), Ms(70100));
  EXPECT_FALSE(h.agent.status(Ms(70100)).lidar_motor_on) << "30 s after the client's last frame";
  EXPECT_EQ(h.lidar_dtr, std::vector<bool>{false});
  EXPECT_EQ(h.lidar_bytes, (std::vector<uint8_t>{0xA5, 0x65}));
  EXPECT_EQ(h.agent.counters().lidar_idle_stops, 1u);
  h.TickRange(Ms(70200), Ms(100000), milliseconds(100));
  EXPECT_EQ(h.agent.counters().lidar_idle_stops, 1u) << "said once";
  // The next workstation asks for it at its authentication, as the app and
  // `record` do: on again.
  h.Connect(Ms(100000));
  h.client = LinkEncoder(LinkSender::kClient);
  h.Authenticate(Ms(100000), options.key);
  h.lidar_dtr.clear();
  h.lidar_bytes.clear();
  h.Send(Ms(100010), LidarMotor{true});
  EXPECT_EQ(h.lidar_dtr, std::vector<bool>{true});
  EXPECT_EQ(h.lidar_bytes, (std::vector<uint8_t>{0xA5, 0x60}));
  EXPECT_TRUE(h.agent.status(Ms(100010)).lidar_motor_on);
}

TEST(AgentCoreTest, TheLidarIdleTimeMustOutlastTheResumeWindow) {
  AgentOptions options = TestOptions();
  options.telemetry_buffer = std::chrono::seconds(10);
  options.resume_wait = std::chrono::seconds(5);
  options.lidar_idle_off = std::chrono::seconds(14);
  std::string error;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(error.find("lidar idle"), std::string::npos) << error;
  options.lidar_idle_off = std::chrono::seconds(15);
  EXPECT_TRUE(options.IsValid(&error)) << error;
  options.lidar_idle_off = Duration::zero();  // Never.
  EXPECT_TRUE(options.IsValid(&error)) << error;
}

TEST(AgentCoreTest, SerialLinkWithoutAuthRepeatsHelloAndAcceptsCommands) {
  AgentOptions options = TestOptions();
  options.require_auth = false;
  options.key.clear();
  options.hello_on_client_hello = true;
  AgentHarness h(options);
  h.Start(Ms(0));
  h.Connect(Ms(0));
  EXPECT_TRUE(h.All<AuthChallenge>().empty());
  h.Send(Ms(10), Hello{});
  EXPECT_EQ(h.All<Hello>().size(), 2u);
  h.Send(Ms(20), DriveCommand{0.1, 0.0});
  EXPECT_EQ(h.All<CommandAck>().back().result, AckResult::kAccepted);
}

TEST(AgentCoreTest, MissingRandomSourceRefusesToAuthenticate) {
  AgentOptions options = TestOptions();
  options.random_source = [](uint8_t*, size_t) { return false; };
  AgentHarness h(options);
  h.Start(Ms(0));
  h.Connect(Ms(0));
  EXPECT_TRUE(h.closed);
  EXPECT_EQ(h.All<AuthResult>().back().outcome, AuthOutcome::kDenied);
}

// ---------------------------------------------------------------------------
// Issue 16: per-frame authentication after the handshake, version 1 peers,
// no answers before authentication, bounded work per call.

TEST(AgentCoreTest, UnauthenticatedPeerGetsNothingBeyondTheChallenge) {
  AgentHarness h(TestOptions());
  h.Start(Ms(0));
  h.Connect(Ms(0));
  ASSERT_EQ(h.received.size(), 2u);  // Hello, AuthChallenge.
  for (int i = 0; i < 1000; ++i) h.Send(Ms(1), Heartbeat{});
  h.TickRange(Ms(1), Ms(1900));
  EXPECT_EQ(h.received.size(), 2u);
}

TEST(AgentCoreTest, OldProtocolVersionGetsAReadableRefusal) {
  AgentHarness h(TestOptions());
  h.Start(Ms(0));
  h.Connect(Ms(0));
  // A version-1 client's Hello, as the old RobotConnection wrote it.
  std::vector<uint8_t> body;
  EncodeLinkPayload(Hello{1, false, "sweepscan 0.0.9", {}}, &body);
  std::vector<uint8_t> frame;
  ASSERT_TRUE(AppendRawLinkFrame(LinkSender::kClient, 0, Ms(1), 0x01, body.data(), body.size(),
                                 &frame, nullptr, 1));
  h.SendBytes(Ms(1), frame);
  EXPECT_TRUE(h.closed);
  ASSERT_FALSE(h.received.empty());
  const LinkMessage& last = h.received.back();
  EXPECT_EQ(last.header.version, 1);  // An old client can read it.
  const auto* result = std::get_if<AuthResult>(&last.payload);
  ASSERT_NE(result, nullptr);
  EXPECT_EQ(result->outcome, AuthOutcome::kDenied);
  EXPECT_NE(result->reason.find("protocol version 1 is not supported"), std::string::npos)
      << result->reason;
  EXPECT_EQ(h.agent.counters().old_protocol_refused, 1u);
}

class SignedFramesTest : public ::testing::Test {
 protected:
  SignedFramesTest() : h_(TestOptions()) {
    h_.Start(Ms(0));
    h_.Connect(Ms(0));
    h_.Authenticate(Ms(0), TestOptions().key);
  }
  size_t Acks() const { return h_.All<CommandAck>().size(); }
  AgentHarness h_;
};

TEST_F(SignedFramesTest, SignedFramesDrive) {
  h_.Send(Ms(10), DriveCommand{0.2, 0.0});
  ASSERT_EQ(Acks(), 1u);
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kArmed);
}

TEST_F(SignedFramesTest, InjectedUnsignedFramesHaveNoEffect) {
  // Someone able to write into the TCP stream, without the session key.
  LinkEncoder attacker(LinkSender::kClient, h_.client.next_sequence());
  h_.SendBytes(Ms(10), attacker.Encode(Ms(10), DriveCommand{0.5, 1.0}));
  h_.SendBytes(Ms(10), attacker.Encode(Ms(10), ClearEmergencyStop{}));
  h_.SendBytes(Ms(10), attacker.Encode(Ms(10), LidarMotor{true}));
  EXPECT_EQ(Acks(), 0u);
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kIdle);
  h_.TickRange(Ms(10), Ms(300));
  EXPECT_FALSE(h_.AnyNonZeroMotorCommand());
  EXPECT_EQ(h_.agent.counters().frames_unsigned, 3u);
  // Frames with a tag under another key are refused too.
  LinkSessionKey wrong = h_.session_key;
  wrong[0] ^= 1;
  attacker.SetSigner(MakeLinkFrameSigner(wrong));
  h_.SendBytes(Ms(300), attacker.Encode(Ms(300), DriveCommand{0.5, 1.0}));
  EXPECT_EQ(h_.agent.counters().frames_bad_tag, 1u);
  EXPECT_EQ(Acks(), 0u);
  // The real client still drives (its sequence numbers are its own).
  h_.Send(Ms(310), DriveCommand{0.1, 0.0});
  EXPECT_EQ(Acks(), 1u);
}

TEST_F(SignedFramesTest, ReplayedAndReorderedFramesAreRefused) {
  const std::vector<uint8_t> drive = h_.client.Encode(Ms(10), DriveCommand{0.2, 0.0});
  const std::vector<uint8_t> stop = h_.client.Encode(Ms(11), Stop{});
  const std::vector<uint8_t> later = h_.client.Encode(Ms(12), Heartbeat{});
  h_.SendBytes(Ms(12), later);  // Sequence n + 2 first ...
  h_.SendBytes(Ms(12), drive);  // ... then n and n + 1: reordered, refused.
  h_.SendBytes(Ms(12), stop);
  EXPECT_EQ(Acks(), 1u);
  EXPECT_EQ(h_.agent.counters().frames_replayed, 2u);
  h_.SendBytes(Ms(13), later);  // The same frame again: replay, refused.
  EXPECT_EQ(Acks(), 1u);
  EXPECT_EQ(h_.agent.counters().frames_replayed, 3u);
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kIdle);  // The Drive never acted.
}

TEST_F(SignedFramesTest, RefusedFramesDoNotFeedTheWatchdog) {
  h_.Send(Ms(0), DriveCommand{0.2, 0.0});
  LinkEncoder attacker(LinkSender::kClient, 1000);
  for (Time t = Ms(0); t <= Ms(700); t += milliseconds(10)) {
    h_.SendBytes(t, attacker.Encode(t, Heartbeat{}));  // Unsigned: not a sign of life.
    h_.Tick(t);
  }
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kTripped);
}

TEST_F(SignedFramesTest, ForgedCandidateFloodIsWorkedOffInBoundedSlices) {
  const AgentOptions options = TestOptions();
  h_.Send(Ms(0), DriveCommand{0.2, 0.0});
  const std::vector<uint8_t> flood = sweepscan::testing::ForgedLinkCandidates(
      LinkSender::kClient, 20000, options.max_client_payload - 32);
  h_.agent.OnClientBytes(flood.data(), flood.size(), Ms(0), &h_.out);
  h_.Collect();
  EXPECT_TRUE(h_.agent.client_work_pending());
  int calls = 1;
  Time t = Ms(0);
  while (h_.agent.client_work_pending() && calls < 100000) {
    t += milliseconds(1);
    h_.agent.ContinueClientBytes(t, &h_.out);
    h_.Tick(t);
    ++calls;
  }
  EXPECT_FALSE(h_.agent.client_work_pending());
  // 560 kB of input at ~10 CRC bytes per byte: many slices of <= 256 KiB.
  EXPECT_GT(calls, 10);
  // The flood fed nothing: the watchdog trips 500 ms after the Drive.
  h_.TickRange(t, Ms(490));
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kArmed);
  h_.TickRange(Ms(500), Ms(510));
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kTripped);
  EXPECT_FALSE(h_.closed);
}

TEST_F(SignedFramesTest, AnUndecodedBacklogBeyondTheLimitDropsTheConnection) {
  const AgentOptions options = TestOptions();
  h_.Send(Ms(0), DriveCommand{0.2, 0.0});
  const std::vector<uint8_t> flood = sweepscan::testing::ForgedLinkCandidates(
      LinkSender::kClient, 60000, options.max_client_payload - 32);
  ASSERT_GT(flood.size(), options.max_client_backlog);
  h_.SendBytes(Ms(1), flood);
  EXPECT_TRUE(h_.closed);
  EXPECT_EQ(h_.agent.counters().input_floods, 1u);
  h_.agent.OnClientDisconnected(Ms(2), &h_.out);
  EXPECT_EQ(h_.agent.watchdog_state(), WatchdogState::kTripped);  // Stopped at once.
}


}  // namespace
}  // namespace hardware
}  // namespace sweepscan
