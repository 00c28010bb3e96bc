// The MCAP reader on what crashed recorders and other legitimate writers
// leave, made from the files @mcap/core's McapWriter wrote
// (tests/data/ros2/, make_ros2_bags.mjs): an unfinished file (no Footer)
// whose last record is zeros or a chunk written only in part, chunks out
// of log-time order, a summary section without its channels.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>

#include "core/io/ros2/mcap.h"
#include "tests/core/io/ros2/ros2_test_bags.h"

namespace sweepscan::io {
namespace {

using testing::McapRecord;
using testing::McapRecords;
using testing::ReadBytes;
using testing::RecordingSink;
using testing::Ros2Data;

Status ReadMemory(const std::vector<uint8_t>& b, RecordingSink* sink, Ros2ReadReport* report) {
  return ReadMcapFromMemory(b.data(), b.size(), RosReadOptions(), sink, nullptr, nullptr, report);
}

std::vector<int64_t> LogTimes(const RecordingSink& sink) {
  std::vector<int64_t> t;
  for (const auto& m : sink.order) t.push_back(m.log_time_ns);
  return t;
}

// The file as a recorder leaves it before it closes: everything before the
// Data End record (no summary, no Footer).
std::vector<uint8_t> Unfinished(const std::vector<uint8_t>& full, size_t* data_end) {
  for (const McapRecord& r : McapRecords(full)) {
    if (r.op == 0x0F) *data_end = r.pos;
  }
  return std::vector<uint8_t>(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(*data_end));
}

// Power lost while recording: the file's last blocks were allocated but not
// written, and read as zeros. Every message before them is kept.
TEST(McapRecoveryTest, AnUnfinishedFileEndingInZerosIsATornTail) {
  for (const char* name : {"ros2_zstd.mcap", "ros2_lz4_nosummary.mcap", "ros2_unchunked.mcap"}) {
    SCOPED_TRACE(name);
    const std::vector<uint8_t> full = ReadBytes(Ros2Data(name));
    RecordingSink all;
    ASSERT_TRUE(ReadMemory(full, &all, nullptr).ok());
    size_t data_end = 0;
    std::vector<uint8_t> b = Unfinished(full, &data_end);
    b.resize(b.size() + 8192, 0);
    RecordingSink sink;
    Ros2ReadReport report;
    const Status s = ReadMemory(b, &sink, &report);
    ASSERT_TRUE(s.ok()) << s.message();
    EXPECT_EQ(LogTimes(sink), LogTimes(all));
    EXPECT_TRUE(report.torn_tail);
    ASSERT_EQ(report.warnings.size(), 1u);
    EXPECT_EQ(report.warnings[0].rfind("<memory>: file ends at byte " + std::to_string(b.size()) +
                                           " at opcode 0x00 at byte " + std::to_string(data_end) +
                                           " (zero bytes to the end of the file)",
                                       0),
              0u)
        << report.warnings[0];
    RosBagSummary summary;
    ASSERT_TRUE(SummarizeMcapFromMemory(b.data(), b.size(), &summary).ok());
    EXPECT_EQ(summary.message_count, uint64_t{testing::kMessages});
  }
}

// The last chunk written in part, the rest of its length zeros (its
// compressed bytes end early, or its CRC does not match): the messages of
// the chunks before it are read, and the warning names the chunk. The same
// damage in a complete file (Footer and magic at its end), or followed by
// more data, stays an error.
TEST(McapRecoveryTest, AnUnfinishedFileWhoseLastChunkIsDamagedKeepsTheChunksBefore) {
  for (const char* name : {"ros2_zstd.mcap", "ros2_lz4_nosummary.mcap"}) {
    SCOPED_TRACE(name);
    const std::vector<uint8_t> full = ReadBytes(Ros2Data(name));
    size_t data_end = 0;
    const std::vector<uint8_t> unfinished = Unfinished(full, &data_end);
    McapRecord last{};
    for (const McapRecord& r : McapRecords(unfinished)) {
      if (r.op == 0x06 && r.pos + 9 + r.len <= unfinished.size()) last = r;
    }
    ASSERT_EQ(last.op, 0x06);
    // The messages of the chunks before the last one, as the whole file has them.
    std::vector<uint8_t> before(unfinished.begin(),
                                unfinished.begin() + static_cast<std::ptrdiff_t>(last.pos));
    RecordingSink expected;
    Ros2ReadReport ignored;
    ASSERT_TRUE(ReadMemory(before, &expected, &ignored).ok());
    ASSERT_GT(expected.order.size(), 10u);

    // Half its records written, the rest of its length zeros, then more zeros.
    std::vector<uint8_t> b(unfinished.begin(), unfinished.begin() + static_cast<std::ptrdiff_t>(
                                                                        last.pos + 9 + last.len));
    std::fill(b.begin() + static_cast<std::ptrdiff_t>(last.pos + 9 + last.len / 2), b.end(), 0);
    b.resize(b.size() + 4096, 0);
    RecordingSink sink;
    Ros2ReadReport report;
    Status s = ReadMemory(b, &sink, &report);
    ASSERT_TRUE(s.ok()) << s.message();
    EXPECT_EQ(LogTimes(sink), LogTimes(expected));
    EXPECT_TRUE(report.torn_tail);
    ASSERT_EQ(report.warnings.size(), 1u);
    const std::string where =
        "its last record (Chunk at byte " + std::to_string(last.pos) + ") damaged";
    EXPECT_NE(report.warnings[0].find(where), std::string::npos) << report.warnings[0];
    RosBagSummary summary;
    ASSERT_TRUE(SummarizeMcapFromMemory(b.data(), b.size(), &summary).ok());

    // Followed by data that is not zeros: damage, as in a complete file.
    std::vector<uint8_t> more = b;
    more.back() = 1;
    EXPECT_FALSE(ReadMemory(more, &sink, &report).ok());
    // The same chunk damage in a complete file: an error.
    std::vector<uint8_t> complete = full;
    std::fill(complete.begin() + static_cast<std::ptrdiff_t>(last.pos + 9 + last.len / 2),
              complete.begin() + static_cast<std::ptrdiff_t>(last.pos + 9 + last.len), 0);
    s = ReadMemory(complete, &sink, &report);
    EXPECT_EQ(s.message().rfind("<memory>: chunk at byte " + std::to_string(last.pos) + ": ", 0),
              0u)
        << s.message();
  }
}

// Chunks need not be in log-time order (the spec; readers use the chunks'
// times): two chunks swapped in the file still give the messages in
// log-time order, without a warning.
TEST(McapRecoveryTest, ChunksOutOfLogTimeOrderAreReadInLogTimeOrder) {
  const std::vector<uint8_t> full = ReadBytes(Ros2Data("ros2_lz4_nosummary.mcap"));
  RecordingSink all;
  ASSERT_TRUE(ReadMemory(full, &all, nullptr).ok());
  std::vector<McapRecord> chunks;
  for (const McapRecord& r : McapRecords(full)) {
    if (r.op == 0x06) chunks.push_back(r);
  }
  // Chunks 6 and 7 hold no channel's first message (each channel is
  // defined before its first message, in the file as in time).
  ASSERT_GT(chunks.size(), 8u);
  const McapRecord a = chunks[6], c = chunks[7];
  ASSERT_EQ(a.pos + 9 + a.len, c.pos);
  std::vector<uint8_t> b(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(a.pos));
  b.insert(b.end(), full.begin() + static_cast<std::ptrdiff_t>(c.pos),
           full.begin() + static_cast<std::ptrdiff_t>(c.pos + 9 + c.len));
  b.insert(b.end(), full.begin() + static_cast<std::ptrdiff_t>(a.pos),
           full.begin() + static_cast<std::ptrdiff_t>(a.pos + 9 + a.len));
  b.insert(b.end(), full.begin() + static_cast<std::ptrdiff_t>(c.pos + 9 + c.len), full.end());
  ASSERT_EQ(b.size(), full.size());
  RecordingSink sink;
  Ros2ReadReport report;
  RosReadStats stats;
  RosBagSummary summary;
  const Status s =
      ReadMcapFromMemory(b.data(), b.size(), RosReadOptions(), &sink, &summary, &stats, &report);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(LogTimes(sink), LogTimes(all));
  EXPECT_TRUE(report.warnings.empty()) << report.warnings[0];
  testing::ExpectAllKnownMessages(sink);
  EXPECT_EQ(summary.message_count, uint64_t{testing::kMessages});
  EXPECT_EQ(stats.bytes_read, b.size());
}

// A summary section with Statistics and Chunk Indexes but without the
// Channel records repeated (a writer's repeatChannels false; the spec makes
// them optional): the file is scanned for its channels, quietly.
TEST(McapRecoveryTest, ASummaryWithoutChannelsIsNotDamage) {
  const std::vector<uint8_t> full = ReadBytes(Ros2Data("ros2_zstd.mcap"));
  std::vector<uint8_t> b;
  size_t summary_start = 0, offsets_start = 0;
  for (const McapRecord& r : McapRecords(full)) {
    if (r.op == 0x0F) summary_start = r.pos + 9 + r.len;
    if (r.op == 0x0E && offsets_start == 0) offsets_start = r.pos;
  }
  ASSERT_NE(summary_start, 0u);
  ASSERT_NE(offsets_start, 0u);
  b.assign(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(summary_start));
  for (const McapRecord& r : McapRecords(full)) {
    // The summary section less its Channels; Summary Offsets dropped too
    // (they would point at the removed group).
    if (r.pos < summary_start || r.op == 0x04 || r.op == 0x0E || r.op == 0x02) continue;
    b.insert(b.end(), full.begin() + static_cast<std::ptrdiff_t>(r.pos),
             full.begin() + static_cast<std::ptrdiff_t>(r.pos + 9 + r.len));
  }
  const uint64_t footer_len = 20, start = summary_start, zero = 0;
  b.push_back(0x02);
  for (const uint64_t v : {footer_len, start, zero}) {
    b.insert(b.end(), reinterpret_cast<const uint8_t*>(&v),
             reinterpret_cast<const uint8_t*>(&v) + 8);
  }
  b.insert(b.end(), 4, 0);  // summary_crc u32 0: not computed
  b.insert(b.end(), full.end() - 8, full.end());
  RosBagSummary s;
  Ros2ReadReport report;
  ASSERT_TRUE(SummarizeMcapFromMemory(b.data(), b.size(), &s, &report).ok());
  EXPECT_TRUE(report.warnings.empty()) << report.warnings[0];
  EXPECT_EQ(s.message_count, uint64_t{testing::kMessages});
  ASSERT_EQ(s.topics.size(), 6u);
  EXPECT_EQ(s.topics[3].topic, "/scan");
  EXPECT_EQ(s.topics[3].message_count, 20u);
}

}  // namespace
}  // namespace sweepscan::io
