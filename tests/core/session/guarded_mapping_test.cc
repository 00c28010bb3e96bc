// frames.bin failing under its reader: a file cut short while mapped (the
// kernel then raises SIGBUS for the pages past its new end) is an error
// with its place, after every record before the cut was visited intact;
// the process lives. A SIGBUS outside a guarded mapping still ends the
// process as before.
#include "core/session/guarded_mapping.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "core/session/session.h"
#include "tests/testing/run_command.h"

namespace sweepscan {
namespace {

std::vector<uint8_t> RecordBytes(int i) {
  std::vector<uint8_t> b(3000);  // a lidar frame's size
  for (size_t k = 0; k < b.size(); ++k) b[k] = static_cast<uint8_t>(i * 7 + k);
  return b;
}

// A session of `records` records of 3 000 bytes (about 3 MB: hundreds of
// pages) in a fresh folder under /tmp (the session's parent: remove it).
std::string WriteSession(int records) {
  char tmpl[] = "/tmp/sweepscan_guarded_XXXXXX";
  const std::string dir = std::string(::mkdtemp(tmpl)) + "/s.sweepscan";
  SessionMeta meta;
  meta.created_utc = "2026-11-29T00:00:00Z";
  std::unique_ptr<SessionWriter> writer;
  Status s = SessionWriter::Create(dir, meta, SessionWriterOptions(), &writer);
  EXPECT_TRUE(s.ok()) << s.message();
  for (int i = 0; i < records; ++i) EXPECT_TRUE(writer->Append(RecordBytes(i), 1000 * i).ok());
  s = writer->Close();
  EXPECT_TRUE(s.ok()) << s.message();
  return dir;
}

void RemoveParent(const std::string& dir) {
  sweepscan::testing::ShellOrFail("rm -rf '" + dir.substr(0, dir.rfind('/')) + "'");
}

// Damaged records skipped (the app's and the CLI's default): the reader
// goes on past the cut into pages the kernel cannot supply.
FramesLoadOptions Skipping() {
  FramesLoadOptions options;
  options.skip_corrupt_records = true;
  return options;
}

TEST(GuardedMappingTest, AFileCutShortWhileVisitedIsAnErrorWithItsPlaceAfterTheIntactRecords) {
  const int kRecords = 1000;
  const std::string dir = WriteSession(kRecords);
  const std::string frames = dir + "/frames.bin";
  int visited = 0;
  bool intact = true;
  const Status s = VisitFramesFile(
      frames, Skipping(),
      [&](const SessionRecordView& r) {
        if (r.ordinal == 10) {
          // Another program cuts the file to a third under the reader.
          EXPECT_EQ(::truncate(frames.c_str(), 1000000), 0);
        }
        const std::vector<uint8_t> expected = RecordBytes(static_cast<int>(r.ordinal));
        intact = intact && r.size == expected.size() &&
                 std::equal(r.bytes, r.bytes + r.size, expected.begin());
        ++visited;
        return true;
      },
      nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find(
                "frames.bin: the file shrank from 3016016 to 1000000 bytes while it was read"),
            std::string::npos)
      << s.message();
  // Every record wholly before the cut, and none of the zeros after it.
  EXPECT_TRUE(intact);
  EXPECT_EQ(visited, (1000000 - 16) / 3016);  // the records wholly before the cut
  RemoveParent(dir);
}

// Strict (the CLI's --strict): the record the cut runs through is refused
// as what it is, a file that shrank, not as a CRC mismatch.
TEST(GuardedMappingTest, StrictlyTheCutIsSaidToBeAShrinkingFile) {
  const std::string dir = WriteSession(1000);
  const std::string frames = dir + "/frames.bin";
  const Status s = VisitFramesFile(
      frames, FramesLoadOptions(),
      [&](const SessionRecordView& r) {
        if (r.ordinal == 10) {
          EXPECT_EQ(::truncate(frames.c_str(), 1000000), 0);
        }
        return true;
      },
      nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("the file shrank from 3016016 to 1000000 bytes"), std::string::npos)
      << s.message();
  RemoveParent(dir);
}

TEST(GuardedMappingTest, TheSameFileReadAgainAfterTheCutGivesItsRecordsAndTheTornTail) {
  const std::string dir = WriteSession(400);
  const std::string frames = dir + "/frames.bin";
  ASSERT_EQ(::truncate(frames.c_str(), 600000), 0);
  FramesLoadReport report;
  int visited = 0;
  const Status s = VisitFramesFile(
      frames, Skipping(), [&](const SessionRecordView&) { return ++visited > 0; }, &report);
  ASSERT_TRUE(s.ok()) << s.message();  // a cut file read afresh is a torn tail, not a failure
  EXPECT_TRUE(report.truncated_tail);
  EXPECT_EQ(visited, (600000 - 16) / (3000 + 16));
  RemoveParent(dir);
}

// A fault outside every guarded range is not swallowed: the process dies
// of SIGBUS as it would without the guard.
TEST(GuardedMappingDeathTest, ASigbusOutsideAGuardedMappingStillEndsTheProcess) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const std::string dir = WriteSession(100);
  const std::string frames = dir + "/frames.bin";
  EXPECT_EXIT(
      {
        GuardedMapping guarded;  // installs the handler
        const int fd = ::open(frames.c_str(), O_RDONLY);
        if (!guarded.Map(fd, frames).ok()) std::exit(3);
        const int other = ::open(frames.c_str(), O_RDWR);
        void* plain = ::mmap(nullptr, 300000, PROT_READ, MAP_SHARED, other, 0);
        if (plain == MAP_FAILED || ::ftruncate(other, 0) != 0) std::exit(4);
        volatile uint8_t byte = static_cast<const uint8_t*>(plain)[200000];
        (void)byte;
        std::exit(0);
      },
      ::testing::KilledBySignal(SIGBUS), "");
  RemoveParent(dir);
}

}  // namespace
}  // namespace sweepscan
