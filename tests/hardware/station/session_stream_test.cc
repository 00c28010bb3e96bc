// The streamed reconstruction (two passes over frames.bin, record by record)
// gives Reconstruct's cloud on the whole decoded session, bit for bit: on a
// clean session, with odometry and without deskew, and on a damaged one
// whose hole is a gap in the poses. Its decode hands over exactly what
// DecodeSession keeps.
#include "hardware/station/session_stream.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <vector>

#include "core/cloud/reconstruct.h"
#include "core/common/crc32c.h"
#include "hardware/station/replay_source.h"
#include "hardware/station/session_cloud.h"
#include "tests/testing/lab_session.h"
#include "tests/testing/run_command.h"

namespace sweepscan::hardware {
namespace {

const std::string& Session() { return testing::LabDriveSession(); }
std::string DamagedCopy(size_t bytes) { return testing::DamagedCopy(Session(), bytes); }

struct Streamed {
  std::vector<CloudPoint> points;
  size_t calls = 0;
  size_t largest_call = 0;
  ReconstructionResult result;
  size_t scans = 0;
  double min[3], max[3];
};

Streamed Stream(const std::string& dir, const ReconstructionOptions& options) {
  Streamed out;
  SessionCloudStream stream;
  Status s = stream.EstimatePoses(dir, DefaultSessionFramesOptions(), options);
  EXPECT_TRUE(s.ok()) << s.message();
  stream.PointBounds(out.min, out.max);
  s = stream.PlacePoints([&out](const CloudPoint* p, size_t n) {
    out.points.insert(out.points.end(), p, p + n);
    ++out.calls;
    out.largest_call = std::max(out.largest_call, n);
    return Status::Ok();
  });
  EXPECT_TRUE(s.ok()) << s.message();
  out.result = stream.result();
  out.scans = stream.scans();
  return out;
}

ReconstructionResult Whole(const std::string& dir, const ReconstructionOptions& options, size_t* scans) {
  SensorLog log;
  SessionDecodeInfo info;
  Status s = DecodeSession(dir, &log, &info);
  EXPECT_TRUE(s.ok()) << s.message();
  ReconstructionResult r;
  s = Reconstruct(log, info.meta.geometry, options, nullptr, &r);
  EXPECT_TRUE(s.ok()) << s.message();
  *scans = log.scans.size();
  return r;
}

void ExpectSameCloud(const std::string& dir, const ReconstructionOptions& options) {
  size_t scans = 0;
  const ReconstructionResult whole = Whole(dir, options, &scans);
  const Streamed streamed = Stream(dir, options);
  ASSERT_GT(whole.points.size(), 100000u);
  ASSERT_EQ(streamed.points.size(), whole.points.size());
  EXPECT_EQ(std::memcmp(streamed.points.data(), whole.points.data(), whole.points.size() * sizeof(CloudPoint)), 0);
  EXPECT_EQ(streamed.scans, scans);
  EXPECT_EQ(streamed.result.stats.samples_in, whole.stats.samples_in);
  EXPECT_EQ(streamed.result.stats.points_out, whole.stats.points_out);
  EXPECT_EQ(streamed.result.stats.invalid_range, whole.stats.invalid_range);
  EXPECT_EQ(streamed.result.stats.no_pose, whole.stats.no_pose);
  EXPECT_EQ(streamed.result.ekf_counters.rejected, whole.ekf_counters.rejected);
  ASSERT_EQ(streamed.result.gaps.size(), whole.gaps.size());
  for (size_t k = 0; k < whole.gaps.size(); ++k) {
    EXPECT_EQ(streamed.result.gaps[k].samples_dropped, whole.gaps[k].samples_dropped);
  }
  EXPECT_EQ(streamed.result.gap_samples_dropped, whole.gap_samples_dropped);
  // In chunks of at most 65 536, and inside the box given beforehand.
  EXPECT_LE(streamed.largest_call, 65536u);
  EXPECT_GE(streamed.calls, whole.points.size() / 65536);
  for (const CloudPoint& p : whole.points) {
    const double v[3] = {p.x, p.y, p.z};
    for (int k = 0; k < 3; ++k) {
      ASSERT_GE(v[k], streamed.min[k]);
      ASSERT_LE(v[k], streamed.max[k]);
    }
  }
}

TEST(SessionStreamTest, EkfCloudIsReconstructsBitForBit) {
  ReconstructionOptions options;
  ExpectSameCloud(Session(), options);
}

TEST(SessionStreamTest, OdometryWithoutDeskewAndACalibrationToo) {
  ReconstructionOptions options;
  options.pose.source = PoseSource::kOdometry;
  options.assembly.deskew = false;
  options.calibration = {0.01, -0.02, 0.015};
  ExpectSameCloud(Session(), options);
}

TEST(SessionStreamTest, ADamagedSessionHasTheSameGapAndDropsTheSameSamples) {
  const std::string dir = DamagedCopy(60000);  // about 1.5 s of frames
  size_t scans = 0;
  const ReconstructionResult whole = Whole(dir, ReconstructionOptions(), &scans);
  ASSERT_EQ(whole.gaps.size(), 1u);
  EXPECT_GT(whole.gap_samples_dropped, 0u);
  ExpectSameCloud(dir, ReconstructionOptions());
}

// A project's session cloud streamed (LoadSessionPositions: what the app's
// project view builds, never holding the decoded session or its 32-byte
// points) is LoadSessionCloud's positions bit for bit, with its damage,
// calibration and truth: under a project calibration, and on a damaged
// copy with the session's own; its progress climbs to the end.
TEST(SessionStreamTest, AProjectSessionsPositionsStreamedAreLoadSessionClouds) {
  for (const bool damaged : {false, true}) {
    ProjectSession session;
    session.id = "s";
    session.path = damaged ? DamagedCopy(60000) : Session();  // absolute
    if (!damaged) session.calibration = MountingError{0.01, -0.02, 0.015};
    const std::string project = "/nowhere/p.sweepscan-project";
    SessionCloud whole, streamed;
    Status s = LoadSessionCloud(project, session, SessionCloudOptions(), &whole);
    ASSERT_TRUE(s.ok()) << s.message();
    SessionCloudOptions options;
    double last = -1.0;
    bool climbs = true;
    options.progress = [&](double f) {
      climbs = climbs && f >= last;
      last = f;
      return true;
    };
    std::vector<Eigen::Vector3f> positions;
    s = LoadSessionPositions(project, session, options, &streamed, &positions);
    ASSERT_TRUE(s.ok()) << s.message();
    const std::vector<Eigen::Vector3f> want = Positions(whole.points);
    ASSERT_GT(want.size(), 100000u);
    ASSERT_EQ(positions.size(), want.size());
    EXPECT_EQ(std::memcmp(positions.data(), want.data(), want.size() * sizeof(Eigen::Vector3f)), 0);
    EXPECT_TRUE(streamed.points.empty());
    EXPECT_EQ(streamed.damage, whole.damage);
    EXPECT_EQ(streamed.damage.empty(), !damaged);
    EXPECT_EQ(streamed.calibration.alpha, whole.calibration.alpha);
    EXPECT_EQ(streamed.calibration.gamma, damaged ? whole.calibration.gamma : 0.015);
    EXPECT_EQ(streamed.has_true_start, whole.has_true_start);
    EXPECT_TRUE(streamed.world_from_session_truth.translation().isApprox(
        whole.world_from_session_truth.translation(), 0.0));
    EXPECT_TRUE(climbs);
    EXPECT_GT(last, 0.9);
  }
}

// After pass 1 the stream bounds the points pass 2 places (the lidar's
// bytes over 2), tightly enough to reserve: within a quarter of them on the
// lab drive. LoadSessionPositions reserves it and so never reallocates.
TEST(SessionStreamTest, PassOneBoundsThePointsPassTwoPlaces) {
  SessionCloudStream stream;
  Status s =
      stream.EstimatePoses(Session(), DefaultSessionFramesOptions(), ReconstructionOptions());
  ASSERT_TRUE(s.ok()) << s.message();
  const size_t bound = stream.PointBound();
  size_t placed = 0;
  s = stream.PlacePoints([&placed](const CloudPoint*, size_t n) {
    placed += n;
    return Status::Ok();
  });
  ASSERT_TRUE(s.ok()) << s.message();
  ASSERT_GT(placed, 100000u);
  EXPECT_GE(bound, placed);
  EXPECT_LE(bound, placed + placed / 4) << bound << " for " << placed << " points";
  std::printf("bound %zu for %zu points placed (%.3f)\n", bound, placed,
              static_cast<double>(bound) / placed);

  ProjectSession session;
  session.id = "s";
  session.path = Session();
  SessionCloud cloud;
  std::vector<Eigen::Vector3f> positions;
  s = LoadSessionPositions("/nowhere/p.sweepscan-project", session, SessionCloudOptions(), &cloud,
                           &positions);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_LE(positions.size(), bound);
  EXPECT_EQ(positions.capacity(), bound);  // Reserved once, never grown.
}

TEST(SessionStreamTest, StreamingDecodeHandsOverWhatDecodeSessionKeeps) {
  const std::string dir = DamagedCopy(5000);
  SensorLog log;
  SessionDecodeInfo info;
  ASSERT_TRUE(DecodeSession(dir, &log, &info).ok());
  SensorLog motion;
  std::vector<LidarScan> scans;
  SessionStreamSinks sinks;
  sinks.motion = &motion;
  sinks.scan = [&scans](LidarScan&& scan) {
    scans.push_back(std::move(scan));
    return true;
  };
  SessionDecodeInfo streamed;
  ASSERT_TRUE(DecodeSessionStreaming(dir, DefaultSessionFramesOptions(), sinks, &streamed).ok());
  EXPECT_TRUE(streamed.frames.damaged());
  EXPECT_EQ(streamed.ToString(), info.ToString());
  EXPECT_EQ(streamed.frames.DamageSummary(), info.frames.DamageSummary());
  ASSERT_EQ(motion.imu.size(), log.imu.size());
  ASSERT_EQ(motion.wheels.size(), log.wheels.size());
  ASSERT_EQ(scans.size(), log.scans.size());
  for (size_t i = 0; i < scans.size(); ++i) {
    ASSERT_EQ(scans[i].index, log.scans[i].index);
    ASSERT_EQ(scans[i].samples.size(), log.scans[i].samples.size());
    for (size_t j = 0; j < scans[i].samples.size(); ++j) {
      ASSERT_EQ(scans[i].samples[j].time, log.scans[i].samples[j].time);
      ASSERT_EQ(scans[i].samples[j].range_m, log.scans[i].samples[j].range_m);
    }
  }
  for (size_t i = 0; i < log.imu.size(); ++i) ASSERT_EQ(motion.imu[i].time, log.imu[i].time);
  // The two passes of SessionCloudStream decode one device each (the
  // wheels and IMU, then the lidar); their counts together are one whole
  // decode's.
  SessionCloudStream stream;
  ASSERT_TRUE(stream.EstimatePoses(dir, DefaultSessionFramesOptions(), ReconstructionOptions()).ok());
  EXPECT_EQ(stream.decode().telemetry.x4.frames_ok, 0u);
  EXPECT_EQ(stream.decode().telemetry.hi219.frames_ok, info.telemetry.hi219.frames_ok);
  ASSERT_TRUE(stream.PlacePoints([](const CloudPoint*, size_t) { return Status::Ok(); }).ok());
  EXPECT_EQ(stream.decode().ToString(), info.ToString());
  EXPECT_GT(info.telemetry.x4.frames_ok, 1000u);
  // --strict: the damage is refused with its place, as DecodeSession does.
  FramesLoadOptions strict;
  SessionDecodeInfo refused;
  const Status s = DecodeSessionStreaming(dir, strict, sinks, &refused);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("frames.bin: record"), std::string::npos) << s.message();
}

TEST(SessionStreamTest, AWriterErrorStopsThePassAndIsReturned) {
  SessionCloudStream stream;
  ASSERT_TRUE(stream.EstimatePoses(Session(), DefaultSessionFramesOptions(), ReconstructionOptions()).ok());
  size_t calls = 0;
  const Status s = stream.PlacePoints([&calls](const CloudPoint*, size_t) {
    return ++calls == 2 ? Status::Error("out.las: write failed: No space left on device") : Status::Ok();
  });
  EXPECT_EQ(s.message(), "out.las: write failed: No space left on device");
  EXPECT_EQ(calls, 2u);
  // A cancel from the progress callback.
  const Status c = stream.PlacePoints([](const CloudPoint*, size_t) { return Status::Ok(); },
                                      [](double f) { return f < 0.3; });
  EXPECT_NE(c.message().find("cancelled"), std::string::npos) << c.message();
}

// The second pass reads the file the first one read: a session recorded
// over in between (`record --overwrite` makes a new frames.bin) is an error
// before any point, not one file's poses under another's scans; so is a
// replay's next decode (a rewind or a seek).
TEST(SessionStreamTest, ASessionRecordedOverBetweenThePassesIsRefused) {
  const std::string dir = Session() + ".replaced";
  testing::ShellOrFail("rm -rf '" + dir + "' && cp -r '" + Session() + "' '" + dir + "'");
  SessionCloudStream stream;
  ASSERT_TRUE(
      stream.EstimatePoses(dir, DefaultSessionFramesOptions(), ReconstructionOptions()).ok());
  std::unique_ptr<SessionReplaySource> replay;
  ASSERT_TRUE(SessionReplaySource::Open(dir, nullptr, &replay).ok());
  // The same bytes under a new inode (a network file system that numbers a
  // file anew at each open): the same recording, read on.
  testing::ShellOrFail("cp '" + dir + "/frames.bin' '" + dir + "/frames.new' && mv '" + dir +
                       "/frames.new' '" + dir + "/frames.bin'");
  EXPECT_TRUE(stream.PlacePoints([](const CloudPoint*, size_t) { return Status::Ok(); }).ok());
  ASSERT_TRUE(
      stream.EstimatePoses(dir, DefaultSessionFramesOptions(), ReconstructionOptions()).ok());
  // Another recording under the same name, as a writer's O_EXCL create
  // makes it: here the same records but the first received 1 ms later.
  {
    std::fstream f(dir + "/frames.bin", std::ios::in | std::ios::out | std::ios::binary);
    std::vector<uint8_t> head(16 + 12);
    f.read(reinterpret_cast<char*>(head.data()), static_cast<std::streamsize>(head.size()));
    uint32_t length = 0;
    std::memcpy(&length, head.data() + 16, 4);
    std::vector<uint8_t> record(12 + length);
    f.seekg(16);
    f.read(reinterpret_cast<char*>(record.data()), static_cast<std::streamsize>(record.size()));
    int64_t t = 0;
    std::memcpy(&t, record.data() + 4, 8);
    t += 1000000;
    std::memcpy(record.data() + 4, &t, 8);
    const uint32_t crc = Crc32c(record.data(), record.size());
    std::ofstream copy(dir + "/frames.new", std::ios::binary);
    f.seekg(0);
    copy << f.rdbuf();
    copy.seekp(16);
    copy.write(reinterpret_cast<const char*>(record.data()),
               static_cast<std::streamsize>(record.size()));
    copy.write(reinterpret_cast<const char*>(&crc), 4);
  }
  testing::ShellOrFail("mv '" + dir + "/frames.new' '" + dir + "/frames.bin'");
  size_t points = 0;
  const Status s = stream.PlacePoints([&points](const CloudPoint*, size_t n) {
    points += n;
    return Status::Ok();
  });
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("frames.bin: replaced since its first pass was read"),
            std::string::npos)
      << s.message();
  EXPECT_EQ(points, 0u);
  replay->Rewind();
  SensorLog batch;
  while (!replay->done()) replay->Take(Time::max(), &batch);
  EXPECT_TRUE(batch.scans.empty());
  EXPECT_NE(replay->status().message().find("replaced since its first pass was read"),
            std::string::npos)
      << replay->status().message();
  // The same file read again (no replacement): both passes as before.
  SessionCloudStream again;
  ASSERT_TRUE(
      again.EstimatePoses(dir, DefaultSessionFramesOptions(), ReconstructionOptions()).ok());
  EXPECT_TRUE(again.PlacePoints([](const CloudPoint*, size_t) { return Status::Ok(); }).ok());
  testing::ShellOrFail("rm -rf '" + dir + "'");
}

}  // namespace
}  // namespace sweepscan::hardware
