// A replay's records: a session read as it replays (SessionReplaySource: its
// wheel and IMU records decoded up front, its scans decoded on a thread of
// its own a bounded stretch ahead) hands out exactly the records, in the same
// slices, as the session decoded whole (LogReplaySource over OpenRecording),
// on a clean and on a damaged session, after a rewind, with its queue at its
// bound; a frames.bin that goes away mid-replay ends it with the reason.
#include "hardware/station/replay_source.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include "tests/testing/lab_session.h"
#include "tests/testing/run_command.h"
#include "tests/testing/remove_at_exit.h"

namespace sweepscan::hardware {
namespace {

const std::string& Session() { return testing::LabDriveSession(); }
std::string DamagedCopy(size_t bytes) { return testing::DamagedCopy(Session(), bytes); }

// Everything a source hands out from where it is, in slices of `step`,
// each slice's records checked to be due (time < until) and the source's
// start and end kept.
struct Taken {
  std::vector<SensorLog> slices;
  Time start, end;
};

Taken TakeAll(ReplaySource* source, double step_s) {
  Taken out;
  out.start = source->start();
  Time until = source->start();
  for (int guard = 0; !source->done() && guard < 100000; ++guard) {
    until = until + FromSeconds(step_s);
    SensorLog slice;
    source->Take(until, &slice);
    for (const auto& w : slice.wheels) EXPECT_LT(w.time, until);
    for (const auto& m : slice.imu) EXPECT_LT(m.time, until);
    for (const auto& scan : slice.scans) EXPECT_LT(scan.end_time(), until);
    out.slices.push_back(std::move(slice));
  }
  EXPECT_TRUE(source->done());
  out.end = source->end();
  return out;
}

::testing::AssertionResult SameRecords(const Taken& a, const Taken& b) {
  if (a.start != b.start) return ::testing::AssertionFailure() << "the starts differ";
  if (a.end != b.end) return ::testing::AssertionFailure() << "the ends differ";
  if (a.slices.size() != b.slices.size()) {
    return ::testing::AssertionFailure()
           << a.slices.size() << " slices against " << b.slices.size();
  }
  for (size_t k = 0; k < a.slices.size(); ++k) {
    const SensorLog& x = a.slices[k];
    const SensorLog& y = b.slices[k];
    if (x.wheels.size() != y.wheels.size() || x.imu.size() != y.imu.size() ||
        x.scans.size() != y.scans.size()) {
      return ::testing::AssertionFailure() << "slice " << k << " holds other counts";
    }
    for (size_t i = 0; i < x.wheels.size(); ++i) {
      if (x.wheels[i].time != y.wheels[i].time || x.wheels[i].left_mps != y.wheels[i].left_mps ||
          x.wheels[i].right_mps != y.wheels[i].right_mps) {
        return ::testing::AssertionFailure() << "slice " << k << " wheel " << i << " differs";
      }
    }
    for (size_t i = 0; i < x.imu.size(); ++i) {
      if (x.imu[i].time != y.imu[i].time || x.imu[i].gyro_z != y.imu[i].gyro_z ||
          x.imu[i].yaw != y.imu[i].yaw) {
        return ::testing::AssertionFailure() << "slice " << k << " IMU record " << i << " differs";
      }
    }
    for (size_t i = 0; i < x.scans.size(); ++i) {
      const auto& p = x.scans[i].samples;
      const auto& q = y.scans[i].samples;
      if (x.scans[i].index != y.scans[i].index || p.size() != q.size()) {
        return ::testing::AssertionFailure() << "slice " << k << " scan " << i << " differs";
      }
      for (size_t j = 0; j < p.size(); ++j) {
        if (p[j].time != q[j].time || p[j].range_m != q[j].range_m || p[j].theta != q[j].theta ||
            p[j].beam != q[j].beam) {
          return ::testing::AssertionFailure()
                 << "slice " << k << " scan " << i << " sample " << j << " differs";
        }
      }
    }
  }
  return ::testing::AssertionSuccess();
}

Taken Whole(const std::string& dir, double step_s, size_t* scans = nullptr) {
  auto recording = std::make_shared<Recording>();
  const Status s = OpenRecording(dir, recording.get());
  EXPECT_TRUE(s.ok()) << s.message();
  if (scans != nullptr) *scans = recording->log.scans.size();
  LogReplaySource source(recording);
  return TakeAll(&source, step_s);
}

std::unique_ptr<SessionReplaySource> Open(const std::string& dir,
                                          size_t ahead = SessionReplaySource::kAheadSamples) {
  std::unique_ptr<SessionReplaySource> source;
  const Status s = SessionReplaySource::Open(dir, nullptr, &source, ahead);
  EXPECT_TRUE(s.ok()) << s.message();
  return source;
}

TEST(SessionReplaySourceTest, HandsOutTheRecordsOfTheWholeDecodeSliceForSlice) {
  size_t scans = 0;
  const Taken whole = Whole(Session(), 0.5, &scans);
  ASSERT_GT(scans, 200u);
  std::unique_ptr<SessionReplaySource> source = Open(Session());
  ASSERT_NE(source, nullptr);
  EXPECT_EQ(source->geometry().lidar_height_m, testing::LabConfig(3).geometry.lidar_height_m);
  EXPECT_EQ(source->decode().telemetry.x4.frames_ok, 0u);  // the lidar's bytes skipped up front
  EXPECT_GT(source->motion().imu.size(), 3000u);
  // Before its last scan is read, the end is the last agent frame's time:
  // at or after the last record's (here 0.5 s after: the agent's last
  // frames carry no record).
  EXPECT_GE(source->end(), whole.end);
  EXPECT_LT(ToSeconds(source->end() - whole.end), 1.0);
  EXPECT_TRUE(source->at_start());
  EXPECT_TRUE(SameRecords(TakeAll(source.get(), 0.5), whole));
  EXPECT_TRUE(source->status().ok());
  EXPECT_FALSE(source->at_start());
  // As a 20x replay at 50 Hz would take them: other slices, the same records.
  source->Rewind();
  EXPECT_TRUE(source->at_start());
  EXPECT_FALSE(source->done());
  EXPECT_TRUE(SameRecords(TakeAll(source.get(), 0.4), Whole(Session(), 0.4)));
}

TEST(SessionReplaySourceTest, ARewindHalfWayStartsOverWithTheSameRecords) {
  const Taken whole = Whole(Session(), 2.0);
  std::unique_ptr<SessionReplaySource> source = Open(Session());
  SensorLog half;
  source->Take(source->start() + FromSeconds(20.0), &half);
  ASSERT_GT(half.scans.size(), 50u);
  source->Rewind();
  EXPECT_TRUE(SameRecords(TakeAll(source.get(), 2.0), whole));
}

// The decoder runs at most `ahead` samples ahead of the replay: it waits for
// room (the records are still all there), and the queue never holds more
// than the bound and one scan.
TEST(SessionReplaySourceTest, TheDecoderWaitsAtItsBoundAndLosesNothing) {
  const size_t ahead = 4000;  // under a second of the X4
  std::unique_ptr<SessionReplaySource> source = Open(Session(), ahead);
  // Nothing taken yet: the decoder fills its queue and waits (it must: the
  // session holds 50 times the bound).
  for (int i = 0; i < 10000 && source->decoder_waits() == 0; ++i) usleep(1000);
  ASSERT_GE(source->decoder_waits(), 1u);
  EXPECT_TRUE(SameRecords(TakeAll(source.get(), 0.25), Whole(Session(), 0.25)));
  EXPECT_LE(source->peak_queued_samples(), ahead + 1000);  // an X4 scan: ~700 samples
  // Rewound, and once its decoder waits at the bound, one slice that takes
  // the whole queue (fewer than 16 scans, so no wake-up on the way): it
  // must wake the decoder before waiting for more. It hung there, now and
  // then, when the decoder had filled the queue before the slice.
  const size_t waits = source->decoder_waits();
  source->Rewind();
  for (int i = 0; i < 10000 && source->decoder_waits() == waits; ++i) usleep(1000);
  ASSERT_GT(source->decoder_waits(), waits);
  SensorLog first;
  source->Take(source->start() + FromSeconds(3.0), &first);
  EXPECT_GT(first.scans.size(), 6u);  // more than the bound's ~6 scans: the decoder went on
  // Dropped while its decoder waits: no hang.
  source.reset();
}

// A damaged stretch is skipped as OpenRecording skips it: the same records.
TEST(SessionReplaySourceTest, ADamagedSessionGivesTheRecordsOfItsWholeDecode) {
  const std::string damaged = DamagedCopy(40000);
  std::unique_ptr<SessionReplaySource> source = Open(damaged);
  ASSERT_NE(source, nullptr);
  EXPECT_TRUE(source->decode().frames.damaged());
  EXPECT_TRUE(SameRecords(TakeAll(source.get(), 1.0), Whole(damaged, 1.0)));
}

// frames.bin gone between two replays (the folder deleted): the replay
// ends at its first slice and says why, not after the wheel and IMU records
// it still holds.
TEST(SessionReplaySourceTest, AFramesFileGoneBeforeAReplayStartsOverEndsItWithTheReason) {
  const std::string copy = testing::RemoveAtExit(Session() + ".gone");
  sweepscan::testing::ShellOrFail("rm -rf '" + copy + "' && cp -r '" + Session() + "' '" + copy +
                                  "'");
  std::unique_ptr<SessionReplaySource> source = Open(copy);
  sweepscan::testing::ShellOrFail("rm '" + copy + "/frames.bin'");
  source->Rewind();
  SensorLog first;
  source->Take(source->start() + FromSeconds(5.0), &first);
  EXPECT_TRUE(source->done());
  ASSERT_FALSE(source->status().ok());
  EXPECT_NE(source->status().message().find("frames.bin"), std::string::npos)
      << source->status().message();
  EXPECT_TRUE(first.scans.empty());
  EXPECT_LT(first.imu.size(), source->motion().imu.size() / 4);
}

// frames.bin cut short by another program while the decoder reads it (its
// mapping then faults, SIGBUS, for the pages past the new end): the replay
// hands out the scans before the cut, exactly the whole decode's, then ends
// and says where; the process lives.
TEST(SessionReplaySourceTest, AFramesFileCutWhileReadEndsTheReplayWithThePlace) {
  const std::string copy = testing::RemoveAtExit(Session() + ".cut");
  sweepscan::testing::ShellOrFail("rm -rf '" + copy + "' && cp -r '" + Session() + "' '" + copy +
                                  "'");
  size_t total_scans = 0;
  const Taken whole = Whole(copy, 0.5, &total_scans);
  std::unique_ptr<SessionReplaySource> source =
      Open(copy, 4000);  // the decoder waits near the start
  struct stat st;
  ASSERT_EQ(::stat((copy + "/frames.bin").c_str(), &st), 0);
  ASSERT_EQ(::truncate((copy + "/frames.bin").c_str(), st.st_size * 2 / 5), 0);
  const Taken cut = TakeAll(source.get(), 0.5);
  ASSERT_FALSE(source->status().ok());
  EXPECT_NE(source->status().message().find("frames.bin: the file shrank from "), std::string::npos)
      << source->status().message();
  std::vector<const LidarScan*> expected, got;
  for (const SensorLog& slice : whole.slices) {
    for (const LidarScan& scan : slice.scans) expected.push_back(&scan);
  }
  for (const SensorLog& slice : cut.slices) {
    for (const LidarScan& scan : slice.scans) got.push_back(&scan);
  }
  EXPECT_GT(got.size(), total_scans / 4);
  EXPECT_LT(got.size(), total_scans / 2);
  for (size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(got[i]->index, expected[i]->index) << i;
    ASSERT_EQ(got[i]->samples.size(), expected[i]->samples.size()) << i;
    ASSERT_EQ(got[i]->end_time(), expected[i]->end_time()) << i;
  }
}

TEST(SessionReplaySourceTest, AMissingSessionIsRefusedWithItsPlace) {
  std::unique_ptr<SessionReplaySource> source;
  const Status s = SessionReplaySource::Open("/nonexistent/x.sweepscan", nullptr, &source);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("/nonexistent/x.sweepscan"), std::string::npos) << s.message();
  EXPECT_EQ(source, nullptr);
}

}  // namespace
}  // namespace sweepscan::hardware
