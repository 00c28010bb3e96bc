// The MCAP reader's log-time order on files built here record by record:
// chains of chunks each overlapping the next by a little (log-time jitter,
// or a converter putting header stamps in log_time), which must be merged
// holding only the chunks that overlap, and a torn tail in such a file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include "core/io/ros2/mcap.h"

namespace sweepscan::io {
namespace {

using Bytes = std::vector<uint8_t>;

template <typename T>
void Put(Bytes* b, T v) {
  const auto* p = reinterpret_cast<const uint8_t*>(&v);
  b->insert(b->end(), p, p + sizeof(v));
}
void PutString(Bytes* b, const std::string& s) {
  Put(b, static_cast<uint32_t>(s.size()));
  b->insert(b->end(), s.begin(), s.end());
}
void PutRecord(Bytes* b, uint8_t op, const Bytes& content) {
  b->push_back(op);
  Put(b, static_cast<uint64_t>(content.size()));
  b->insert(b->end(), content.begin(), content.end());
}

// A Message record on channel 1 with no payload: the reader hands it to
// the sink's OnUndecodable with its log time (an Imu needs bytes).
Bytes MessageRecord(int64_t log_ns) {
  Bytes m, r;
  Put(&m, uint16_t{1});
  Put(&m, uint32_t{0});
  Put(&m, log_ns);
  Put(&m, log_ns);
  PutRecord(&r, 0x05, m);
  return r;
}

// An uncompressed Chunk record with CRC 0 (not checked) holding `records`.
Bytes ChunkRecord(int64_t start, int64_t end, const Bytes& records) {
  Bytes c, r;
  Put(&c, start);
  Put(&c, end);
  Put(&c, static_cast<uint64_t>(records.size()));
  Put(&c, uint32_t{0});
  PutString(&c, "");
  Put(&c, static_cast<uint64_t>(records.size()));
  c.insert(c.end(), records.begin(), records.end());
  PutRecord(&r, 0x06, c);
  return r;
}

// Magic, Header, the /imu Schema and Channel: a file without its end.
Bytes Start() {
  Bytes b = {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'}, h, s, c;
  PutString(&h, "ros2");
  PutString(&h, "sweepscan test");
  PutRecord(&b, 0x01, h);
  Put(&s, uint16_t{1});
  PutString(&s, "sensor_msgs/msg/Imu");
  PutString(&s, "ros2msg");
  PutString(&s, "");
  PutRecord(&b, 0x03, s);
  Put(&c, uint16_t{1});
  Put(&c, uint16_t{1});
  PutString(&c, "/imu");
  PutString(&c, "cdr");
  Put(&c, uint32_t{0});  // metadata: an empty map
  PutRecord(&b, 0x04, c);
  return b;
}

// Data End, Footer without a summary, closing magic.
void Finish(Bytes* b) {
  Bytes d, f;
  Put(&d, uint32_t{0});
  PutRecord(b, 0x0F, d);
  Put(&f, uint64_t{0});
  Put(&f, uint64_t{0});
  Put(&f, uint32_t{0});
  PutRecord(b, 0x02, f);
  b->insert(b->end(), {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'});
}

class LogTimeSink : public RosMessageSink {
 public:
  bool OnLaserScan(const RosMessageInfo&, const RosLaserScan&) override { return true; }
  bool OnOdometry(const RosMessageInfo&, const RosOdometry&) override { return true; }
  bool OnImu(const RosMessageInfo&, const RosImu&) override { return true; }
  bool OnTf(const RosMessageInfo&, const RosTfMessage&) override { return true; }
  void OnUndecodable(const RosMessageInfo& info, const std::string&) override {
    times.push_back(info.log_time_ns);
  }
  std::vector<int64_t> times;
};

constexpr int kChunks = 40, kPerChunk = 10;
constexpr int64_t kStepNs = 100'000'000;  // one chunk per 100 ms

// Chunk i: messages every 10 ms from i * 100 ms, its last one 5 ms into
// chunk i + 1's span. Every chunk overlaps the next, so the whole file is
// one chain of overlapping chunks. Returns the log times in file order.
std::vector<int64_t> AddChain(Bytes* b, int chunks) {
  std::vector<int64_t> times;
  for (int i = 0; i < chunks; ++i) {
    Bytes records;
    const int64_t start = int64_t{i} * kStepNs;
    for (int k = 0; k < kPerChunk; ++k) {
      const int64_t t = start + (k + 1 == kPerChunk ? kStepNs + 5'000'000 : k * 10'000'000);
      const Bytes m = MessageRecord(t);
      records.insert(records.end(), m.begin(), m.end());
      times.push_back(t);
    }
    const Bytes chunk = ChunkRecord(start, start + kStepNs + 5'000'000, records);
    b->insert(b->end(), chunk.begin(), chunk.end());
  }
  return times;
}

// The first two chunks swapped in the file, so that the reader sees the
// chunks out of log-time order and merges them.
Bytes OverlappingChain(std::vector<int64_t>* times, int chunks = kChunks) {
  Bytes first = Start();
  const size_t head = first.size();
  *times = AddChain(&first, chunks);
  Bytes b(first.begin(), first.begin() + static_cast<std::ptrdiff_t>(head));
  // Each chunk here has the same length: swap chunks 0 and 1 byte for byte.
  const size_t len = (first.size() - head) / static_cast<size_t>(chunks);
  b.insert(b.end(), first.begin() + static_cast<std::ptrdiff_t>(head + len),
           first.begin() + static_cast<std::ptrdiff_t>(head + 2 * len));
  b.insert(b.end(), first.begin() + static_cast<std::ptrdiff_t>(head),
           first.begin() + static_cast<std::ptrdiff_t>(head + len));
  b.insert(b.end(), first.begin() + static_cast<std::ptrdiff_t>(head + 2 * len), first.end());
  std::sort(times->begin(), times->end());
  return b;
}

// A chain of chunks each overlapping the next by 5 ms used to be read as
// one group: every chunk decompressed and every message queued before the
// first was handed on (the whole file in memory), and cancel unseen until
// the end. Merged, at most the two chunks overlapping an instant are held.
TEST(McapOrderTest, AChainOfOverlappingChunksIsMergedHoldingFewChunks) {
  std::vector<int64_t> expected;
  Bytes b = OverlappingChain(&expected);
  Finish(&b);
  LogTimeSink sink;
  Ros2ReadReport report;
  const Status s =
      ReadMcapFromMemory(b.data(), b.size(), RosReadOptions(), &sink, nullptr, nullptr, &report);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(sink.times, expected);
  EXPECT_TRUE(report.warnings.empty()) << report.warnings[0];
  EXPECT_GE(report.peak_chunks_held, 2u);
  EXPECT_LE(report.peak_chunks_held, 3u);
  EXPECT_LE(report.peak_messages_held, uint64_t{3 * kPerChunk});
}

// Cancel is seen per chunk: stopping as the second pass begins hands on
// (almost) nothing, not the whole chain.
TEST(McapOrderTest, CancelIsSeenWithinAChainOfOverlappingChunks) {
  std::vector<int64_t> expected;
  Bytes b = OverlappingChain(&expected);
  Finish(&b);
  LogTimeSink sink;
  RosReadOptions opt;
  opt.progress = [](double f) { return f <= 0.5; };  // the first pass, then stop
  const Status s = ReadMcapFromMemory(b.data(), b.size(), opt, &sink, nullptr, nullptr, nullptr);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("cancelled"), std::string::npos) << s.message();
  EXPECT_LT(sink.times.size(), size_t{2 * kPerChunk});
}

// An unfinished file (no Footer) out of log-time order whose last chunk
// (CRC 0, so it loads) has its records cut after three messages, then only
// zeros: the first pass calls it a torn tail and keeps those three; the
// second must hand on the same messages and end there, not fail on the
// damage the first pass forgave.
TEST(McapOrderTest, ATornLastChunkIsForgivenByBothPasses) {
  std::vector<int64_t> expected;
  Bytes b = OverlappingChain(&expected, 6);
  Bytes records;
  const int64_t start = 6 * kStepNs;  // overlaps the chain's last chunk
  for (int k = 0; k < 3; ++k) {
    const Bytes m = MessageRecord(start + k * 10'000'000);
    records.insert(records.end(), m.begin(), m.end());
    expected.push_back(start + k * 10'000'000);
  }
  records.push_back(0x05);  // a Message record claiming 100 bytes, 20 written
  Put(&records, uint64_t{100});
  records.insert(records.end(), 20, 0);
  const Bytes chunk = ChunkRecord(start, start + 90'000'000, records);
  b.insert(b.end(), chunk.begin(), chunk.end());
  b.insert(b.end(), 4096, 0);
  std::sort(expected.begin(), expected.end());
  LogTimeSink sink;
  Ros2ReadReport report;
  const Status s =
      ReadMcapFromMemory(b.data(), b.size(), RosReadOptions(), &sink, nullptr, nullptr, &report);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_TRUE(report.torn_tail);
  EXPECT_EQ(sink.times, expected);
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_NE(report.warnings[0].find("the " + std::to_string(expected.size()) + " messages"),
            std::string::npos)
      << report.warnings[0];
}

}  // namespace
}  // namespace sweepscan::io
