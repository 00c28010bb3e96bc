// The fast evaluation against known truth: on the simulated worlds its
// results equal those of the PCL version it replaced (recorded below from
// that version, commit c266598: same planes, normals within 0.01 deg,
// offsets and room dimensions within 0.1 mm, density within 0.1 %), they are
// identical on 1 and 2 threads, every neighbour backend gives the same
// neighbours, progress is monotone and ends at 1, and a cancel stops the
// evaluation within 100 ms.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <thread>

#include "core/cloud/cloud_io.h"
#include "core/evaluation/batched_tree.h"
#include "core/evaluation/cloud_arrays.h"
#include "core/evaluation/evaluation.h"
#include "tests/testing/worlds.h"

namespace sweepscan {
namespace {

struct ExpectedPlane {
  const char* kind;
  double n[3];
  double d;
  size_t count;
  double rms;
};
struct ExpectedDimension {
  int a, b;
  const char* axis;
  double distance_m;
};
struct Expected {
  size_t points_in, points_after_outliers;
  double mean_nn_m;
  std::vector<ExpectedPlane> planes;
  std::vector<ExpectedDimension> dimensions;
};

// Printed by the PCL version (StatisticalOutlierRemoval, SACSegmentation,
// KdTreeFLANN) with the default options and density over every point.
// lab5_truth
const Expected kLab5Truth = {270449, 262473, 0.012667868,
    {
        {"floor", {0.000013850, -0.000098451, 0.999999995}, 0.000020459, 116113, 0.002434334},
        {"ceiling", {0.000016339, -0.000009686, 1.000000000}, -2.499956491, 76839, 0.004808740},
        {"wall", {-0.000008722, 1.000000000, 0.000029941}, -0.000022024, 23708, 0.005289663},
        {"wall", {0.000019292, -1.000000000, 0.000007248}, 4.999846667, 20411, 0.005323730},
        {"wall", {-0.000306422, -0.999999947, 0.000111797}, 4.551995888, 6900, 0.004487953},
        {"wall", {-0.000008876, -0.999999935, 0.000359972}, 4.199855737, 5691, 0.003885664},
        {"wall", {0.000026270, -0.999999988, 0.000151026}, 0.699689437, 4724, 0.004119564},
        {"wall", {-0.999999999, -0.000051166, 0.000010214}, 10.000192790, 3671, 0.003528870},
        {"wall", {-0.000196904, -0.999866535, 0.016336264}, 0.135292143, 3422, 0.006982768},
    },
    {
        {0, 1, "vertical", 2.499738836},
        {2, 3, "horizontal", 4.999934883},
        {2, 4, "horizontal", 4.550172849},
        {2, 5, "horizontal", 4.200094222},
        {2, 6, "horizontal", 0.699943516},
        {3, 5, "horizontal", 0.799818768},
        {3, 6, "horizontal", 4.299985153},
        {3, 8, "horizontal", 4.849827159},
        {4, 6, "horizontal", 3.849824621},
        {4, 8, "horizontal", 4.403817958},
        {5, 6, "horizontal", 3.500045374},
        {5, 8, "horizontal", 4.057448965},
        {6, 8, "horizontal", 0.558049067},
    }};
// lab1_ekf
const Expected kLab1Ekf = {270377, 262498, 0.013203319,
    {
        {"floor", {0.000005336, 0.000002284, 1.000000000}, -0.000194694, 116147, 0.002438784},
        {"ceiling", {-0.000028709, 0.000044869, 0.999999999}, -2.499848297, 76823, 0.004824212},
        {"wall", {-0.001208701, 0.999999268, -0.000056483}, 0.001561341, 23674, 0.005476891},
        {"wall", {0.001314759, -0.999999135, 0.000025435}, 4.998243884, 20445, 0.005419616},
        {"wall", {-0.069962275, 0.997533471, -0.005679325}, -4.054041802, 7134, 0.016552288},
        {"wall", {-0.002343047, 0.999997255, 0.000014700}, -0.689727120, 4722, 0.004277409},
        {"wall", {-0.001528608, 0.999998805, -0.000229261}, -4.197153618, 4431, 0.003941598},
        {"wall", {-0.999998907, -0.001478500, -0.000022855}, 10.007604108, 3685, 0.003517509},
        {"wall", {0.001189591, -0.999878372, 0.015550781}, 0.133320376, 3405, 0.007063148},
    },
    {
        {0, 1, "vertical", 2.499754276},
        {2, 3, "horizontal", 5.000366740},
        {2, 5, "horizontal", 0.698848068},
        {2, 6, "horizontal", 4.200418929},
        {3, 5, "horizontal", 4.301505308},
        {3, 6, "horizontal", 0.799847928},
        {3, 8, "horizontal", 4.850528949},
        {5, 6, "horizontal", 3.502622391},
        {5, 8, "horizontal", 0.556360245},
        {6, 8, "horizontal", 4.057794551},
    }};
// circle1_truth
const Expected kCircle1Truth = {125955, 119964, 0.012874104,
    {
        {"floor", {-0.000014464, 0.000090380, 0.999999996}, -0.000182182, 54268, 0.002229439},
        {"ceiling", {0.000030153, -0.000005492, 1.000000000}, -2.500091318, 39036, 0.004674017},
        {"wall", {0.000020952, 1.000000000, 0.000021677}, -0.000215004, 9073, 0.003820307},
        {"wall", {0.004202883, 0.999868368, -0.015671055}, -0.155345138, 5587, 0.006418985},
        {"wall", {0.000085233, -0.999999996, -0.000001149}, 4.999479890, 3889, 0.006735481},
        {"wall", {-0.999999829, 0.000475167, 0.000340776}, -0.001260308, 1978, 0.009673339},
        {"wall", {-0.999999936, -0.000029932, -0.000357589}, 10.000325043, 2008, 0.009646178},
        {"wall", {0.000200293, 0.999999852, -0.000505018}, -4.200613027, 1879, 0.005205591},
    },
    {
        {0, 1, "vertical", 2.499861398},
        {2, 4, "horizontal", 4.999812515},
        {2, 7, "horizontal", 4.200029094},
        {3, 4, "horizontal", 4.848639519},
        {3, 7, "horizontal", 4.056200712},
        {4, 7, "horizontal", 0.799667672},
        {5, 6, "horizontal", 9.999736839},
    }};

// The EKF cloud with the filter the reference was made with (before the gyro
// bias state): the comparison is of the evaluation, not of the poses.
std::vector<Eigen::Vector3f> Cloud(const sim::SimConfig& config, PoseSource source) {
  const ReconstructionResult r = testing::SimulateAndReconstruct(config, source, /*deskew=*/true, {},
                                                                 /*ekf_gyro_bias=*/false);
  std::vector<Eigen::Vector3f> pts;
  pts.reserve(r.points.size());
  for (const auto& p : r.points) pts.emplace_back(p.x, p.y, p.z);
  return pts;
}

// The worlds are simulated once for all tests.
const std::vector<Eigen::Vector3f>& World(int i) {
  static const std::vector<Eigen::Vector3f>* worlds[3] = {nullptr, nullptr, nullptr};
  if (worlds[i] == nullptr) {
    switch (i) {
      case 0: worlds[i] = new std::vector<Eigen::Vector3f>(Cloud(testing::LabConfig(5), PoseSource::kTruth)); break;
      case 1: worlds[i] = new std::vector<Eigen::Vector3f>(Cloud(testing::LabConfig(1), PoseSource::kEkf)); break;
      default: worlds[i] = new std::vector<Eigen::Vector3f>(Cloud(testing::CircleConfig(1), PoseSource::kTruth)); break;
    }
  }
  return *worlds[i];
}

void ExpectEqualsToday(const std::vector<Eigen::Vector3f>& pts, const Expected& x, int threads) {
  EvaluationOptions o;
  o.threads = threads;
  CloudEvaluation e;
  ASSERT_TRUE(EvaluateCloud(pts, o, &e).ok());
  EXPECT_EQ(e.points_in, x.points_in);
  // The same statistics on the same exact neighbours; a point exactly at
  // the threshold could only flip by a rounding of the sum's order.
  EXPECT_NEAR(static_cast<double>(e.points_after_outliers),
              static_cast<double>(x.points_after_outliers), 2.0);
  EXPECT_NEAR(e.mean_nn_distance_m, x.mean_nn_m, 1e-3 * x.mean_nn_m);
  EXPECT_EQ(e.density_queries, e.points_after_outliers);
  ASSERT_EQ(e.planes.size(), x.planes.size());
  for (size_t i = 0; i < x.planes.size(); ++i) {
    const EvaluatedPlane& p = e.planes[i];
    const ExpectedPlane& q = x.planes[i];
    SCOPED_TRACE("plane " + std::to_string(i));
    EXPECT_EQ(p.kind, q.kind);
    const Eigen::Vector3d n(q.n[0], q.n[1], q.n[2]);
    const double angle_deg =
        std::acos(std::min(1.0, p.plane.normal.dot(n.normalized()))) * 180.0 / M_PI;
    EXPECT_LT(angle_deg, 0.01);
    EXPECT_NEAR(p.plane.d, q.d, 1e-4);
    EXPECT_NEAR(static_cast<double>(p.plane.count), static_cast<double>(q.count),
                0.001 * static_cast<double>(q.count) + 2.0);
    EXPECT_NEAR(p.plane.rms, q.rms, 1e-5);
    EXPECT_EQ(p.deviations.count, p.plane.count);
  }
  ASSERT_EQ(e.dimensions.size(), x.dimensions.size());
  for (size_t i = 0; i < x.dimensions.size(); ++i) {
    EXPECT_EQ(e.dimensions[i].plane_a, x.dimensions[i].a);
    EXPECT_EQ(e.dimensions[i].plane_b, x.dimensions[i].b);
    EXPECT_EQ(e.dimensions[i].axis, x.dimensions[i].axis);
    EXPECT_NEAR(e.dimensions[i].distance_m, x.dimensions[i].distance_m, 1e-4);
  }
}

TEST(EvaluationTruthTest, LabTruthPosesEqualsThePclVersion) { ExpectEqualsToday(World(0), kLab5Truth, 2); }
TEST(EvaluationTruthTest, LabEkfPosesEqualsThePclVersion) { ExpectEqualsToday(World(1), kLab1Ekf, 2); }
TEST(EvaluationTruthTest, CircleDriveEqualsThePclVersion) { ExpectEqualsToday(World(2), kCircle1Truth, 2); }
TEST(EvaluationTruthTest, OneThreadEqualsThePclVersionToo) { ExpectEqualsToday(World(0), kLab5Truth, 1); }

void ExpectIdentical(const CloudEvaluation& a, const CloudEvaluation& b) {
  EXPECT_EQ(a.points_after_outliers, b.points_after_outliers);
  EXPECT_EQ(a.mean_nn_distance_m, b.mean_nn_distance_m);  // bit for bit
  EXPECT_EQ(a.density_queries, b.density_queries);
  ASSERT_EQ(a.planes.size(), b.planes.size());
  for (size_t i = 0; i < a.planes.size(); ++i) {
    EXPECT_EQ(a.planes[i].kind, b.planes[i].kind);
    EXPECT_EQ(a.planes[i].plane.normal, b.planes[i].plane.normal);
    EXPECT_EQ(a.planes[i].plane.d, b.planes[i].plane.d);
    EXPECT_EQ(a.planes[i].plane.rms, b.planes[i].plane.rms);
    EXPECT_EQ(a.planes[i].plane.count, b.planes[i].plane.count);
    EXPECT_EQ(a.planes[i].deviations.counts, b.planes[i].deviations.counts);
    EXPECT_EQ(a.planes[i].deviations.mean_m, b.planes[i].deviations.mean_m);
    EXPECT_EQ(a.planes[i].deviations.stddev_m, b.planes[i].deviations.stddev_m);
  }
  ASSERT_EQ(a.dimensions.size(), b.dimensions.size());
  for (size_t i = 0; i < a.dimensions.size(); ++i) {
    EXPECT_EQ(a.dimensions[i].distance_m, b.dimensions[i].distance_m);
  }
}

// 1, 2 and 3 threads (3: at most the machine's cores) give the same result
// bit for bit, on every world.
TEST(EvaluationThreadsTest, IdenticalOnOneTwoAndThreeThreads) {
  for (int w = 0; w < 3; ++w) {
    SCOPED_TRACE("world " + std::to_string(w));
    CloudEvaluation r[3];
    for (int t = 1; t <= 3; ++t) {
      EvaluationOptions o;
      o.threads = t;
      ASSERT_TRUE(EvaluateCloud(World(w), o, &r[t - 1]).ok());
      EXPECT_EQ(r[t - 1].timing.threads,
                std::min(t, static_cast<int>(std::max(1u, std::thread::hardware_concurrency()))));
    }
    ExpectIdentical(r[0], r[1]);
    ExpectIdentical(r[0], r[2]);
  }
}

// The four neighbour structures are exact: the same outliers and density.
TEST(NeighbourIndexTest, BackendsAgree) {
  const auto& pts = World(0);
  CloudEvaluation r[4];
  const NeighbourBackend backends[4] = {NeighbourBackend::kBatched, NeighbourBackend::kKdTree,
                                        NeighbourBackend::kVoxelGrid, NeighbourBackend::kPclKdTree};
  for (int b = 0; b < 4; ++b) {
    EvaluationOptions o;
    o.neighbours = backends[b];
    ASSERT_TRUE(EvaluateCloud(pts, o, &r[b]).ok()) << NeighbourBackendName(backends[b]);
  }
  for (int b = 1; b < 4; ++b) {
    SCOPED_TRACE(NeighbourBackendName(backends[b]));
    EXPECT_EQ(r[b].points_after_outliers, r[0].points_after_outliers);
    EXPECT_NEAR(r[b].mean_nn_distance_m, r[0].mean_nn_distance_m, 1e-9);
    ASSERT_EQ(r[b].planes.size(), r[0].planes.size());
    for (size_t i = 0; i < r[0].planes.size(); ++i) {
      EXPECT_EQ(r[b].planes[i].plane.count, r[0].planes[i].plane.count);
    }
  }
}

// Brute force on random points with duplicates and clusters: every
// backend returns the k smallest distances.
TEST(NeighbourIndexTest, KnnMatchesBruteForce) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f);
  std::normal_distribution<float> g(0.0f, 0.01f);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 3000; ++i) pts.emplace_back(u(rng), u(rng), 0.1f * u(rng));
  for (int i = 0; i < 2000; ++i) pts.emplace_back(1.0f + g(rng), g(rng), g(rng));
  for (int i = 0; i < 50; ++i) pts.push_back(pts[static_cast<size_t>(i) * 7]);  // duplicates
  pts.emplace_back(40.0f, 40.0f, 40.0f);                                         // far away
  const int k = 12;
  for (NeighbourBackend b : {NeighbourBackend::kBatched, NeighbourBackend::kKdTree,
                             NeighbourBackend::kVoxelGrid, NeighbourBackend::kPclKdTree}) {
    SCOPED_TRACE(NeighbourBackendName(b));
    NeighbourIndex index;
    ASSERT_TRUE(index.Build(pts, b));
    // Every point at once, in blocks of an odd size: the range queries the
    // evaluation makes (KnnRange) against brute force.
    const size_t block = 1000 + 3;
    std::vector<uint32_t> ri(block * k);
    std::vector<float> rd(block * k);
    for (size_t begin = 0; begin < index.size(); begin += block) {
      const size_t end = std::min(index.size(), begin + block);
      index.KnnRange(begin, end, k, ri.data(), rd.data());
      for (size_t s = begin; s < end; s += 5) {
        const Eigen::Vector3f q(index.sorted_point(s));
        std::vector<float> truth;
        for (const auto& p : pts) truth.push_back((p - q).squaredNorm());
        std::partial_sort(truth.begin(), truth.begin() + k, truth.end());
        for (int j = 0; j < k; ++j) {
          ASSERT_FLOAT_EQ(rd[(s - begin) * k + j], truth[static_cast<size_t>(j)]) << s << " " << j;
          const Eigen::Vector3f p(index.sorted_point(ri[(s - begin) * k + j]));
          ASSERT_FLOAT_EQ((p - q).squaredNorm(), rd[(s - begin) * k + j]);
        }
      }
    }
    for (size_t i = 0; i < pts.size(); i += 37) {
      std::vector<float> truth;
      for (const auto& p : pts) truth.push_back((p - pts[i]).squaredNorm());
      std::sort(truth.begin(), truth.end());
      uint32_t idx[k];
      float d2[k];
      ASSERT_EQ(index.Knn(pts[i].data(), k, idx, d2), k);
      for (int j = 0; j < k; ++j) {
        EXPECT_NEAR(d2[j], truth[static_cast<size_t>(j)], 1e-6f) << i << " " << j;
        const Eigen::Vector3f p(index.sorted_point(idx[j]));
        EXPECT_EQ(p, pts[index.order()[idx[j]]]);
      }
    }
  }
}

// The batched tree's two kernels (AVX2 and portable) and its fallback:
// a sparse slab next to a dense cluster, so that a group's radius guessed
// from its neighbour is often too small, every point against brute force,
// and the two kernels equal bit for bit.
TEST(NeighbourIndexTest, BatchedKernelsAndFallbackAreExact) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> g(0.0f, 0.002f);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 4000; ++i) pts.emplace_back(4.0f * u(rng), 4.0f * u(rng), 0.05f * u(rng));
  for (int c = 0; c < 6; ++c) {  // dense blobs inside the slab
    const Eigen::Vector3f centre(4.0f * u(rng), 4.0f * u(rng), 0.02f);
    for (int i = 0; i < 500; ++i) pts.push_back(centre + Eigen::Vector3f(g(rng), g(rng), g(rng)));
  }
  for (int i = 0; i < 30; ++i) pts.push_back(pts[static_cast<size_t>(i) * 101]);  // duplicates
  const int k = 21;
  NeighbourIndex index;
  ASSERT_TRUE(index.Build(pts, NeighbourBackend::kBatched));
  const size_t n = index.size();
  std::vector<uint32_t> idx[2];
  std::vector<float> d2[2];
  const size_t fallbacks = BatchedKdTree::ThreadFallbacks();
  for (int pass = 0; pass < 2; ++pass) {
    BatchedKdTree::AllowAvx2(pass == 0);
    idx[pass].resize(n * k);
    d2[pass].resize(n * k);
    for (size_t b = 0; b < n; b += 4096) {
      const size_t e = std::min(n, b + 4096);
      index.KnnRange(b, e, k, &idx[pass][b * k], &d2[pass][b * k]);
    }
  }
  BatchedKdTree::AllowAvx2(true);
  EXPECT_GT(BatchedKdTree::ThreadFallbacks(), fallbacks) << "the fallback was not exercised";
  EXPECT_EQ(d2[0], d2[1]);
  for (size_t s = 0; s < n; ++s) {
    const Eigen::Vector3f q(index.sorted_point(s));
    std::vector<float> truth;
    for (size_t t = 0; t < n; ++t) truth.push_back((Eigen::Vector3f(index.sorted_point(t)) - q).squaredNorm());
    std::partial_sort(truth.begin(), truth.begin() + k, truth.end());
    for (int j = 0; j < k; ++j) {
      ASSERT_FLOAT_EQ(d2[0][s * k + j], truth[static_cast<size_t>(j)]) << s << " " << j;
      const Eigen::Vector3f p(index.sorted_point(idx[0][s * k + j]));
      ASSERT_FLOAT_EQ((p - q).squaredNorm(), d2[0][s * k + j]);
    }
  }
}

TEST(EvaluationProgressTest, MonotoneStagesInOrderEndsAtOne) {
  std::vector<EvaluationProgress> seen;
  EvaluationControl control;
  control.progress = [&](const EvaluationProgress& p) {
    seen.push_back(p);  // called one call at a time
    return true;
  };
  EvaluationOptions o;
  o.threads = 2;
  CloudEvaluation e;
  ASSERT_TRUE(EvaluateCloud(World(0), o, &e, control).ok());
  ASSERT_GE(seen.size(), 5u);
  for (size_t i = 1; i < seen.size(); ++i) {
    EXPECT_GE(seen[i].fraction, seen[i - 1].fraction) << i;
    EXPECT_GE(static_cast<int>(seen[i].stage), static_cast<int>(seen[i - 1].stage)) << i;
    if (seen[i].stage == seen[i - 1].stage) {
      EXPECT_GE(seen[i].stage_fraction, seen[i - 1].stage_fraction) << i;
    }
  }
  std::map<EvaluationStage, int> stages;
  for (const auto& p : seen) {
    ++stages[p.stage];
    EXPECT_GE(p.fraction, 0.0);
    EXPECT_LE(p.fraction, 1.0);
  }
  EXPECT_EQ(stages.size(), 5u);  // every stage reported
  EXPECT_EQ(seen.front().fraction, 0.0);
  EXPECT_EQ(seen.back().stage, EvaluationStage::kDone);
  EXPECT_EQ(seen.back().fraction, 1.0);
  EXPECT_EQ(stages[EvaluationStage::kDone], 1);
}

// A larger cloud (the lab drive repeated four times, shifted by 1 mm, about
// a million points) so that every stage runs long enough to be cancelled in.
std::vector<Eigen::Vector3f> BigCloud() {
  std::vector<Eigen::Vector3f> pts;
  for (int copy = 0; copy < 4; ++copy) {
    for (const auto& p : World(0)) pts.push_back(p + Eigen::Vector3f(0.001f * copy, 0.0f, 0.0f));
  }
  return pts;
}

// Cancelled from the callback in each stage: the evaluation returns within
// 100 ms with kEvaluationCancelled, and reports nothing after it.
TEST(EvaluationCancelTest, StopsWithin100msOfACancelInEveryStage) {
  const std::vector<Eigen::Vector3f> pts = BigCloud();
  for (EvaluationStage stage : {EvaluationStage::kNeighbours, EvaluationStage::kOutliers,
                                EvaluationStage::kDensity, EvaluationStage::kPlanes}) {
    SCOPED_TRACE(EvaluationStageName(stage));
    using Clock = std::chrono::steady_clock;
    Clock::time_point cancelled_at{};
    bool cancelled = false;
    int calls_after = 0;
    EvaluationControl control;
    control.progress = [&](const EvaluationProgress& p) {
      if (cancelled) {
        ++calls_after;
        return false;
      }
      if (p.stage == stage && (p.stage_fraction >= 0.3 || stage == EvaluationStage::kOutliers ||
                               stage == EvaluationStage::kDensity)) {
        cancelled = true;
        cancelled_at = Clock::now();
        return false;
      }
      return true;
    };
    EvaluationOptions o;
    o.threads = 2;
    CloudEvaluation e;
    const Status s = EvaluateCloud(pts, o, &e, control);
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - cancelled_at).count();
    ASSERT_TRUE(cancelled);
    EXPECT_FALSE(s.ok());
    EXPECT_EQ(s.message(), kEvaluationCancelled);
    EXPECT_LT(ms, 100.0);
    std::printf("[cancel] %s: returned %.1f ms after the cancel\n", EvaluationStageName(stage), ms);
  }
}

// Cancelled through the flag from another thread, while it runs.
TEST(EvaluationCancelTest, FlagFromAnotherThread) {
  const std::vector<Eigen::Vector3f> pts = BigCloud();
  std::atomic<bool> cancel{false};
  EvaluationControl control;
  control.cancel = &cancel;
  using Clock = std::chrono::steady_clock;
  Clock::time_point cancelled_at{};
  std::thread canceller([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    cancelled_at = Clock::now();
    cancel = true;
  });
  CloudEvaluation e;
  const Status s = EvaluateCloud(pts, EvaluationOptions(), &e, control);
  const auto returned = Clock::now();
  canceller.join();
  EXPECT_EQ(s.message(), kEvaluationCancelled);
  const double ms = std::chrono::duration<double, std::milli>(returned - cancelled_at).count();
  EXPECT_LT(ms, 100.0);
}

// The direct reader gives the same points as PCL's, for PLY and PCD.
TEST(CloudArraysTest, ReadsWhatSaveCloudWrites) {
  const ReconstructionResult r =
      testing::SimulateAndReconstruct(testing::CircleConfig(2), PoseSource::kTruth, true);
  std::vector<CloudPoint> cloud(r.points.begin(), r.points.begin() + 5000);
  cloud[10].x = std::nanf("");  // dropped by both readers
  for (const char* ext : {".ply", ".pcd"}) {
    const std::string path = ::testing::TempDir() + "/cloud_arrays" + ext;
    ASSERT_TRUE(SaveCloud(path, cloud).ok());
    std::vector<Eigen::Vector3f> direct, pcl;
    std::string error;
    ASSERT_EQ(ReadCloudPositions(path, &direct, &error), CloudReadResult::kOk) << error;
    ASSERT_TRUE(LoadCloudPositions(path, &pcl).ok());
    ASSERT_EQ(direct.size(), 4999u);
    EXPECT_EQ(direct, pcl);
    std::remove(path.c_str());
  }
  std::vector<Eigen::Vector3f> none;
  std::string error;
  EXPECT_EQ(ReadCloudPositions("/nonexistent.ply", &none, &error), CloudReadResult::kError);
  EXPECT_EQ(ReadCloudPositions("x.xyz", &none, &error), CloudReadResult::kUnsupported);
}

}  // namespace
}  // namespace sweepscan
