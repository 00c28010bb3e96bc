// frames.bin's reading rules where damage meets the end of the file or a
// wall-clock step (docs/session-format.md, "Reading rules"): a damaged
// length that reaches the end by chance is damage, not a torn tail; damage
// at a clock step loses its own records only; damage to the end of the
// file is sized from the intact records. And a session that could not be
// begun leaves no folder behind.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "core/session/session.h"
#include "tests/testing/run_command.h"

namespace sweepscan {
namespace {

using Bytes = std::vector<uint8_t>;

// frames.bin in memory: records of the given payload sizes, record i's
// bytes all i + 1, at the given receive times. *offsets: each record's.
Bytes Frames(const std::vector<size_t>& sizes, const std::vector<int64_t>& times,
             std::vector<size_t>* offsets) {
  Bytes file = SessionFramesHeader();
  for (size_t i = 0; i < sizes.size(); ++i) {
    offsets->push_back(file.size());
    const Bytes payload(sizes[i], static_cast<uint8_t>(i + 1));
    AppendSessionRecord(payload.data(), payload.size(), times[i], &file);
  }
  return file;
}

FramesLoadOptions Skip() {
  FramesLoadOptions o;
  o.skip_corrupt_records = true;
  return o;
}

// Records of 10, 10, 16 and 16 bytes end at byte 132. Bit 6 of the second
// record's length turns 10 into 74, and 42 + 16 + 74 is 132: its CRC fails
// and it "ends" exactly at the end of the file, as a torn final record
// does. The two records it spans are intact, so it is damage: the records
// after it were dropped as a tail (in strict mode too, and cut by a writer
// reopening the session). The same with the zeros a power loss leaves.
TEST(FramesDamageTest, ADamagedLengthThatReachesTheEndIsDamageNotATornTail) {
  for (const size_t zeros : {size_t{0}, size_t{64}}) {
    SCOPED_TRACE(zeros);
    std::vector<size_t> offsets;
    Bytes file = Frames({10, 10, 16, 16}, {1000, 2000, 3000, 4000}, &offsets);
    ASSERT_EQ(file.size(), 132u);
    file.resize(file.size() + zeros, 0);
    ASSERT_EQ(file[offsets[1]], 10);
    file[offsets[1]] ^= 0x40;
    std::vector<SessionRecord> records;
    FramesLoadReport report;
    ASSERT_TRUE(
        LoadFramesFromMemory(file.data(), file.size(), "x", Skip(), &records, &report).ok());
    ASSERT_EQ(records.size(), 3u);
    EXPECT_EQ(records[0].bytes, Bytes(10, 1));
    EXPECT_EQ(records[1].bytes, Bytes(16, 3));
    EXPECT_EQ(records[2].bytes, Bytes(16, 4));
    // The zeros themselves are the power loss's tail, after the last record.
    EXPECT_EQ(report.truncated_tail, zeros > 0) << report.tail_reason;
    EXPECT_EQ(report.valid_bytes, 132u);
    ASSERT_EQ(report.damage.size(), 1u);
    EXPECT_EQ(report.damage[0].offset, offsets[1]);
    EXPECT_EQ(report.damage[0].bytes, offsets[2] - offsets[1]);
    EXPECT_EQ(report.corrupt_records_skipped, 1u);
    const Status strict =
        LoadFramesFromMemory(file.data(), file.size(), "x", FramesLoadOptions(), &records, &report);
    ASSERT_FALSE(strict.ok());
    EXPECT_NE(strict.message().find("record 1 at byte 42: CRC mismatch, and its length 74 spans an "
                                    "intact record at byte 68"),
              std::string::npos)
        << strict.message();
  }
  // A torn final record stays a torn tail: the last record cut short.
  std::vector<size_t> offsets;
  Bytes file = Frames({10, 10, 16, 16}, {1000, 2000, 3000, 4000}, &offsets);
  file[file.size() - 6] ^= 0xFF;  // The last record's payload: its page never written.
  std::vector<SessionRecord> records;
  FramesLoadReport report;
  ASSERT_TRUE(
      LoadFramesFromMemory(file.data(), file.size(), "x", FramesLoadOptions(), &records, &report)
          .ok());
  EXPECT_EQ(records.size(), 3u);
  EXPECT_TRUE(report.truncated_tail);
}

// A recorder without a real-time clock has its clock stepped by NTP
// mid-drive (+40 days, or back 2 days); a damaged record right at the step
// lost every record after it, whose times lay outside the window the
// search for the next intact record allows.
TEST(FramesDamageTest, DamageAtAWallClockStepLosesOnlyItsOwnRecord) {
  constexpr int64_t kDayNs = int64_t{86400} * 1000000000;
  for (const int64_t step : {40 * kDayNs, -2 * kDayNs}) {
    SCOPED_TRACE(step);
    std::vector<size_t> sizes(40, 30);
    std::vector<int64_t> times;
    for (int i = 0; i < 40; ++i) times.push_back(int64_t{1000000000} * i + (i >= 20 ? step : 0));
    std::vector<size_t> offsets;
    Bytes file = Frames(sizes, times, &offsets);
    file[offsets[19] + 20] ^= 0x01;  // The payload of the last record before the step.
    std::vector<SessionRecord> records;
    FramesLoadReport report;
    ASSERT_TRUE(
        LoadFramesFromMemory(file.data(), file.size(), "x", Skip(), &records, &report).ok());
    EXPECT_EQ(records.size(), 39u);
    EXPECT_EQ(report.corrupt_records_skipped, 1u);
    ASSERT_EQ(report.damage.size(), 1u);
    EXPECT_EQ(report.damage[0].bytes, offsets[20] - offsets[19]);
    EXPECT_EQ(records.back().receive_time_ns, times.back());
  }
}

// Random bytes over the last quarter of the file: the lengths in them stop
// being usable within a record or two, and it said "2 records, 0.00 s
// lost". Now the records and seconds are estimated from the intact ones'
// mean size and rate (records of 20-60 bytes, one every 10 ms).
TEST(FramesDamageTest, DamageToTheEndOfTheFileIsSizedFromTheIntactRecords) {
  std::mt19937 rng(7);
  std::vector<size_t> sizes;
  std::vector<int64_t> times;
  for (int i = 0; i < 400; ++i) {
    sizes.push_back(20 + rng() % 41);
    times.push_back(int64_t{10000000} * i);
  }
  std::vector<size_t> offsets;
  Bytes file = Frames(sizes, times, &offsets);
  for (size_t i = offsets[300]; i < file.size(); ++i) file[i] = static_cast<uint8_t>(rng());
  std::vector<SessionRecord> records;
  FramesLoadReport report;
  ASSERT_TRUE(LoadFramesFromMemory(file.data(), file.size(), "x", Skip(), &records, &report).ok());
  ASSERT_EQ(records.size(), 300u);
  ASSERT_EQ(report.damage.size(), 1u);
  const FramesDamage& d = report.damage[0];
  EXPECT_TRUE(d.to_end_of_file);
  EXPECT_EQ(d.bytes, file.size() - offsets[300]);
  // 100 records and 1.00 s were lost (the last one's own 10 ms included).
  EXPECT_NEAR(static_cast<double>(d.records), 100.0, 10.0);
  EXPECT_EQ(report.corrupt_records_skipped, d.records);
  EXPECT_NEAR(d.SecondsLost(), 1.0, 0.1);
  const std::string summary = report.DamageSummary();
  EXPECT_NE(summary.find("to the end of the file, about " + std::to_string(d.records) + " records"),
            std::string::npos)
      << summary;
}

// A full disk at the start of a recording: meta.json cannot be written
// (here a file-size limit of 100 bytes). The folder Create made is
// removed, so that the next `record` to the same name is not refused as
// an existing session.
TEST(FramesDamageTest, ASessionThatCannotBeBegunLeavesNoFolder) {
  char tmpl[] = "/tmp/sweepscan_frames_damage_XXXXXX";
  const std::string tmp = ::mkdtemp(tmpl);
  const std::string dir = tmp + "/full.sweepscan";
  SessionMeta meta;
  meta.geometry.lidar_height_m = 0.42;
  meta.geometry.wheel_distance_m = 0.16;
  rlimit old{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  auto* const previous = ::signal(SIGXFSZ, SIG_IGN);  // EFBIG instead of the signal.
  rlimit small = old;
  small.rlim_cur = 100;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  std::unique_ptr<SessionWriter> writer;
  const Status s = SessionWriter::Create(dir, meta, SessionWriterOptions(), &writer);
  ::setrlimit(RLIMIT_FSIZE, &old);
  ::signal(SIGXFSZ, previous);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("meta.json"), std::string::npos) << s.message();
  struct stat st;
  EXPECT_NE(::stat(dir.c_str(), &st), 0) << dir << " was left behind";
  // The same folder, made by the operator beforehand, is kept (empty).
  ASSERT_EQ(::mkdir(dir.c_str(), 0755), 0);
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  ::signal(SIGXFSZ, SIG_IGN);
  EXPECT_FALSE(SessionWriter::Create(dir, meta, SessionWriterOptions(), &writer).ok());
  ::setrlimit(RLIMIT_FSIZE, &old);
  ::signal(SIGXFSZ, previous);
  EXPECT_EQ(::stat(dir.c_str(), &st), 0);
  EXPECT_TRUE(SessionWriter::Create(dir, meta, SessionWriterOptions(), &writer).ok());
  writer.reset();
  testing::ShellOrFail("rm -rf '" + tmp + "'");
}

}  // namespace
}  // namespace sweepscan
