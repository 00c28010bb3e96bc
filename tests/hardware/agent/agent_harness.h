// The test side of an AgentCore driven by explicit times: the options the
// tests use, robot times in ms, and AgentHarness (the workstation end plus
// everything the agent wrote). Shared by agent_core_test and
// telemetry_buffer_test.
#ifndef SWEEPSCAN_TESTS_HARDWARE_AGENT_AGENT_HARNESS_H_
#define SWEEPSCAN_TESTS_HARDWARE_AGENT_AGENT_HARNESS_H_

#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <vector>

#include "hardware/agent/agent_core.h"
#include "hardware/codecs/motor_board_codec.h"
#include "hardware/link/hmac_sha256.h"

namespace sweepscan {
namespace hardware {
namespace agent_testing {

using std::chrono::milliseconds;

inline std::vector<uint8_t> Key(const std::string& s) { return std::vector<uint8_t>(s.begin(), s.end()); }

inline AgentOptions TestOptions() {
  AgentOptions options;
  options.key = Key("correct horse battery staple");
  options.devices = {{1, "X4 sim"}, {2, "HI219 sim"}, {3, "motor board sim"}};
  options.v_max_mps = 0.5;
  options.w_max_radps = 1.0;
  options.accel_max_mps2 = 1.0;
  options.alpha_max_radps2 = 2.0;
  return options;
}

inline Time Ms(int64_t ms) { return Time(milliseconds(ms)); }

// The workstation side of the test plus everything the agent wrote.
class AgentHarness {
 public:
  explicit AgentHarness(const AgentOptions& options) : agent(options) {
    std::string error;
    EXPECT_TRUE(options.IsValid(&error)) << error;
  }

  void Collect() {
    std::vector<LinkMessage> messages;
    client_decoder.Feed(out.to_client.data(), out.to_client.size(), &messages);
    for (auto& m : messages) received.push_back(std::move(m));
    motor_decoder.Feed(out.to_device[2], Time());
    for (const MotorCommand& c : motor_decoder.TakeRecords()) motor_commands.push_back(c);
    // DTR first: RobotAgent sets it before writing the lidar's bytes.
    if (out.lidar_dtr.has_value()) lidar_dtr.push_back(*out.lidar_dtr);
    auto& lidar = out.to_device[0];
    lidar_bytes.insert(lidar_bytes.end(), lidar.begin(), lidar.end());
    if (out.close_client) closed = true;
    out.Clear();
  }
  void Start(Time t) {
    agent.Start(t, &out);
    Collect();
  }
  void Connect(Time t) {
    client_decoder.Reset();
    agent.OnClientConnected(t, &out);
    Collect();
  }
  void Send(Time t, const LinkPayload& payload) {
    const std::vector<uint8_t> frame = client.Encode(t, payload);
    agent.OnClientBytes(frame.data(), frame.size(), t, &out);
    Collect();
  }
  void Tick(Time t) {
    agent.Tick(t, &out);
    Collect();
  }
  // Ticks every `step` from `from` to `to` inclusive.
  void TickRange(Time from, Time to, Duration step = milliseconds(10)) {
    for (Time t = from; t <= to; t += step) Tick(t);
  }
  const AuthChallenge* LastChallenge() const {
    for (auto it = received.rbegin(); it != received.rend(); ++it) {
      if (const auto* c = std::get_if<AuthChallenge>(&it->payload)) return c;
    }
    return nullptr;
  }
  void Authenticate(Time t, const std::vector<uint8_t>& key) {
    const AuthChallenge* challenge = LastChallenge();
    ASSERT_NE(challenge, nullptr);
    AuthResponse response;
    LinkSessionKey session;
    ASSERT_TRUE(MakeLinkAuthResponse(key, *challenge, &response, &session));
    Send(t, Hello{});
    Send(t, response);
    // Every frame after the response is signed with the session key.
    client.SetSigner(MakeLinkFrameSigner(session));
    session_key = session;
  }
  void SendBytes(Time t, const std::vector<uint8_t>& frame) {
    agent.OnClientBytes(frame.data(), frame.size(), t, &out);
    Collect();
  }
  template <typename T>
  std::vector<T> All() const {
    std::vector<T> result;
    for (const auto& m : received) {
      if (const auto* p = std::get_if<T>(&m.payload)) result.push_back(*p);
    }
    return result;
  }
  bool AnyNonZeroMotorCommand() const {
    for (const auto& c : motor_commands) {
      if (c.vx_mps != 0.0 || c.wz_radps != 0.0) return true;
    }
    return false;
  }

  AgentCore agent;
  AgentOutput out;
  LinkEncoder client{LinkSender::kClient};
  LinkDecoder client_decoder;
  MotorCommandDecoder motor_decoder;
  std::vector<LinkMessage> received;
  std::vector<MotorCommand> motor_commands;
  std::vector<uint8_t> lidar_bytes;
  std::vector<bool> lidar_dtr;  // Every state the lidar's DTR line was set to.
  bool closed = false;
  LinkSessionKey session_key{};
};

}  // namespace agent_testing
}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_TESTS_HARDWARE_AGENT_AGENT_HARNESS_H_
