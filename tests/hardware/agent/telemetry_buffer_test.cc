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
    EXPECT_EQ(t[i].flags, 0) << "read after the client was adopted: neither late nor a break";
  }
}

TEST_F(BufferingAgentTest, AClientThatNeverAsksGetsLiveTelemetryAfterTheResumeWait) {
  ConnectAndAuthenticate(Ms(1));
  ReadChunks(1, 99);  // 990 ms: still held (resume_wait 1 s from 1 ms).
  EXPECT_TRUE(h_.All<Telemetry>().empty());
  ReadChunks(100, 101);
  EXPECT_EQ(h_.All<Telemetry>().size(), 101u);
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
