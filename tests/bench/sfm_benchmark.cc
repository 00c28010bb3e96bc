// Lidar-only SfM benchmarks (issue 12). Run (one core):
//   cmake --build build --target sfm_benchmark && build/tests/sfm_benchmark
// Figures are recorded in docs/performance.md ("Lidar-only SfM").
#include <benchmark/benchmark.h>

#include <random>

#include "core/sfm/p3l.h"
#include "core/sfm/refine.h"
#include "core/sfm/rig_scenario.h"
#include "core/sfm/synthetic.h"

namespace sweepscan::sfm {
namespace {

std::vector<SyntheticProblem> Problems(double noise) {
  std::mt19937_64 rng(42);
  SyntheticOptions o;
  o.noise_width_m = noise;
  std::vector<SyntheticProblem> v;
  for (int i = 0; i < 1000; ++i) v.push_back(MakeSyntheticProblem(o, &rng));
  return v;
}

// The whole minimal solve (polynomial, companion-matrix roots, rotations,
// polishing, translation, Eq. 37, ranking by a fourth correspondence).
// items/s = minimal solves per second.
void BM_P3lSolve(benchmark::State& state) {
  const std::vector<SyntheticProblem> problems = Problems(state.range(0) * 1e-3);
  size_t i = 0, candidates = 0;
  std::vector<PoseCandidate> out;
  for (auto _ : state) {
    const SyntheticProblem& sp = problems[i++ % problems.size()];
    SolveP3l(sp.planes, sp.lines, {}, sp.disambiguation, &out);
    candidates += out.size();
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["candidates"] = static_cast<double>(candidates) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_P3lSolve)->Arg(0)->Arg(20);

// Rotations only (Eq. 4-35).
void BM_P3lRotations(benchmark::State& state) {
  const std::vector<SyntheticProblem> problems = Problems(0.0);
  size_t i = 0;
  for (auto _ : state) {
    const SyntheticProblem& sp = problems[i++ % problems.size()];
    const std::array<Eigen::Vector3d, 3> n = {sp.planes[0].normal, sp.planes[1].normal, sp.planes[2].normal};
    const std::array<Eigen::Vector3d, 3> u = {sp.lines[0].direction, sp.lines[1].direction, sp.lines[2].direction};
    benchmark::DoNotOptimize(SolveP3lRotations(n, u).size());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_P3lRotations);

// The sequence pipeline on a simulated rig (core/sim/rig.h): arg 0 the room
// walk (650 frames, 1300 scans), arg 1 the stairwell walk (1750 frames,
// 3500 scans). BM_SequenceTracking: line extraction, association, pose
// updates and plane discovery (no refinement). BM_SequenceRefinement: one
// joint refinement (Eq. 40, Ceres, two threads) of every pose and plane
// from the tracked poses.
struct SequenceData {
  sim::RigSimConfig config;
  sim::RigRun run;
  std::vector<Scan> scans;
  Rig rig;
  SequenceInit init;
  SequenceResult tracked;  // refine_passes = 0
};

const SequenceData& Data(int which) {
  static SequenceData data[2];
  static bool ready[2] = {false, false};
  SequenceData& d = data[which];
  if (!ready[which]) {
    d.config = which == 0 ? sim::SmallRoomRigScenario() : sim::StairwellRigScenario();
    d.run = sim::SimulateRig(d.config);
    d.scans = ScansFromRigRun(d.run);
    d.rig = RigFromRigRun(d.run);
    InitFromTruth(d.run, d.config.scene, true, {}, &d.init, nullptr);
    SequenceOptions o;
    o.refine_passes = 0;
    RunSequence(d.scans, d.rig, d.init, o, &d.tracked);
    ready[which] = true;
  }
  return d;
}

void BM_SequenceTracking(benchmark::State& state) {
  const SequenceData& d = Data(static_cast<int>(state.range(0)));
  SequenceOptions o;
  o.refine_passes = 0;
  SequenceResult r;
  for (auto _ : state) {
    RunSequence(d.scans, d.rig, d.init, o, &r);
    benchmark::DoNotOptimize(r.tracked.data());
  }
  state.counters["scans"] = static_cast<double>(d.scans.size());
  state.counters["planes"] = static_cast<double>(r.planes.size());
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * d.scans.size()));
}
BENCHMARK(BM_SequenceTracking)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_SequenceRefinement(benchmark::State& state) {
  const SequenceData& d = Data(static_cast<int>(state.range(0)));
  RefineOptions ro;
  ro.threads = 2;
  ro.fixed_planes = {0, 1, 2};
  for (auto _ : state) {
    std::vector<Rigid3d> poses = d.tracked.tracked;
    std::vector<WorldPlane> planes;
    for (const FoundPlane& fp : d.tracked.planes) planes.push_back(fp.plane);
    RefineSummary summary;
    RefinePosesAndPlanes(d.tracked.lines, ro, &poses, &planes, &summary);
    benchmark::DoNotOptimize(poses.data());
    state.counters["iterations"] = summary.iterations;
    state.counters["lines"] = summary.residual_blocks;
  }
  state.counters["frames"] = static_cast<double>(d.tracked.tracked.size());
}
BENCHMARK(BM_SequenceRefinement)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace sweepscan::sfm

BENCHMARK_MAIN();
