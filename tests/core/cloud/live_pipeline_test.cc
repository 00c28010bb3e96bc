#include "core/cloud/live_pipeline.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace sweepscan
