// Core pipeline benchmarks. Run (Release build):
//   cmake -S . -B build-release -G Ninja -DCMAKE_BUILD_TYPE=Release
//   ninja -C build-release core_benchmark && build-release/tests/core_benchmark
// Figures are recorded in docs/performance.md.
#include <benchmark/benchmark.h>

#include "core/cloud/assembler.h"
#include "core/pose/pose_estimator.h"
#include "core/sim/world.h"
#include "tests/testing/worlds.h"

namespace sweepscan {
namespace {

struct LabData {
  sim::SimConfig config = testing::LabConfig();
  SensorLog log;
  PoseBuffer poses;
  size_t samples = 0;
  LabData() {
    sim::SimWorld world(config);
    log = world.RunAll();
    PoseEstimatorOptions o;
    o.initial_pose = config.start;
    poses = EstimatePoses(log, o, config.geometry).poses();
    for (const auto& s : log.scans) samples += s.samples.size();
  }
};

const LabData& Lab() {
  static const LabData* data = new LabData();
  return *data;
}

// Per-sample deskew (pose interpolation) + Laser->Body->World transform +
// append to cloud chunks, one core. items/s = lidar samples per second.
void BM_DeskewTransformAssemble(benchmark::State& state) {
  const LabData& lab = Lab();
  const bool deskew = state.range(0) != 0;
  for (auto _ : state) {
    AssemblyOptions o;
    o.deskew = deskew;
    Assembler assembler(o, BodyFromLidar(lab.config.geometry, {}), PoseSource::kEkf);
    PointChunks chunks;
    for (const LidarScan& scan : lab.log.scans) assembler.AddScan(scan, lab.poses, &chunks);
    chunks.Seal();
    benchmark::DoNotOptimize(chunks.sealed_point_count());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(lab.samples));
}
BENCHMARK(BM_DeskewTransformAssemble)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond);

// EKF over the lab's wheel and IMU records (items = records); Arg(1): and
// the Rauch-Tung-Striebel pass over them (PoseEstimatorOptions::smooth,
// what the calibration uses).
void BM_PoseEstimation(benchmark::State& state) {
  const LabData& lab = Lab();
  for (auto _ : state) {
    PoseEstimatorOptions o;
    o.initial_pose = lab.config.start;
    o.smooth = state.range(0) != 0;
    benchmark::DoNotOptimize(EstimatePoses(lab.log, o, lab.config.geometry).poses().size());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(lab.log.wheels.size() + lab.log.imu.size()));
  state.counters["drive_s"] = ToSeconds(lab.poses.latest() - lab.poses.earliest());
}
BENCHMARK(BM_PoseEstimation)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// The simulated world (ray casting + sensor models) of the lab drive;
// the counter x_real_time is simulated seconds per wall-clock second.
void BM_SimulateLab(benchmark::State& state) {
  const sim::SimConfig config = testing::LabConfig();
  double simulated = 0.0;
  for (auto _ : state) {
    sim::SimWorld world(config);
    const SensorLog log = world.RunAll();
    benchmark::DoNotOptimize(log.scans.size());
    simulated += world.duration_s();
  }
  state.counters["x_real_time"] = benchmark::Counter(simulated, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SimulateLab)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace sweepscan

BENCHMARK_MAIN();
