// Results, options, voxel downsampling and the shared machinery of the
// registration (internal.h): progress and cancel, deterministic parallel
// loops, target normals, the point-to-plane normal equations and their
// degeneracy analysis.
#include "core/registration/registration.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <sstream>
#include <thread>

#include "core/geometry/skew.h"
#include "core/registration/internal.h"

namespace sweepscan {

const char* const kRegistrationCancelled = "registration cancelled";

const char* RegistrationStageName(RegistrationStage stage) {
  switch (stage) {
    case RegistrationStage::kPrepare: return "prepare";
    case RegistrationStage::kPlanes: return "planes";
    case RegistrationStage::kHypotheses: return "hypotheses";
    case RegistrationStage::kIcp: return "icp";
    case RegistrationStage::kDone: return "done";
  }
  return "?";
}

namespace {
// The 1-sigma along the block's worst direction (its largest eigenvalue), as
// the project file's evidence reports it (RegistrationEvidence), so that
// `project align` and `project info` give the same figure.
double WorstSigma(const Eigen::Matrix3d& block) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(0.5 * (block + block.transpose()));
  return std::sqrt(std::max(0.0, es.eigenvalues().maxCoeff()));
}
}  // namespace

double RegistrationResult::RotationSigmaDeg() const {
  return WorstSigma(covariance.topLeftCorner<3, 3>()) * 180.0 / M_PI;
}

double RegistrationResult::TranslationSigmaM() const {
  return WorstSigma(covariance.bottomRightCorner<3, 3>());
}

std::string RegistrationResult::Report() const {
  const Eigen::Vector3d rpy = RollPitchYawFromQuaternion(target_from_source.rotation());
  const Eigen::Vector3d& t = target_from_source.translation();
  char buf[512];
  std::snprintf(buf, sizeof(buf),
                "method %s\n"
                "translation m: %.4f %.4f %.4f\n"
                "roll pitch yaw deg: %.4f %.4f %.4f\n"
                "sigma: %.4f deg, %.4f m\n"
                "rms m: %.4f  overlap: %.3f  correspondences: %zu  iterations: %d\n",
                method.c_str(), t.x(), t.y(), t.z(), rpy[0] * 180 / M_PI, rpy[1] * 180 / M_PI,
                rpy[2] * 180 / M_PI, RotationSigmaDeg(), TranslationSigmaM(), rms_m, overlap,
                correspondences, iterations);
  std::string s = buf;
  if (method == "planes") {
    std::snprintf(buf, sizeof(buf), "score best %.3f, next distinct %.3f\n", best_score,
                  second_score);
    s += buf;
  }
  if (degenerate) {
    s += std::string(free_is_rotation ? "free rotation axis " : "free direction ") +
         registration_internal::FormatDirection(free_direction) + "\n";
  }
  return s;
}

bool PlaneAlignOptions::IsValid(std::string* error) const {
  const auto fail = [&](const char* m) {
    if (error != nullptr) *error = m;
    return false;
  };
  if (!(voxel_m > 0.0)) return fail("voxel_m must be > 0");
  if (!(plane_distance_m > 0.0)) return fail("plane_distance_m must be > 0");
  if (max_planes < 3) return fail("max_planes must be >= 3");
  if (!(min_plane_fraction > 0.0 && min_plane_fraction < 1.0))
    return fail("min_plane_fraction must be in (0, 1)");
  if (!(classify_angle_deg > 0.0 && classify_angle_deg < 45.0))
    return fail("classify_angle_deg must be in (0, 45)");
  if (!(floor_agreement_deg > 0.0)) return fail("floor_agreement_deg must be > 0");
  if (!(min_wall_angle_deg > 0.0 && min_wall_angle_deg <= 90.0))
    return fail("min_wall_angle_deg must be in (0, 90]");
  if (!(angle_tolerance_deg > 0.0)) return fail("angle_tolerance_deg must be > 0");
  if (!(inlier_distance_m > 0.0 && inlier_plane_m > 0.0)) return fail("inlier distances must be > 0");
  if (!(conflict_distance_m >= inlier_distance_m)) return fail("conflict_distance_m must be >= inlier_distance_m");
  if (!(thin_wall_m >= 0.0)) return fail("thin_wall_m must be >= 0");
  if (!(conflict_weight >= 0.0)) return fail("conflict_weight must be >= 0");
  if (coarse_samples < 10 || score_samples < 10) return fail("samples must be >= 10");
  if (rescore_count < 2) return fail("rescore_count must be >= 2");
  if (polish_iterations < 0) return fail("polish_iterations must be >= 0");
  if (!(min_overlap > 0.0 && min_overlap < 1.0)) return fail("min_overlap must be in (0, 1)");
  if (!(min_score_ratio >= 1.0)) return fail("min_score_ratio must be >= 1");
  if (!(distinct_yaw_deg > 0.0 && distinct_translation_m > 0.0))
    return fail("distinct_yaw_deg and distinct_translation_m must be > 0");
  return true;
}

bool PairAlignOptions::IsValid(std::string* error) const {
  if (!(min_spread_m > 0.0) || !(pick_sigma_m >= 0.0)) {
    if (error != nullptr) *error = "min_spread_m must be > 0 and pick_sigma_m >= 0";
    return false;
  }
  return true;
}

bool IcpOptions::IsValid(std::string* error) const {
  const auto fail = [&](const char* m) {
    if (error != nullptr) *error = m;
    return false;
  };
  if (!(source_voxel_m >= 0.0 && target_voxel_m >= 0.0)) return fail("voxels must be >= 0");
  if (normal_k < 3) return fail("normal_k must be >= 3");
  if (!(max_surface_variation > 0.0)) return fail("max_surface_variation must be > 0");
  if (!(min_distance_m > 0.0 && max_distance_m >= min_distance_m))
    return fail("need 0 < min_distance_m <= max_distance_m");
  if (!(distance_shrink > 0.0 && distance_shrink <= 1.0)) return fail("distance_shrink must be in (0, 1]");
  if (!(robust_k > 0.0 && min_scale_m > 0.0)) return fail("robust_k and min_scale_m must be > 0");
  if (max_iterations < 1) return fail("max_iterations must be >= 1");
  if (!(degeneracy_threshold > 0.0)) return fail("degeneracy_threshold must be > 0");
  if (!(covariance_cluster_m >= 0.0)) return fail("covariance_cluster_m must be >= 0");
  if (!(pair_sigma_m > 0.0)) return fail("pair_sigma_m must be > 0");
  return true;
}

std::vector<Eigen::Vector3f> VoxelCentroids(const std::vector<Eigen::Vector3f>& points,
                                             double voxel_m) {
  if (points.empty() || !(voxel_m > 0.0)) return points;
  Eigen::Vector3f lo = points[0];
  for (const auto& p : points) lo = lo.cwiseMin(p);
  // 21 bits a coordinate: 2^21 voxels of 1 cm is 20 km, far beyond a floor.
  std::vector<std::pair<uint64_t, uint32_t>> keys(points.size());
  const double inv = 1.0 / voxel_m;
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d c = ((points[i] - lo).cast<double>() * inv).array().floor();
    const auto k = [](double v) { return static_cast<uint64_t>(std::min(v, 2097151.0)); };
    keys[i] = {(k(c.x()) << 42) | (k(c.y()) << 21) | k(c.z()), static_cast<uint32_t>(i)};
  }
  std::sort(keys.begin(), keys.end());
  std::vector<Eigen::Vector3f> out;
  for (size_t a = 0; a < keys.size();) {
    size_t b = a;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (; b < keys.size() && keys[b].first == keys[a].first; ++b) {
      sum += points[keys[b].second].cast<double>();
    }
    out.push_back((sum / static_cast<double>(b - a)).cast<float>());
    a = b;
  }
  return out;
}

namespace registration_internal {

struct Control::Arena {
  explicit Arena(int n) : arena(n) {}
  tbb::task_arena arena;
};

Control::Control(const RegistrationControl& control, int threads) : control_(control) {
  const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  threads_ = threads > 0 ? std::min(threads, cores) : cores;
  arena_ = std::make_unique<Arena>(threads_);
}

Control::~Control() = default;

bool Control::Cancelled() const {
  if (cancelled_.load(std::memory_order_relaxed)) return true;
  return control_.cancel != nullptr && control_.cancel->load(std::memory_order_relaxed);
}

bool Control::For(size_t n, size_t block, const std::function<void(size_t, size_t, size_t)>& body) {
  if (Cancelled()) return false;
  const size_t blocks = Blocks(n, block);
  const auto run = [&](size_t b) {
    if (Cancelled()) return;
    const size_t begin = b * block;
    body(b, begin, std::min(n, begin + block));
  };
  if (threads_ == 1 || blocks <= 1) {
    for (size_t b = 0; b < blocks; ++b) run(b);
  } else {
    arena_->arena.execute([&] {
      tbb::parallel_for(
          tbb::blocked_range<size_t>(0, blocks, 1),
          [&](const tbb::blocked_range<size_t>& r) {
            for (size_t b = r.begin(); b != r.end(); ++b) run(b);
          },
          tbb::simple_partitioner());
    });
  }
  return !Cancelled();
}

NeighbourIndex::ParallelFor Control::ForFunction() {
  return [this](size_t n, size_t block, const std::function<void(size_t, size_t, size_t)>& body) {
    return For(n, block, body);
  };
}

bool Control::Report(RegistrationStage stage, double fraction, int iteration, double rms_m,
                     bool force) {
  if (Cancelled()) return false;
  if (!control_.progress) return true;
  std::lock_guard<std::mutex> lock(mutex_);
  const auto now = std::chrono::steady_clock::now();
  if (!force && now - last_report_ < std::chrono::milliseconds(20)) return true;
  last_fraction_ = std::max(last_fraction_, std::clamp(fraction, 0.0, 1.0));
  last_report_ = now;
  RegistrationProgress p;
  p.stage = stage;
  p.fraction = last_fraction_;
  p.iteration = iteration;
  p.rms_m = rms_m;
  if (!control_.progress(p)) cancelled_.store(true, std::memory_order_relaxed);
  return !Cancelled();
}

bool BuildSurface(const std::vector<Eigen::Vector3f>& points, int k, Control* control,
                  Surface* surface) {
  if (!surface->index.Build(points, NeighbourBackend::kBatched, control->ForFunction())) return false;
  const size_t n = points.size();
  const int kk = static_cast<int>(std::min<size_t>(static_cast<size_t>(k), n));
  surface->normals.assign(n, Eigen::Vector3f::UnitZ());
  surface->variation.assign(n, 1.0f);
  if (kk < 3) return true;
  return control->For(n, 4096, [&](size_t, size_t begin, size_t end) {
    std::vector<uint32_t> idx((end - begin) * kk);
    std::vector<float> d2((end - begin) * kk);
    surface->index.KnnRange(begin, end, kk, idx.data(), d2.data());
    for (size_t s = begin; s < end; ++s) {
      // PCA of the neighbourhood: the normal is the eigenvector of the
      // smallest eigenvalue of the covariance (core/geometry/plane.h).
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      const uint32_t* pi = &idx[(s - begin) * kk];
      for (int j = 0; j < kk; ++j) {
        const float* p = surface->index.sorted_point(pi[j]);
        mean += Eigen::Vector3d(p[0], p[1], p[2]);
      }
      mean /= kk;
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (int j = 0; j < kk; ++j) {
        const float* p = surface->index.sorted_point(pi[j]);
        const Eigen::Vector3d d = Eigen::Vector3d(p[0], p[1], p[2]) - mean;
        cov += d * d.transpose();
      }
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
      es.computeDirect(cov);
      const Eigen::Vector3d ev = es.eigenvalues().cwiseMax(0.0);
      const double sum = ev.sum();
      surface->normals[s] = es.eigenvectors().col(0).normalized().cast<float>();
      surface->variation[s] = sum > 0.0 ? static_cast<float>(ev[0] / sum) : 1.0f;
    }
  });
}

Rigid3d LeftUpdate(const Vector6d& xi, const Rigid3d& t) {
  const Eigen::Vector3d w = xi.head<3>();
  const double angle = w.norm();
  const Eigen::Quaterniond r =
      angle > 0.0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle)) : Eigen::Quaterniond::Identity();
  return Rigid3d(xi.tail<3>(), r) * t;
}

Vector6d GaussNewtonStep(const NormalSums& sums, const Degeneracy& degeneracy) {
  if (!(sums.w > 0.0)) return Vector6d::Zero();
  const Vector6d gn = degeneracy.basis.transpose() * sums.g / sums.w;
  Vector6d xin = Vector6d::Zero();
  for (int i = degeneracy.free_count; i < 6; ++i) {
    const Vector6d u = degeneracy.eigenvectors.col(i);
    xin -= u * (u.dot(gn) / degeneracy.eigenvalues[i]);
  }
  return degeneracy.basis * xin;
}

void NormalSums::Add(const Eigen::Vector3d& q, const Eigen::Vector3d& n, double r, double weight) {
  Vector6d j;
  j.head<3>() = q.cross(n);
  j.tail<3>() = n;
  h.selfadjointView<Eigen::Upper>().rankUpdate(j, weight);
  g += weight * r * j;
  w += weight;
  wr2 += weight * r * r;
  r2 += r * r;
  wq += weight * q;
  wq2 += weight * q.squaredNorm();
  ++count;
}

void NormalSums::Add(const NormalSums& o) {
  h += o.h;
  g += o.g;
  w += o.w;
  wr2 += o.wr2;
  r2 += o.r2;
  wq += o.wq;
  wq2 += o.wq2;
  count += o.count;
}

Degeneracy AnalyseDegeneracy(const NormalSums& sums, double threshold) {
  Degeneracy d;
  if (!(sums.w > 0.0)) {
    d.free_count = 6;
    return d;
  }
  const Matrix6d h = sums.h.selfadjointView<Eigen::Upper>();
  const Eigen::Vector3d c = sums.wq / sums.w;
  const double l = std::sqrt(std::max(1e-12, sums.wq2 / sums.w - c.squaredNorm()));
  // xi = A S xi'': v = v' + c x omega (the perturbation about c), omega = omega'' / L.
  Matrix6d a = Matrix6d::Identity();
  a.bottomLeftCorner<3, 3>() = Skew(c);
  Matrix6d s = Matrix6d::Identity();
  s.topLeftCorner<3, 3>() *= 1.0 / l;
  d.basis = a * s;
  const Matrix6d hn = d.basis.transpose() * h * d.basis / sums.w;
  Eigen::SelfAdjointEigenSolver<Matrix6d> es(hn);
  d.eigenvalues = es.eigenvalues();
  d.eigenvectors = es.eigenvectors();
  for (int i = 0; i < 6; ++i) d.free_count += d.eigenvalues[i] < threshold ? 1 : 0;
  if (d.free_count > 0) {
    const Vector6d u = d.eigenvectors.col(0);
    d.free_is_rotation = u.head<3>().norm() > u.tail<3>().norm();
    const Eigen::Vector3d v = d.free_is_rotation ? Eigen::Vector3d(u.head<3>()) : Eigen::Vector3d(u.tail<3>());
    d.free_direction = v.normalized();
  }
  return d;
}

Matrix6d Covariance(const NormalSums& sums, const Degeneracy& degeneracy) {
  if (!(sums.w > 6.0)) return Matrix6d::Zero();
  const double sigma2 = sums.wr2 / (sums.w - 6.0);
  Matrix6d inv = Matrix6d::Zero();
  for (int i = degeneracy.free_count; i < 6; ++i) {
    const Vector6d u = degeneracy.eigenvectors.col(i);
    inv += u * u.transpose() / degeneracy.eigenvalues[i];
  }
  // hn = B^T H B / W, so H^-1 = B hn^-1 B^T / W.
  return sigma2 / sums.w * degeneracy.basis * inv * degeneracy.basis.transpose();
}

std::string FormatDirection(const Eigen::Vector3d& v) {
  char buf[96];
  std::snprintf(buf, sizeof(buf), "(%.3f, %.3f, %.3f)", v.x(), v.y(), v.z());
  return buf;
}

}  // namespace registration_internal
}  // namespace sweepscan
