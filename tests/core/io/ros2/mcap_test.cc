// The MCAP reader against files written by @mcap/core's McapWriter
// (tests/data/ros2/, make_ros2_bags.mjs): zstd chunks with a full summary
// section, lz4 chunks without any summary, messages outside chunks; and
// damaged copies of them (truncations, flipped bytes, patched fields).
#include "core/io/ros2/mcap.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "tests/core/io/ros2/ros2_test_bags.h"

namespace sweepscan::io {
namespace {

using testing::kBaseNs;
using testing::kLatencyNs;
using testing::McapRecord;
using testing::McapRecords;
using testing::ReadBytes;
using testing::RecordingSink;
using testing::Ros2Data;

const char* const kFiles[] = {"ros2_zstd.mcap", "ros2_lz4_nosummary.mcap", "ros2_unchunked.mcap"};
constexpr uint64_t kDecodable = testing::kMessages - testing::kChatters;  // 46

size_t First(const std::vector<uint8_t>& b, uint8_t op) {
  for (const McapRecord& r : McapRecords(b)) {
    if (r.op == op) return r.pos;
  }
  ADD_FAILURE() << "no record 0x" << std::hex << int{op};
  return 0;
}

Status ReadMemory(const std::vector<uint8_t>& b, RecordingSink* sink, RosReadStats* stats,
                  Ros2ReadReport* report, RosBagSummary* summary = nullptr) {
  return ReadMcapFromMemory(b.data(), b.size(), RosReadOptions(), sink, summary, stats, report);
}

TEST(McapTest, ReadsEveryFileFieldForField) {
  for (const char* name : kFiles) {
    SCOPED_TRACE(name);
    RecordingSink sink;
    RosReadStats stats;
    RosBagSummary summary;
    Ros2ReadReport report;
    Status s = ReadMcap(Ros2Data(name), RosReadOptions(), &sink, &summary, &stats, &report);
    ASSERT_TRUE(s.ok()) << s.message();
    testing::ExpectAllKnownMessages(sink);
    EXPECT_EQ(stats.messages_read, kDecodable);
    EXPECT_EQ(stats.messages_skipped, uint64_t{testing::kChatters});
    EXPECT_EQ(stats.messages_undecodable, 0u);
    EXPECT_EQ(stats.bytes_read, ReadBytes(Ros2Data(name)).size());
    EXPECT_TRUE(report.warnings.empty()) << report.warnings[0];
    EXPECT_FALSE(report.torn_tail);
    EXPECT_EQ(summary.message_count, uint64_t{testing::kMessages});
    ASSERT_EQ(summary.topics.size(), 6u);
    EXPECT_EQ(summary.topics[3].topic, "/scan");
    EXPECT_EQ(summary.topics[3].first_ns, kBaseNs + kLatencyNs);
  }
}

TEST(McapTest, SummaryFromTheSummarySectionAndFromAScan) {
  for (const char* name : kFiles) {
    SCOPED_TRACE(name);
    RosBagSummary s;
    Ros2ReadReport report;
    Status st = SummarizeMcap(Ros2Data(name), &s, &report);
    ASSERT_TRUE(st.ok()) << st.message();
    EXPECT_TRUE(report.warnings.empty());
    EXPECT_EQ(s.format, "mcap");
    EXPECT_EQ(s.file_bytes, ReadBytes(Ros2Data(name)).size());
    EXPECT_EQ(s.message_count, uint64_t{testing::kMessages});
    EXPECT_EQ(s.start_ns, testing::kTfStaticLogNs);
    EXPECT_EQ(s.end_ns, testing::ScanStampNs(19) + kLatencyNs);
    const std::string file(name);
    EXPECT_EQ(s.compression, file == "ros2_zstd.mcap"            ? "zstd"
                             : file == "ros2_lz4_nosummary.mcap" ? "lz4"
                                                                 : "none");
    const std::vector<std::pair<std::string, uint64_t>> expected = {
        {"/chatter", 3}, {"/imu", 10}, {"/odom", 10}, {"/scan", 20}, {"/tf", 5}, {"/tf_static", 1}};
    ASSERT_EQ(s.topics.size(), expected.size());
    for (size_t i = 0; i < expected.size(); ++i) {
      EXPECT_EQ(s.topics[i].topic, expected[i].first);
      EXPECT_EQ(s.topics[i].message_count, expected[i].second);
      EXPECT_EQ(s.topics[i].serialization, "cdr");
    }
    EXPECT_EQ(s.topics[3].type, "sensor_msgs/msg/LaserScan");
    EXPECT_EQ(s.topics[3].kind(), RosMessageKind::kLaserScan);
    EXPECT_EQ(s.topics[0].kind(), RosMessageKind::kOther);
    if (file == "ros2_lz4_nosummary.mcap") {  // scanned: per-topic times known
      EXPECT_EQ(s.topics[2].first_ns, testing::OdomStampNs(0) + kLatencyNs);
      EXPECT_EQ(s.topics[2].last_ns, testing::OdomStampNs(9) + kLatencyNs);
    }
  }
}

TEST(McapTest, TopicFilterCancelAndProgress) {
  RecordingSink sink;
  RosReadStats stats;
  RosReadOptions opt;
  opt.topics = {"/odom", "/tf_static"};
  std::vector<double> progress;
  opt.progress = [&](double f) {
    progress.push_back(f);
    return true;
  };
  Status s = ReadMcap(Ros2Data("ros2_zstd.mcap"), opt, &sink, nullptr, &stats);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(sink.odoms.size(), 10u);
  EXPECT_EQ(sink.tf_static.size(), 1u);
  EXPECT_TRUE(sink.scans.empty());
  EXPECT_EQ(stats.messages_read, 11u);
  EXPECT_EQ(stats.messages_skipped, uint64_t{testing::kMessages} - 11);
  ASSERT_FALSE(progress.empty());
  EXPECT_EQ(progress.back(), 1.0);

  RecordingSink stopper;
  stopper.stop_after = 5;
  s = ReadMcap(Ros2Data("ros2_lz4_nosummary.mcap"), RosReadOptions(), &stopper, nullptr, nullptr);
  EXPECT_EQ(s.message(), Ros2Data("ros2_lz4_nosummary.mcap") + ": cancelled");
  EXPECT_EQ(stopper.order.size(), 5u);

  opt.progress = [](double) { return false; };
  s = ReadMcap(Ros2Data("ros2_zstd.mcap"), opt, &sink, nullptr, nullptr);
  EXPECT_EQ(s.message(), Ros2Data("ros2_zstd.mcap") + ": cancelled");
}

// The desktop app's Cancel of a bag's summary: a file read whole for it
// (no summary section) reports its progress and stops when told; one with a
// summary section is summarised from it, without a scan to follow.
TEST(McapTest, ASummaryScanReportsProgressAndCancels) {
  const std::string scanned = Ros2Data("ros2_lz4_nosummary.mcap");
  std::vector<double> fractions;
  const auto follow = [&](double f) {
    fractions.push_back(f);
    return true;
  };
  RosBagSummary s;
  ASSERT_TRUE(SummarizeMcap(scanned, &s, nullptr, follow).ok());
  EXPECT_EQ(s.message_count, uint64_t{testing::kMessages});
  ASSERT_FALSE(fractions.empty());
  EXPECT_EQ(fractions.back(), 1.0);
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));

  size_t calls = 0;
  const Status st = SummarizeMcap(scanned, &s, nullptr, [&](double) { return ++calls, false; });
  EXPECT_EQ(st.message(), scanned + ": cancelled");
  EXPECT_EQ(calls, 1u);

  fractions.clear();
  ASSERT_TRUE(SummarizeMcap(Ros2Data("ros2_zstd.mcap"), &s, nullptr, follow).ok());
  EXPECT_TRUE(fractions.empty());
}

// A recording killed mid-write: whatever was complete is read, the tear is a
// warning with its byte offset, never an error or a crash.
TEST(McapTest, TruncatedFilesKeepTheMessagesBeforeTheTear) {
  for (const char* name : kFiles) {
    SCOPED_TRACE(name);
    const std::vector<uint8_t> full = ReadBytes(Ros2Data(name));
    RecordingSink all;
    ASSERT_TRUE(ReadMemory(full, &all, nullptr, nullptr).ok());
    size_t data_end = 0;
    for (const McapRecord& r : McapRecords(full)) {
      if (r.op == 0x0F) data_end = r.pos;
    }
    std::vector<size_t> cuts = {0,
                                5,
                                8,
                                12,
                                16,
                                17,
                                30,
                                full.size() / 3,
                                full.size() / 2,
                                data_end - 1,
                                data_end,
                                data_end + 5,
                                data_end + 13,
                                full.size() - 1};
    for (size_t c = 40; c < full.size(); c += 997) cuts.push_back(c);
    for (size_t cut : cuts) {
      const std::vector<uint8_t> part(full.begin(), full.begin() + cut);
      RecordingSink sink;
      Ros2ReadReport report;
      RosReadStats stats;
      Status s = ReadMemory(part, &sink, &stats, &report);
      if (cut < 8) {
        EXPECT_EQ(s.message(),
                  "<memory>: not an MCAP file (no MCAP magic \\x89MCAP0\\r\\n at byte 0)");
        continue;
      }
      ASSERT_TRUE(s.ok()) << cut << ": " << s.message();
      // What was read is the start of the full sequence, message for message.
      ASSERT_LE(sink.order.size(), all.order.size());
      for (size_t i = 0; i < sink.order.size(); ++i) {
        EXPECT_EQ(sink.order[i].log_time_ns, all.order[i].log_time_ns);
      }
      for (size_t k = 0; k < sink.scans.size(); ++k) {
        testing::ExpectScan(sink.scans[k], testing::ExpectedScan(static_cast<int>(k)));
      }
      if (cut >= data_end + 9 + 4) {
        EXPECT_FALSE(report.torn_tail) << cut;  // the Data End record is complete
        EXPECT_EQ(sink.order.size(), all.order.size());
        continue;
      }
      EXPECT_TRUE(report.torn_tail) << cut;
      ASSERT_EQ(report.warnings.size(), 1u);
      EXPECT_EQ(report.warnings[0].rfind("<memory>: file ends at byte " + std::to_string(cut), 0),
                0u)
          << report.warnings[0];
    }
  }
  // The same through a file: the path and the record are named.
  const std::vector<uint8_t> full = ReadBytes(Ros2Data("ros2_zstd.mcap"));
  const size_t chunk = First(full, 0x06);
  const std::string path = ::testing::TempDir() + "/torn.mcap";
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(full.data()),
              static_cast<std::streamsize>(chunk + 100));
  }
  RecordingSink sink;
  Ros2ReadReport report;
  ASSERT_TRUE(ReadMcap(path, RosReadOptions(), &sink, nullptr, nullptr, &report).ok());
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_NE(report.warnings[0].find(path + ": file ends at byte " + std::to_string(chunk + 100) +
                                    " inside the Chunk record at byte " + std::to_string(chunk)),
            std::string::npos)
      << report.warnings[0];
  RosBagSummary summary;
  ASSERT_TRUE(SummarizeMcap(path, &summary, &report).ok());  // no footer: scanned
  EXPECT_EQ(summary.message_count, 0u);
  unlink(path.c_str());
}

TEST(McapTest, FlippedBytesNeverCrash) {
  for (const char* name : kFiles) {
    const std::vector<uint8_t> full = ReadBytes(Ros2Data(name));
    for (size_t at = 0; at < full.size(); at += 3) {
      std::vector<uint8_t> b = full;
      b[at] ^= static_cast<uint8_t>(0x5A + at);
      RecordingSink sink;
      RosReadStats stats;
      Ros2ReadReport report;
      Status s = ReadMemory(b, &sink, &stats, &report);
      EXPECT_LE(stats.messages_read + stats.messages_undecodable, kDecodable);
      if (!s.ok()) {
        EXPECT_EQ(s.message().rfind("<memory>: ", 0), 0u) << s.message();
      }
      RosBagSummary summary;
      SummarizeMcapFromMemory(b.data(), b.size(), &summary, &report);
    }
  }
}

TEST(McapTest, UnknownCompressionIsNamed) {
  const std::vector<uint8_t> full = ReadBytes(Ros2Data("ros2_zstd.mcap"));
  const size_t chunk = First(full, 0x06);
  // Rewrite the chunk's compression "zstd" as "brotli" (two bytes longer).
  std::vector<uint8_t> b(full.begin(), full.begin() + chunk);
  uint64_t len;
  memcpy(&len, full.data() + chunk + 1, 8);
  const size_t compression_at = chunk + 9 + 28;
  uint32_t compression_len;
  memcpy(&compression_len, full.data() + compression_at, 4);
  ASSERT_EQ(compression_len, 4u);
  ASSERT_EQ(memcmp(full.data() + compression_at + 4, "zstd", 4), 0);
  len += 2;
  b.push_back(0x06);
  b.insert(b.end(), reinterpret_cast<uint8_t*>(&len), reinterpret_cast<uint8_t*>(&len) + 8);
  b.insert(b.end(), full.begin() + chunk + 9, full.begin() + compression_at);
  const uint32_t six = 6;
  b.insert(b.end(), reinterpret_cast<const uint8_t*>(&six),
           reinterpret_cast<const uint8_t*>(&six) + 4);
  for (char c : std::string("brotli")) b.push_back(static_cast<uint8_t>(c));
  b.insert(b.end(), full.begin() + compression_at + 8, full.end());
  RecordingSink sink;
  Status s = ReadMemory(b, &sink, nullptr, nullptr);
  EXPECT_EQ(s.message(),
            "<memory>: chunk at byte " + std::to_string(chunk) + ": unknown compression 'brotli'");
}

TEST(McapTest, BadChunkCrcIsAnError) {
  std::vector<uint8_t> b = ReadBytes(Ros2Data("ros2_lz4_nosummary.mcap"));
  const size_t chunk = First(b, 0x06);
  uint32_t crc;
  memcpy(&crc, b.data() + chunk + 9 + 24, 4);
  ASSERT_NE(crc, 0u);
  b[chunk + 9 + 24] ^= 1;
  RecordingSink sink;
  Status s = ReadMemory(b, &sink, nullptr, nullptr);
  char expected[160];
  snprintf(expected, sizeof(expected),
           "<memory>: chunk at byte %zu: CRC-32 of the uncompressed records is 0x%08x, the chunk "
           "says 0x%08x",
           chunk, crc, crc ^ 1u);
  EXPECT_EQ(s.message(), expected);
  // A CRC of zero means "not computed": accepted.
  memset(b.data() + chunk + 9 + 24, 0, 4);
  EXPECT_TRUE(ReadMemory(b, &sink, nullptr, nullptr).ok());
}

TEST(McapTest, MessageOnUnknownChannelIsAnError) {
  std::vector<uint8_t> b = ReadBytes(Ros2Data("ros2_unchunked.mcap"));
  const size_t message = First(b, 0x05);
  b[message + 9] = 99;
  b[message + 10] = 0;
  RecordingSink sink;
  Status s = ReadMemory(b, &sink, nullptr, nullptr);
  EXPECT_EQ(s.message(), "<memory>: Message at byte " + std::to_string(message) +
                             ": message on unknown channel 99 (no earlier Channel record "
                             "defines it)");
}

TEST(McapTest, AbsurdChunkSizesAreRefusedBeforeAllocating) {
  std::vector<uint8_t> b = ReadBytes(Ros2Data("ros2_zstd.mcap"));
  const size_t chunk = First(b, 0x06);
  const uint64_t huge = uint64_t{1} << 40;
  memcpy(b.data() + chunk + 9 + 16, &huge, 8);
  Status s = ReadMemory(b, nullptr, nullptr, nullptr);
  EXPECT_EQ(s.message(), "<memory>: chunk at byte " + std::to_string(chunk) +
                             ": uncompressed_size 1099511627776 is more than the 1073741824 "
                             "bytes accepted");
  // A chunk that says it is smaller than its data decompresses to.
  b = ReadBytes(Ros2Data("ros2_lz4_nosummary.mcap"));
  const size_t lz4_chunk = First(b, 0x06);
  const uint64_t small = 100;
  memcpy(b.data() + lz4_chunk + 9 + 16, &small, 8);
  RecordingSink sink;
  s = ReadMemory(b, &sink, nullptr, nullptr);
  EXPECT_EQ(s.message(), "<memory>: chunk at byte " + std::to_string(lz4_chunk) +
                             ": lz4: decompresses to more than the 100 bytes the chunk says");
}

// A file that ends in its Footer and closing magic was written whole: a
// record whose length overruns it is damage, refused with where, not a
// torn tail whose later messages would vanish without a word.
TEST(McapTest, ACorruptLengthInACompleteFileIsRefusedNotReadAsATornTail) {
  for (const char* name : {"ros2_zstd.mcap", "ros2_lz4_nosummary.mcap"}) {
    SCOPED_TRACE(name);
    std::vector<uint8_t> b = ReadBytes(Ros2Data(name));
    const size_t chunk = First(b, 0x06);
    uint64_t len;
    memcpy(&len, b.data() + chunk + 1, 8);
    len += uint64_t{1} << 40;
    memcpy(b.data() + chunk + 1, &len, 8);
    RecordingSink sink;
    Ros2ReadReport report;
    const Status s = ReadMemory(b, &sink, nullptr, &report);
    EXPECT_EQ(s.message().rfind("<memory>: Chunk at byte " + std::to_string(chunk) + " claims", 0),
              0u)
        << s.message();
    EXPECT_NE(s.message().find("the record's length is corrupt (not a file cut short)"),
              std::string::npos)
        << s.message();
    EXPECT_FALSE(report.torn_tail);
  }
}

// A compressed chunk that holds bytes but says it decompresses to none
// (uncompressed_size and CRC zeroed) is refused, not taken as empty.
TEST(McapTest, ACompressedChunkSayingItIsEmptyIsRefused) {
  std::vector<uint8_t> b = ReadBytes(Ros2Data("ros2_lz4_nosummary.mcap"));
  const size_t chunk = First(b, 0x06);
  memset(b.data() + chunk + 9 + 16, 0, 12);  // uncompressed_size u64, uncompressed_crc u32
  RecordingSink sink;
  const Status s = ReadMemory(b, &sink, nullptr, nullptr);
  EXPECT_EQ(s.message(), "<memory>: chunk at byte " + std::to_string(chunk) +
                             ": lz4: decompresses to more than the 0 bytes the chunk says");
}

// A Schema whose length says 17 MiB (inside a file that has them) is
// refused before it is read into memory.
TEST(McapTest, AnAbsurdSchemaLengthIsRefusedBeforeAllocating) {
  std::vector<uint8_t> b = ReadBytes(Ros2Data("ros2_unchunked.mcap"));
  const size_t schema = First(b, 0x03);
  std::vector<uint8_t> big(b.begin(), b.begin() + static_cast<std::ptrdiff_t>(schema));
  const uint64_t len = uint64_t{17} << 20;
  big.push_back(0x03);
  big.insert(big.end(), reinterpret_cast<const uint8_t*>(&len),
             reinterpret_cast<const uint8_t*>(&len) + 8);
  big.resize(big.size() + len + 64, 0);  // no Footer: a torn file, the length fits in it
  const Status s = ReadMemory(big, nullptr, nullptr, nullptr);
  EXPECT_EQ(s.message(), "<memory>: Schema at byte " + std::to_string(schema) +
                             " claims 17825792 bytes, more than the 16777216 accepted");
}

TEST(McapTest, BrokenSummaryFallsBackToAScan) {
  std::vector<uint8_t> b = ReadBytes(Ros2Data("ros2_zstd.mcap"));
  size_t statistics = 0;
  for (const McapRecord& r : McapRecords(b)) {
    if (r.op == 0x0B) statistics = r.pos;
  }
  ASSERT_NE(statistics, 0u);
  b[statistics + 9] ^= 0x40;  // message_count: the summary CRC no longer matches
  RosBagSummary s;
  Ros2ReadReport report;
  ASSERT_TRUE(SummarizeMcapFromMemory(b.data(), b.size(), &s, &report).ok());
  EXPECT_EQ(s.message_count, uint64_t{testing::kMessages});
  EXPECT_EQ(s.topics[3].first_ns, kBaseNs + kLatencyNs);  // scanned
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_EQ(report.warnings[0],
            "<memory>: summary section's CRC-32 does not match the footer's; scanning the file "
            "instead");
}

TEST(McapTest, NotAnMcapFile) {
  RosBagSummary s;
  Status st = SummarizeMcap(Ros2Data("sqlite_bag/sqlite_bag_0.db3"), &s);
  EXPECT_EQ(st.message(), Ros2Data("sqlite_bag/sqlite_bag_0.db3") +
                              ": not an MCAP file (no MCAP magic \\x89MCAP0\\r\\n at byte 0)");
  st = SummarizeMcap(Ros2Data("no_such.mcap"), &s);
  EXPECT_EQ(st.message(),
            Ros2Data("no_such.mcap") + ": cannot open for reading: No such file or directory");
  st = SummarizeMcap(Ros2Data("mcap_bag"), &s);
  EXPECT_EQ(st.message(), Ros2Data("mcap_bag") + ": is a folder");
}

TEST(McapTest, Crc32IsZlibs) {
  const char* text = "123456789";
  EXPECT_EQ(McapCrc32(reinterpret_cast<const uint8_t*>(text), 9), 0xCBF43926u);
  EXPECT_EQ(McapCrc32(reinterpret_cast<const uint8_t*>(text) + 4, 5,
                      McapCrc32(reinterpret_cast<const uint8_t*>(text), 4)),
            0xCBF43926u);
}

}  // namespace
}  // namespace sweepscan::io
