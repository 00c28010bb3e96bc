// The evaluation's neighbour structures and stages on a scanner cloud.
//   ninja -C build-h evaluation_benchmark
//   SWEEPSCAN_EVAL_CLOUD=/tmp/evalbench/lab_215.ply build-h/tests/evaluation_benchmark
// Without SWEEPSCAN_EVAL_CLOUD the cloud is the simulated lab drive
// (tests/testing/worlds.h, 270 k points). Figures: docs/performance.md,
// "Evaluation".
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdlib>

#include "core/cloud/cloud_io.h"
#include "core/evaluation/batched_tree.h"
#include "core/evaluation/cloud_arrays.h"
#include "core/evaluation/evaluation.h"
#include "core/evaluation/neighbours.h"
#include "tests/testing/worlds.h"

namespace sweepscan {
namespace {

const std::vector<Eigen::Vector3f>& Points() {
  static const std::vector<Eigen::Vector3f> points = [] {
    std::vector<Eigen::Vector3f> pts;
    const char* path = std::getenv("SWEEPSCAN_EVAL_CLOUD");
    if (path != nullptr) {
      std::string error;
      if (ReadCloudPositions(path, &pts, &error) != CloudReadResult::kOk) {
        LoadCloudPositions(path, &pts);
      }
      return pts;
    }
    const ReconstructionResult r =
        testing::SimulateAndReconstruct(testing::LabConfig(5), PoseSource::kTruth, true);
    for (const auto& p : r.points) pts.emplace_back(p.x, p.y, p.z);
    return pts;
  }();
  return points;
}

const NeighbourBackend kBackends[] = {NeighbourBackend::kBatched, NeighbourBackend::kKdTree,
                                      NeighbourBackend::kVoxelGrid, NeighbourBackend::kPclKdTree};

// Spatial sort and structure build, one thread.
void BM_NeighbourBuild(benchmark::State& state) {
  const NeighbourBackend backend = kBackends[state.range(0)];
  state.SetLabel(NeighbourBackendName(backend));
  size_t bytes = 0;
  for (auto _ : state) {
    NeighbourIndex index;
    index.Build(Points(), backend);
    benchmark::DoNotOptimize(index.size());
    bytes = index.MemoryBytes();
  }
  // Sorted copy, order and the structure.
  state.counters["bytes_per_point"] =
      static_cast<double>(bytes) / static_cast<double>(std::max<size_t>(1, Points().size()));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * Points().size()));
}
BENCHMARK(BM_NeighbourBuild)->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->Iterations(2);

// The 21 nearest (20 and the point itself) of every point, one thread.
void BM_NeighbourQueries(benchmark::State& state) {
  const NeighbourBackend backend = kBackends[state.range(0)];
  state.SetLabel(NeighbourBackendName(backend));
  NeighbourIndex index;
  index.Build(Points(), backend);
  constexpr int k = 21;
  constexpr size_t block = 4096;
  std::vector<uint32_t> idx(block * k);
  std::vector<float> d2(block * k);
  const size_t fallbacks = BatchedKdTree::ThreadFallbacks();
  for (auto _ : state) {
    for (size_t b = 0; b < index.size(); b += block) {
      index.KnnRange(b, std::min(index.size(), b + block), k, idx.data(), d2.data());
    }
    benchmark::DoNotOptimize(d2.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * index.size()));
  // Queries the batched tree answered by a descent of their own.
  state.counters["fallbacks"] =
      static_cast<double>(BatchedKdTree::ThreadFallbacks() - fallbacks);
}
BENCHMARK(BM_NeighbourQueries)->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->Iterations(1);

// The whole evaluation on 1 and 2 threads.
void BM_EvaluateCloud(benchmark::State& state) {
  EvaluationOptions o;
  o.threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    CloudEvaluation e;
    EvaluateCloud(Points(), o, &e);
    state.counters["neighbours_s"] = e.timing.neighbours_s;
    state.counters["planes_s"] = e.timing.planes_s;
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * Points().size()));
}
BENCHMARK(BM_EvaluateCloud)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(2);

}  // namespace
}  // namespace sweepscan

BENCHMARK_MAIN();
