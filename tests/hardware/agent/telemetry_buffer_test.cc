// The agent's buffering across outages (docs/robot-agent.md, "Outages and
// reconnection"; hardware/agent/telemetry_buffer.h), driven by explicit
// times: telemetry held until the client's first command, TelemetryResume
// resending exactly what a reconnected client missed (late and break flags,
// a split read), eviction by age, and the memory bound at full serial rate.
#include "hardware/agent/telemetry_buffer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "hardware/agent/agent_core.h"
#include "tests/hardware/agent/agent_harness.h"

namespace sweepscan {
namespace hardware {
namespace {

using agent_testing::AgentHarness;
using agent_testing::Ms;
using agent_testing::TestOptions;

// Lidar chunk i: `size` bytes that start with which chunk they are, read at 10 ms * i.
std::vector<uint8_t> Chunk(int i, size_t size = 4) {
  std::vector<uint8_t> bytes(size, 0x5A);
  bytes[0] = static_cast<uint8_t>(i);
  bytes[1] = static_cast<uint8_t>(i >> 8);
  return bytes;
}
int ChunkIndex(const Telemetry& t) { return t.bytes[0] | (t.bytes[1] << 8); }

class BufferingAgentTest : public ::testing::Test {
 protected:
  explicit BufferingAgentTest(Duration keep = std::chrono::seconds(10)) : h_(Options(keep)) {
    h_.Start(Ms(0));
  }
  static AgentOptions Options(Duration keep) {
    AgentOptions o = TestOptions();
    o.telemetry_buffer = keep;
    return o;
  }
  void ConnectAndAuthenticate(Time t) {
    h_.client = LinkEncoder(LinkSender::kClient);
    h_.Connect(t);
    h_.Authenticate(t, TestOptions().key);
  }
  // Lidar chunks `from` .. `to` (inclusive) read at 10 ms each, ticking.
  void ReadChunks(int from, int to, size_t size = 4) {
    for (int i = from; i <= to; ++i) {
      const auto bytes = Chunk(i, size);
      h_.agent.OnDeviceBytes(LinkDevice::kLidar, bytes.data(), bytes.size(), Ms(10 * i), &h_.out);
      h_.Tick(Ms(10 * i));
    }
  }
  std::vector<Telemetry> TelemetrySince(size_t first_message) const {
    std::vector<Telemetry> out;
    for (size_t k = first_message; k < h_.received.size(); ++k) {
      if (const auto* t = std::get_if<Telemetry>(&h_.received[k].payload)) out.push_back(*t);
    }
    return out;
  }
  AgentHarness h_;
};

TEST_F(BufferingAgentTest, TelemetryWaitsForTheClientsFirstCommandThenFlowsInOrder) {
  ConnectAndAuthenticate(Ms(1));
  ReadChunks(1, 5);  // Read before the client said anything: held.
  EXPECT_TRUE(h_.All<Telemetry>().empty());
  h_.Send(Ms(55), Heartbeat{});
  ReadChunks(6, 8);
  const auto t = h_.All<Telemetry>();
  ASSERT_EQ(t.size(), 8u);
  for (int i = 0; i < 8; ++i) {
    EXPECT_EQ(ChunkIndex(t[i]), i + 1);
    EXPECT_EQ(t[i].receive_time, Ms(10 * (i + 1)));
    // Read after the client was adopted: not late. The first is a break: the
    // client did not say what it holds (no TelemetryResume), so nothing
    // joins these bytes to any it had.
    EXPECT_EQ(t[i].flags, i == 0 ? kTelemetryBreak : 0) << i;
  }
}

TEST_F(BufferingAgentTest, AClientThatNeverAsksGetsLiveTelemetryAfterTheResumeWait) {
  ConnectAndAuthenticate(Ms(1));
  ReadChunks(1, 499);  // 4 990 ms: still held (resume_wait 5 s from 1 ms).
  EXPECT_TRUE(h_.All<Telemetry>().empty());
  ReadChunks(500, 501);
  EXPECT_EQ(h_.All<Telemetry>().size(), 501u);  // Held, not lost.
}

// A resume that comes after the wait (a round trip over a poor Wi-Fi link
// right after the handshake) is refused: the agent has already sent the
// live bytes, and the outage's could only follow them out of order. The
// first live chunk says they are lost; it was unmarked, and the session
// said "no data lost".
TEST_F(BufferingAgentTest, AResumeAfterTheWaitIsRefusedAndTheOutageIsMarkedLost) {
  ConnectAndAuthenticate(Ms(1));
  h_.Send(Ms(2), Heartbeat{});
  ReadChunks(1, 100);
  h_.agent.OnClientDisconnected(Ms(1001), &h_.out);
  h_.Collect();
  ReadChunks(101, 400);  // 3 s away.
  ConnectAndAuthenticate(Ms(4005));
  const size_t mark = h_.received.size();
  ReadChunks(401, 910);  // The wait ends at 9 005 ms.
  TelemetryResume resume;
  resume.devices[0] = {true, Ms(1000), 4};
  h_.Send(Ms(9200), resume);
  const auto t = TelemetrySince(mark);
  ASSERT_EQ(t.size(), 510u);  // 401 .. 910: the live bytes since the connection.
  EXPECT_EQ(ChunkIndex(t.front()), 401);
  EXPECT_NE(t.front().flags & kTelemetryBreak, 0) << "101 .. 400 were lost";
  for (size_t k = 1; k < t.size(); ++k) EXPECT_EQ(t[k].flags, 0) << k;
  const auto acks = h_.All<CommandAck>();
  ASSERT_FALSE(acks.empty());
  EXPECT_EQ(acks.back().acked_type, static_cast<uint8_t>(LinkMessageType::kTelemetryResume));
  EXPECT_EQ(acks.back().result, AckResult::kUnsupported);
  EXPECT_EQ(h_.agent.counters().resumes, 0u);
}

// An emergency stop as the link comes back (pressed while authenticating)
// is obeyed at once and does not end the wait for the resume.
TEST_F(BufferingAgentTest, AnEmergencyStopBeforeTheResumeLeavesTheResumeItsPlace) {
  ConnectAndAuthenticate(Ms(1));
  h_.Send(Ms(2), Heartbeat{});
  ReadChunks(1, 100);
  h_.agent.OnClientDisconnected(Ms(1001), &h_.out);
  h_.Collect();
  ReadChunks(101, 200);
  ConnectAndAuthenticate(Ms(2005));
  const size_t mark = h_.received.size();
  h_.Send(Ms(2006), EmergencyStop{});
  EXPECT_TRUE(h_.agent.emergency_stop_latched());
  TelemetryResume resume;
  resume.devices[0] = {true, Ms(1000), 4};
  h_.Send(Ms(2007), resume);
  const auto t = TelemetrySince(mark);
  ASSERT_EQ(t.size(), 100u);  // 101 .. 200: resent, nothing lost.
  EXPECT_EQ(ChunkIndex(t.front()), 101);
  for (const Telemetry& c : t) EXPECT_EQ(c.flags & kTelemetryBreak, 0);
  EXPECT_EQ(h_.agent.counters().resumes, 1u);
}

// A serial line never disconnects: a radio link that drops and returns
// shows as the client's Hello again. What was sent meanwhile went nowhere,
// so the Hello holds telemetry for the client's resume as a connection
// does; the resume was refused before ("unsupported") and the outage lost.
TEST(SerialBufferingAgentTest, AHelloAfterARadioOutageIsResumedFromTheClientsPosition) {
  AgentOptions o = TestOptions();
  o.require_auth = false;
  o.hello_on_client_hello = true;
  AgentHarness h(o);
  h.Start(Ms(0));
  h.client = LinkEncoder(LinkSender::kClient);
  h.Connect(Ms(1));  // The port is open.
  h.Send(Ms(2), Heartbeat{});
  auto read = [&](int from, int to) {
    for (int i = from; i <= to; ++i) {
      const auto bytes = Chunk(i);
      h.agent.OnDeviceBytes(LinkDevice::kLidar, bytes.data(), bytes.size(), Ms(10 * i), &h.out);
      h.Tick(Ms(10 * i));
    }
  };
  read(1, 100);
  read(101, 300);  // Sent while the radio was down: never received.
  const size_t mark = h.received.size();
  Hello hello;
  hello.name = "workstation";
  h.Send(Ms(3005), hello);
  TelemetryResume resume;
  resume.devices[0] = {true, Ms(1000), 4};  // Holds chunk 100.
  h.Send(Ms(3006), resume);
  read(301, 302);
  std::vector<Telemetry> t;
  for (size_t k = mark; k < h.received.size(); ++k) {
    if (const auto* m = std::get_if<Telemetry>(&h.received[k].payload)) t.push_back(*m);
  }
  ASSERT_EQ(t.size(), 202u);  // 101 .. 302, nothing twice, nothing missing.
  for (size_t k = 0; k < t.size(); ++k) {
    EXPECT_EQ(ChunkIndex(t[k]), 101 + static_cast<int>(k));
    EXPECT_EQ(t[k].flags & kTelemetryBreak, 0) << k;
  }
  EXPECT_EQ(h.agent.counters().resumes, 1u);
  EXPECT_EQ(h.agent.counters().chunks_resent, 200u);
}

TEST_F(BufferingAgentTest, ResumeResendsEverythingAfterTheClientsPositionMarkedLate) {
  ConnectAndAuthenticate(Ms(1));
  h_.Send(Ms(2), Heartbeat{});
  ReadChunks(1, 100);
  ASSERT_EQ(h_.All<Telemetry>().size(), 100u);
  // The link dies; what was sent after chunk 80 never reached the client
  // (it sat in a dead TCP connection's buffers). 3 s pass.
  h_.agent.OnClientDisconnected(Ms(1001), &h_.out);
  h_.Collect();
  ReadChunks(101, 400);
  ConnectAndAuthenticate(Ms(4005));
  const size_t mark = h_.received.size();
  TelemetryResume resume;
  resume.devices[0] = {true, Ms(800), 4};  // Holds chunk 80 whole.
  h_.Send(Ms(4006), resume);
  ReadChunks(401, 402);
  const auto t = TelemetrySince(mark);
  ASSERT_EQ(t.size(), 322u);  // 81 .. 402, nothing twice, nothing missing.
  for (size_t k = 0; k < t.size(); ++k) {
    const int i = 81 + static_cast<int>(k);
    EXPECT_EQ(ChunkIndex(t[k]), i);
    EXPECT_EQ(t[k].receive_time, Ms(10 * i));
    EXPECT_EQ((t[k].flags & kTelemetryBreak) != 0, false);
    EXPECT_EQ((t[k].flags & kTelemetryLate) != 0, i <= 400) << i;
  }
  EXPECT_EQ(h_.agent.counters().resumes, 1u);
  EXPECT_EQ(h_.agent.counters().chunks_resent, 320u);
  EXPECT_EQ(h_.agent.counters().resume_breaks, 0u);
  const auto acks = h_.All<CommandAck>();
  ASSERT_FALSE(acks.empty());
  EXPECT_EQ(acks.back().acked_type, static_cast<uint8_t>(LinkMessageType::kTelemetryResume));
  EXPECT_EQ(acks.back().result, AckResult::kAccepted);
}

TEST_F(BufferingAgentTest, ResumeInsideASplitReadSkipsExactlyTheBytesTheClientHas) {
  ConnectAndAuthenticate(Ms(1));
  h_.Send(Ms(2), Heartbeat{});
  std::vector<uint8_t> big(kLinkMaxTelemetryBytes + 1000);
  for (size_t i = 0; i < big.size(); ++i) big[i] = static_cast<uint8_t>(i * 7);
  h_.agent.OnDeviceBytes(LinkDevice::kImu, big.data(), big.size(), Ms(20), &h_.out);
  h_.Collect();
  h_.agent.OnClientDisconnected(Ms(30), &h_.out);
  h_.Collect();
  ConnectAndAuthenticate(Ms(40));
  const size_t mark = h_.received.size();
  TelemetryResume resume;
  resume.devices[1] = {true, Ms(20), 5000};  // Got the first 5000 bytes of that read.
  h_.Send(Ms(41), resume);
  std::vector<uint8_t> rest;
  for (const Telemetry& t : TelemetrySince(mark)) {
    EXPECT_EQ(t.device, 2);
    EXPECT_EQ(t.receive_time, Ms(20));
    rest.insert(rest.end(), t.bytes.begin(), t.bytes.end());
  }
  EXPECT_EQ(rest, std::vector<uint8_t>(big.begin() + 5000, big.end()));
}

class ShortBufferAgentTest : public BufferingAgentTest {
 protected:
  ShortBufferAgentTest() : BufferingAgentTest(std::chrono::seconds(1)) {}
};

TEST_F(ShortBufferAgentTest, AnOutageLongerThanTheBufferIsResentFromItsOldestChunkAsABreak) {
  ConnectAndAuthenticate(Ms(1));
  h_.Send(Ms(2), Heartbeat{});
  ReadChunks(1, 100, 300);  // 30 kB/s, about the X4's rate.
  h_.agent.OnClientDisconnected(Ms(1001), &h_.out);
  h_.Collect();
  ReadChunks(101, 400, 300);  // 3 s away, 1 s kept.
  ConnectAndAuthenticate(Ms(4005));
  const size_t mark = h_.received.size();
  TelemetryResume resume;
  resume.devices[0] = {true, Ms(1000), 300};
  h_.Send(Ms(4006), resume);
  const auto t = TelemetrySince(mark);
  ASSERT_FALSE(t.empty());
  // Whole 64 KiB blocks (about 200 chunks) are dropped once their newest
  // chunk is 1 s old: at least the last second is there, and less than 3 s.
  EXPECT_LE(ChunkIndex(t.front()), 301);
  EXPECT_GT(ChunkIndex(t.front()), 101);
  EXPECT_EQ(ChunkIndex(t.back()), 400);
  EXPECT_NE(t.front().flags & kTelemetryBreak, 0) << "bytes before it were lost";
  for (size_t k = 1; k < t.size(); ++k) {
    EXPECT_EQ(ChunkIndex(t[k]), ChunkIndex(t[k - 1]) + 1);
    EXPECT_EQ(t[k].flags & kTelemetryBreak, 0);
  }
  EXPECT_EQ(h_.agent.counters().resume_breaks, 1u);
  // The buffer stays within its bound.
  EXPECT_LE(h_.agent.telemetry_buffer().peak_bytes(),
            h_.agent.telemetry_buffer().max_bytes() + 64 * 1024);
}

TEST(TelemetryBufferTest, MemoryStaysBoundedAtFullSerialRate) {
  // The three serial lines at full rate, read 1 000 times a second each,
  // for a minute: the bound of telemetry_buffer.h.
  TelemetryBuffer buffer(std::chrono::seconds(10), 0, Ms(0));
  const size_t per_read[3] = {13, 12, 12};  // ~12 800 + 11 520 + 11 520 B/s.
  std::vector<uint8_t> bytes(16, 0x42);
  for (int ms = 0; ms < 60000; ++ms) {
    for (uint8_t d = 1; d <= 3; ++d) buffer.Push(d, Ms(ms), bytes.data(), per_read[d - 1], Ms(ms));
  }
  EXPECT_LE(buffer.peak_bytes(), buffer.max_bytes() + 64 * 1024);
  EXPECT_EQ(buffer.max_bytes(), 1310720u);
  // And it still holds the last 10 s (the age bound, not the byte bound, binds).
  size_t kept = 0;
  Time oldest = Ms(60000);
  buffer.CollectFrom(0, [&](const TelemetryBuffer::Piece& p) {
    ++kept;
    oldest = std::min(oldest, p.receive_time);
  });
  EXPECT_LE(oldest, Ms(50000));
  EXPECT_GE(kept, 30000u);
}

}  // namespace
}  // namespace hardware
}  // namespace sweepscan
