// Registration of the office floor's drives b -> a (tests/testing/worlds.h,
// truth poses): our robust point-to-plane ICP against PCL 1.13's
// GeneralizedIterativeClosestPoint and IterativeClosestPointWithNormals
// (point-to-plane), on the same downsampled clouds, from the same initial
// pose (the truth turned 5 deg and moved 0.3 m), each to convergence.
// Counters: final error against the truth (mm, deg). Every PCL template of
// the benchmarks lives in this one file (compile time).
//   ninja -C build registration_benchmark && build/tests/core/registration/registration_benchmark
// Figures: docs/performance.md, "Registration".
#include <benchmark/benchmark.h>

// GCC 12 reports -Warray-bounds inside Eigen's SSE copies of 3-float
// vectors as PCL's GICP and normal estimation instantiate them: a false
// positive in third-party templates (core/pose/ekf.cc has the same), silenced
// for this file, whose code is the benchmarks only.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Warray-bounds"
#endif

#include <pcl/features/normal_3d.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>
#include <pcl/registration/icp.h>

#include "core/registration/registration.h"
#include "tests/testing/worlds.h"

namespace sweepscan {
namespace {

constexpr double kVoxel = 0.05;

struct Clouds {
  std::vector<Eigen::Vector3f> a, b;  // downsampled, each in its session's frame
  Rigid3d truth;                      // a_from_b
  Rigid3d initial;
};

std::vector<Eigen::Vector3f> SessionCloud(const sim::SimConfig& c, const Rigid3d& start) {
  const ReconstructionResult r = testing::SimulateAndReconstruct(c, PoseSource::kTruth, true);
  const Rigid3d session_from_world = start.inverse();
  std::vector<Eigen::Vector3f> out;
  for (const CloudPoint& p : r.points) {
    out.push_back((session_from_world * Eigen::Vector3d(p.x, p.y, p.z)).cast<float>());
  }
  return VoxelCentroids(out, kVoxel);
}

const Clouds& Data() {
  static const Clouds clouds = [] {
    Clouds c;
    const sim::SimConfig ca = testing::BuildingConfig('a'), cb = testing::BuildingConfig('b');
    const Rigid3d sa = Rigid3d::FromPose(ca.start.x, ca.start.y, 0, 0, 0, ca.start.yaw);
    const Rigid3d sb = Rigid3d::FromPose(cb.start.x, cb.start.y, 0, 0, 0, cb.start.yaw);
    c.a = SessionCloud(ca, sa);
    c.b = SessionCloud(cb, sb);
    c.truth = sa.inverse() * sb;
    c.initial = Rigid3d::FromPose(0.2, -0.2, 0.05, 0, 0, 5.0 * M_PI / 180.0) * c.truth;
    return c;
  }();
  return clouds;
}

void Report(benchmark::State& state, const Rigid3d& result) {
  const Clouds& c = Data();
  state.counters["err_mm"] = 1000.0 * (result.translation() - c.truth.translation()).norm();
  state.counters["err_deg"] = result.rotation().angularDistance(c.truth.rotation()) * 180.0 / M_PI;
  state.counters["source_pts"] = static_cast<double>(c.b.size());
  state.counters["target_pts"] = static_cast<double>(c.a.size());
}

Rigid3d FromMatrix(const Eigen::Matrix4f& m) {
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>().cast<double>();
  return Rigid3d(m.topRightCorner<3, 1>().cast<double>(), Eigen::Quaterniond(r));
}

void BM_OurIcp(benchmark::State& state) {
  const Clouds& c = Data();
  IcpOptions o;
  o.source_voxel_m = o.target_voxel_m = 0.0;  // already downsampled
  o.threads = static_cast<int>(state.range(0));
  RegistrationResult r;
  for (auto _ : state) {
    const Status s = RefineIcp(c.b, c.a, c.initial, o, {}, &r);
    if (!s.ok()) state.SkipWithError(s.message().c_str());
  }
  Report(state, r.target_from_source);
  state.counters["iterations"] = r.iterations;
}
BENCHMARK(BM_OurIcp)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

template <typename Point>
typename pcl::PointCloud<Point>::Ptr ToPcl(const std::vector<Eigen::Vector3f>& pts) {
  typename pcl::PointCloud<Point>::Ptr cloud(new pcl::PointCloud<Point>);
  cloud->resize(pts.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    (*cloud)[i].x = pts[i].x();
    (*cloud)[i].y = pts[i].y();
    (*cloud)[i].z = pts[i].z();
  }
  return cloud;
}

// Same schedule as ours where PCL has one: 1 m correspondence distance (the
// initial error is 0.3 m / 5 deg, up to 0.9 m at 10 m), up to 60 iterations.
template <typename Registration>
void Configure(Registration* reg) {
  reg->setMaxCorrespondenceDistance(1.0);
  reg->setMaximumIterations(60);
  reg->setTransformationEpsilon(1e-10);
  reg->setEuclideanFitnessEpsilon(1e-10);
}

void BM_PclGicp(benchmark::State& state) {
  const Clouds& c = Data();
  const auto source = ToPcl<pcl::PointXYZ>(c.b), target = ToPcl<pcl::PointXYZ>(c.a);
  Eigen::Matrix4f result = Eigen::Matrix4f::Identity();
  for (auto _ : state) {
    pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> gicp;
    Configure(&gicp);
    gicp.setInputSource(source);
    gicp.setInputTarget(target);
    pcl::PointCloud<pcl::PointXYZ> aligned;
    gicp.align(aligned, c.initial.ToIsometry().matrix().cast<float>());
    result = gicp.getFinalTransformation();
  }
  Report(state, FromMatrix(result));
}
BENCHMARK(BM_PclGicp)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

void BM_PclIcpWithNormals(benchmark::State& state) {
  const Clouds& c = Data();
  Eigen::Matrix4f result = Eigen::Matrix4f::Identity();
  for (auto _ : state) {
    // Normals of both clouds from 12 neighbours (ours: the target's, 12).
    const auto source = ToPcl<pcl::PointNormal>(c.b), target = ToPcl<pcl::PointNormal>(c.a);
    for (const auto& cloud : {source, target}) {
      pcl::NormalEstimation<pcl::PointNormal, pcl::PointNormal> ne;
      ne.setInputCloud(cloud);
      ne.setKSearch(12);
      ne.compute(*cloud);
    }
    pcl::IterativeClosestPointWithNormals<pcl::PointNormal, pcl::PointNormal> icp;
    Configure(&icp);
    icp.setInputSource(source);
    icp.setInputTarget(target);
    pcl::PointCloud<pcl::PointNormal> aligned;
    icp.align(aligned, c.initial.ToIsometry().matrix().cast<float>());
    result = icp.getFinalTransformation();
  }
  Report(state, FromMatrix(result));
}
BENCHMARK(BM_PclIcpWithNormals)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

}  // namespace
}  // namespace sweepscan

BENCHMARK_MAIN();
