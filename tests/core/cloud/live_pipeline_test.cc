#include "core/cloud/live_pipeline.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <vector>

#include "tests/testing/worlds.h"

namespace sweepscan {
namespace {

// Records fed in irregular batches, as the live link delivers them, give
// exactly the offline reconstruction.
TEST(LivePipelineTest, BatchedEqualsOffline) {
  sim::SimConfig config = testing::LabConfig(2);
  config.path = {{0.2, 0.0, 5.0}, {0.0, 0.4, 3.0}, {0.15, 0.2, 4.0}};
  ReconstructionOptions options;
  options.pose.initial_pose = config.start;

  sim::SimWorld offline_world(config);
  const SensorLog log = offline_world.RunAll();
  ReconstructionResult offline;
  ASSERT_TRUE(Reconstruct(log, config.geometry, options, nullptr, &offline).ok());

  LivePipeline live(options, config.geometry, /*chunk_capacity=*/4096);
  sim::SimWorld world(config);
  sim::SensorLogCollector collector;
  size_t scans_taken = 0, sealed_before_end = 0;
  for (double t = 0.9; !world.finished(); t += 0.0437) {
    world.RunUntil(TimeFromSeconds(t), &collector);
    SensorLog* all = collector.log();
    // Hand over everything but the scan still being filled.
    SensorLog batch;
    batch.wheels.swap(all->wheels);
    batch.imu.swap(all->imu);
    const size_t complete = all->scans.empty() ? 0 : all->scans.size() - 1;
    batch.scans.assign(all->scans.begin(), all->scans.begin() + complete);
    all->scans.erase(all->scans.begin(), all->scans.begin() + complete);
    scans_taken += complete;
    live.Add(batch);
    sealed_before_end = live.cloud().sealed_point_count();
  }
  SensorLog rest;
  rest.scans.swap(collector.log()->scans);
  live.Add(rest);
  live.Finish();
  EXPECT_GT(sealed_before_end, 0u) << "a viewer sees points while recording";

  const std::vector<CloudPoint> points = live.cloud().Flatten();
  ASSERT_EQ(points.size(), offline.points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const CloudPoint &a = points[i], &b = offline.points[i];
    ASSERT_TRUE(a.x == b.x && a.y == b.y && a.z == b.z && a.time_ns == b.time_ns && a.scan == b.scan &&
                a.beam == b.beam)
        << "point " << i << ": scan " << a.scan << "/" << b.scan << " beam " << a.beam << "/" << b.beam
        << " x " << a.x << "/" << b.x << " z " << a.z << "/" << b.z;
  }
  EXPECT_EQ(live.scans_waiting(), 0u);
}

// A 10 s hole in every stream (the link dropped; reconstruct_test's
// GapIsReportedAndOnlyItsSamplesDropped has the same drive), fed in
// batches: the pipeline does not stall at the gap (a scan ending inside it
// is placed once the pose after it is final), and gives the offline cloud
// and the same gap with the same dropped samples.
TEST(LivePipelineTest, GapInTheRecordsAsOffline) {
  sim::SimConfig config = testing::LabConfig(3);
  config.start = {2.0, 2.5, 0.0};
  config.path = {{0.0, 0.0, 2.0}, {0.3, 0.0, 6.0}, {0.3, 0.3, 2.0}, {0.0, 0.0, 10.0}, {0.3, 0.0, 5.0}};
  sim::SimWorld world(config);
  SensorLog log = world.RunAll();
  const Time a = TimeFromSeconds(sim::SimWorld::kStartTimeS + 9.6);
  const Time b = TimeFromSeconds(sim::SimWorld::kStartTimeS + 19.6);
  const Duration lidar_margin = std::chrono::milliseconds(5);  // the lidar's buffer held a little more
  const auto inside = [&](const auto& r) { return r.time > a && r.time < b; };
  log.wheels.erase(std::remove_if(log.wheels.begin(), log.wheels.end(), inside), log.wheels.end());
  log.imu.erase(std::remove_if(log.imu.begin(), log.imu.end(), inside), log.imu.end());
  for (LidarScan& scan : log.scans) {
    scan.samples.erase(std::remove_if(scan.samples.begin(), scan.samples.end(),
                                      [&](const LidarSample& s) {
                                        return s.time > a + lidar_margin && s.time < b - lidar_margin;
                                      }),
                       scan.samples.end());
  }
  log.scans.erase(std::remove_if(log.scans.begin(), log.scans.end(),
                                 [](const LidarScan& s) { return s.samples.empty(); }),
                  log.scans.end());

  ReconstructionOptions options;
  options.pose.initial_pose = config.start;
  ReconstructionResult offline;
  ASSERT_TRUE(Reconstruct(log, config.geometry, options, nullptr, &offline).ok());
  ASSERT_EQ(offline.gaps.size(), 1u);

  // Batches as the link delivers them after the hole: every 43.7 ms of
  // time, the records up to it and the scans complete by then.
  LivePipeline live(options, config.geometry, /*chunk_capacity=*/4096);
  size_t iw = 0, ii = 0, is = 0;
  size_t waiting_after_gap = 0;
  for (double t = 0.9; iw < log.wheels.size() || ii < log.imu.size() || is < log.scans.size(); t += 0.0437) {
    const Time until = TimeFromSeconds(t);
    SensorLog batch;
    while (iw < log.wheels.size() && log.wheels[iw].time <= until) batch.wheels.push_back(log.wheels[iw++]);
    while (ii < log.imu.size() && log.imu[ii].time <= until) batch.imu.push_back(log.imu[ii++]);
    while (is < log.scans.size() && log.scans[is].end_time() <= until) batch.scans.push_back(log.scans[is++]);
    live.Add(batch);
    if (until > b + std::chrono::milliseconds(500)) waiting_after_gap = std::max(waiting_after_gap, live.scans_waiting());
  }
  EXPECT_LE(waiting_after_gap, 2u) << "no scan held back at the gap";
  live.Finish();
  const std::vector<CloudPoint> points = live.cloud().Flatten();
  ASSERT_EQ(points.size(), offline.points.size());
  EXPECT_EQ(0, std::memcmp(points.data(), offline.points.data(), points.size() * sizeof(CloudPoint)));
  const std::vector<PoseGap> gaps = live.gaps();
  ASSERT_EQ(gaps.size(), 1u);
  EXPECT_EQ(gaps[0].begin, offline.gaps[0].begin);
  EXPECT_EQ(gaps[0].first_pose, offline.gaps[0].first_pose);
  EXPECT_GT(gaps[0].samples_dropped, 0u);
  EXPECT_EQ(gaps[0].samples_dropped, offline.gaps[0].samples_dropped);
  EXPECT_EQ(live.stats().no_pose, offline.stats.no_pose);
}

}  // namespace
}  // namespace sweepscan
