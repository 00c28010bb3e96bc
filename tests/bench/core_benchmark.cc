// Core pipeline benchmarks. Run (Release build):
//   cmake -S . -B build-release -G Ninja -DCMAKE_BUILD_TYPE=Release
//   ninja -C build-release core_benchmark && build-release/tests/core_benchmark
// Figures are recorded in docs/performance.md.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <random>
#include <string>

#include "core/cloud/assembler.h"
#include "core/cloud/cloud_io.h"
#include "core/cloud/las_writer.h"
#include "core/cloud/packed_chunk.h"
#include "core/cloud/payload_codec.h"
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

// The store's compressed payloads (core/cloud/payload_codec.h) on the lab's
// own cloud: its sealed chunks' payloads, as the pager compresses them.
struct LabPayloads {
  std::vector<std::shared_ptr<const ChunkPayload>> payloads;
  std::vector<size_t> sizes;
  std::vector<bool> grid, quantised;
  std::vector<std::vector<uint8_t>> bytes;
  std::vector<std::vector<uint32_t>> ends;
  std::vector<std::vector<CloudPoint>> decoded;
  size_t points = 0;
  LabPayloads() {
    const LabData& lab = Lab();
    Assembler assembler(AssemblyOptions(), BodyFromLidar(lab.config.geometry, {}), PoseSource::kEkf);
    PointChunks chunks;
    for (const LidarScan& scan : lab.log.scans) assembler.AddScan(scan, lab.poses, &chunks);
    chunks.Seal();
    for (const auto& c : chunks.SealedChunks()) {
      payloads.push_back(c->Pin());
      sizes.push_back(c->size());
      grid.push_back(c->positions_on_grid());
      quantised.push_back(c->ranges_quantised());
      bytes.emplace_back();
      ends.emplace_back();
      EncodePayload(*payloads.back(), c->size(), &bytes.back(), &ends.back());
      decoded.emplace_back();
      c->Decode(&decoded.back());
      points += c->size();
    }
  }
};
const LabPayloads& Payloads() {
  static const LabPayloads* data = new LabPayloads();
  return *data;
}

// Sealing every chunk of the lab (PackedChunk::Pack: the 14-byte layout,
// block bounds and the census of 0.5 m cubes; items/s = points), as the
// placing thread does for each 65 536 points of an open.
void BM_PackChunk(benchmark::State& state) {
  const LabPayloads& lab = Payloads();
  for (auto _ : state) {
    for (const auto& points : lab.decoded) {
      benchmark::DoNotOptimize(PackedChunk::Pack(points.data(), points.size(), nullptr));
    }
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * lab.points));
}
BENCHMARK(BM_PackChunk)->Unit(benchmark::kMillisecond);

// Compressing every sealed chunk of the lab (items/s = points).
void BM_PayloadEncode(benchmark::State& state) {
  const LabPayloads& lab = Payloads();
  std::vector<uint8_t> bytes;
  std::vector<uint32_t> ends;
  for (auto _ : state) {
    for (size_t c = 0; c < lab.payloads.size(); ++c) EncodePayload(*lab.payloads[c], lab.sizes[c], &bytes, &ends);
    benchmark::DoNotOptimize(bytes.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * lab.points));
  size_t packed = 0;
  for (const auto& b : lab.bytes) packed += b.size();
  state.counters["bytes_a_point"] = static_cast<double>(packed) / static_cast<double>(lab.points);
}
BENCHMARK(BM_PayloadEncode)->Unit(benchmark::kMillisecond);

// Arg(0): every chunk unpacked whole (what Pin() does). Arg(1): one
// segment's positions at a time, every segment in turn. Arg(2): one
// block's positions at a time (what a pick does). items/s = points decoded.
void BM_PayloadDecode(benchmark::State& state) {
  const LabPayloads& lab = Payloads();
  const int64_t mode = state.range(0);
  ChunkPayload out;
  std::string error;
  for (auto _ : state) {
    for (size_t c = 0; c < lab.payloads.size(); ++c) {
      const size_t n = lab.sizes[c];
      if (mode == 0) {
        DecodeSegments(lab.bytes[c], lab.ends[c], n, lab.grid[c], lab.quantised[c], 0, lab.ends[c].size(), false,
                       &out, &error);
        continue;
      }
      for (size_t s = 0; mode == 1 && s * kCodecSegmentPoints < n; ++s) {
        DecodeSegments(lab.bytes[c], lab.ends[c], n, lab.grid[c], lab.quantised[c], s, s + 1, true, &out, &error);
        benchmark::DoNotOptimize(out.xyz_mm.data());
      }
      for (size_t b = 0; mode == 2 && b * kCodecBlockPoints < n; ++b) {
        DecodeBlockPositions(lab.bytes[c], lab.ends[c], n, lab.grid[c], b, &out, &error);
        benchmark::DoNotOptimize(out.xyz_mm.data());
      }
    }
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * lab.points));
}
BENCHMARK(BM_PayloadDecode)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

// 10 M points of a 10 x 5 x 2.5 m room (a 1 M-point source, 32 MB, appended
// ten times in 64 Ki-point chunks, as a project streams its sessions).
constexpr size_t kBenchSourcePoints = 1 << 20;
constexpr int kBenchRepeats = 10;
const std::vector<CloudPoint>& BenchCloud() {
  static const std::vector<CloudPoint>* cloud = [] {
    auto* pts = new std::vector<CloudPoint>(kBenchSourcePoints);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> x(0.0f, 10.0f), y(0.0f, 5.0f), z(0.0f, 2.5f);
    for (size_t i = 0; i < pts->size(); ++i) {
      CloudPoint& p = (*pts)[i];
      p = {x(rng), y(rng), z(rng), 3.0f, static_cast<int64_t>(i) * 200'000, static_cast<uint32_t>(i / 720),
           static_cast<uint16_t>(i % 720), 0, 0};
    }
    return pts;
  }();
  return *cloud;
}
// Arg(0): /dev/shm (tmpfs: the writer and the page cache), Arg(1): /tmp
// (the disk, with the checked writer's fsync). items/s = points written.
std::string BenchFolder(int64_t arg) { return arg == 0 ? "/dev/shm" : "/tmp"; }

// LAS 1.4 export (core/cloud/las_writer.h): PDRF 6 + 11 extra bytes, 41 bytes a point.
void BM_LasWrite(benchmark::State& state) {
  const std::vector<CloudPoint>& src = BenchCloud();
  LasWriterOptions o;
  o.extent.Add(src.data(), src.size());
  SetLasTimeFromSession("2026-11-22T10:15:00Z", o.extent, &o);
  const std::string path = BenchFolder(state.range(0)) + "/sweepscan_bench_" + std::to_string(::getpid()) + ".las";
  for (auto _ : state) {
    state.PauseTiming();
    ::unlink(path.c_str());  // Not timed: freeing the previous file's pages.
    state.ResumeTiming();
    LasWriter w;
    Status s = w.Open(path, o);
    for (int r = 0; r < kBenchRepeats && s.ok(); ++r) {
      for (size_t i = 0; i < src.size() && s.ok(); i += 65536) s = w.Append(src.data() + i, 65536);
    }
    if (s.ok()) s = w.Finish();
    if (!s.ok()) state.SkipWithError(s.message().c_str());
  }
  ::unlink(path.c_str());
  const int64_t points = static_cast<int64_t>(state.iterations()) * kBenchRepeats * static_cast<int64_t>(src.size());
  state.SetItemsProcessed(points);
  state.SetBytesProcessed(points * kLasRecordSize);
}
BENCHMARK(BM_LasWrite)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

// The same 10 M points as PLY (SaveCloud, 32 bytes a point), for comparison;
// SaveCloud takes the whole cloud in memory.
void BM_PlyWrite(benchmark::State& state) {
  std::vector<CloudPoint> all;
  for (int r = 0; r < kBenchRepeats; ++r) all.insert(all.end(), BenchCloud().begin(), BenchCloud().end());
  const std::string path = BenchFolder(state.range(0)) + "/sweepscan_bench_" + std::to_string(::getpid()) + ".ply";
  for (auto _ : state) {
    state.PauseTiming();
    ::unlink(path.c_str());
    state.ResumeTiming();
    const Status s = SaveCloud(path, all);
    if (!s.ok()) state.SkipWithError(s.message().c_str());
  }
  ::unlink(path.c_str());
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(all.size()));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(all.size()) * 32);
}
BENCHMARK(BM_PlyWrite)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace sweepscan

BENCHMARK_MAIN();
