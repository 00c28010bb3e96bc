#include "core/evaluation/evaluation.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <boost/random/mersenne_twister.hpp>
#include <boost/random/uniform_int.hpp>
#include <boost/random/variate_generator.hpp>
#include <chrono>
#include <cmath>
#include <limits>

#include "core/evaluation/parallel.h"
#include "core/evaluation/plane_scoring.h"
#include "core/evaluation/room_planes.h"

namespace sweepscan {

const char* const kEvaluationCancelled = "evaluation: cancelled";

namespace {

using evaluation_internal::Runner;

constexpr double kRadToDeg = 180.0 / M_PI;
constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();
// Block sizes: fixed (the result must not depend on the thread count) and
// small enough that a block takes a few milliseconds.
constexpr size_t kQueryBlock = 4096;
constexpr size_t kPassBlock = 1 << 16;
constexpr int kHypothesisBatch = 32;

Status Cancelled() { return Status::Error(kEvaluationCancelled); }

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

NeighbourIndex::ParallelFor ForOf(Runner* runner) {
  return [runner](size_t n, size_t block,
                  const std::function<void(size_t, size_t, size_t)>& body) {
    return runner->For(n, block, body, 0.0, 0.05);
  };
}

// What the shared neighbour pass leaves per point (original indexing). The
// nearest neighbour's squared distance is not kept: Density computes it
// again from the two points, as the structure did (dx^2 + dy^2 + dz^2 in
// float), 4 bytes a point fewer at the evaluation's peak.
struct NeighbourPass {
  int k = 0;                       // outlier k (0: none)
  int queried = 0;                 // neighbours asked for (itself included)
  std::vector<float> mean_dist;    // mean distance to the k neighbours (k > 0)
  std::vector<uint32_t> nearest;   // nearest other point, kNone if none
};

bool RunNeighbourPass(const NeighbourIndex& index, int k, Runner* runner, NeighbourPass* pass) {
  const size_t n = index.size();
  pass->k = k;
  pass->queried = static_cast<int>(std::min<size_t>(n, static_cast<size_t>(std::max(k, 1) + 1)));
  if (k > 0) pass->mean_dist.assign(n, 0.0f);
  pass->nearest.assign(n, kNone);
  const std::vector<uint32_t>& order = index.order();
  const size_t kq = static_cast<size_t>(pass->queried);
  return runner->For(
      n, kQueryBlock,
      [&](size_t, size_t begin, size_t end) {
        std::vector<uint32_t> idx((end - begin) * kq);
        std::vector<float> d2((end - begin) * kq);
        index.KnnRange(begin, end, pass->queried, idx.data(), d2.data());
        for (size_t s = begin; s < end; ++s) {
          const uint32_t* pi = &idx[(s - begin) * kq];
          const float* pd = &d2[(s - begin) * kq];
          const uint32_t i = order[s];
          if (k > 0) {
            // PCL: the first result is taken to be the point itself.
            double sum = 0.0;
            for (size_t j = 1; j < kq; ++j) sum += std::sqrt(static_cast<double>(pd[j]));
            pass->mean_dist[i] = static_cast<float>(sum / k);
          }
          for (size_t j = 0; j < kq; ++j) {
            if (pi[j] != s) {
              pass->nearest[i] = order[pi[j]];
              break;
            }
          }
        }
      },
      0.05, 1.0);
}

float SquaredDistance(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  const float dx = a.x() - b.x(), dy = a.y() - b.y(), dz = a.z() - b.z();
  return dx * dx + dy * dy + dz * dz;
}

// PCL StatisticalOutlierRemoval::applyFilterIndices' statistics, summed in
// blocks combined in order.
bool OutlierFlags(const NeighbourPass& pass, double stddev_mult, Runner* runner,
                  std::vector<uint8_t>* kept) {
  const size_t n = pass.mean_dist.size();
  const size_t blocks = Runner::Blocks(n, kPassBlock);
  std::vector<double> sums(blocks), sq_sums(blocks);
  if (!runner->For(n, kPassBlock, [&](size_t b, size_t begin, size_t end) {
        double sum = 0.0, sq_sum = 0.0;
        for (size_t i = begin; i < end; ++i) {
          const float d = pass.mean_dist[i];
          sum += d;
          sq_sum += d * d;
        }
        sums[b] = sum;
        sq_sums[b] = sq_sum;
      }, 0.0, 0.5)) {
    return false;
  }
  double sum = 0.0, sq_sum = 0.0;
  for (size_t b = 0; b < blocks; ++b) {
    sum += sums[b];
    sq_sum += sq_sums[b];
  }
  const double count = static_cast<double>(n);
  const double mean = sum / count;
  const double variance = (sq_sum - sum * sum / count) / (count - 1.0);
  const double threshold = mean + stddev_mult * std::sqrt(variance);
  kept->resize(n);
  return runner->For(n, kPassBlock, [&](size_t, size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      (*kept)[i] = static_cast<double>(pass.mean_dist[i]) <= threshold ? 1 : 0;
    }
  }, 0.5, 1.0);
}

// Eq. 18-19 over the kept points (all if `kept` is null; `m` of them),
// every stride-th of them in index order: the nearest kept neighbour from
// the shared pass, a new query only where that neighbour was removed. The
// kept points are found through the flags in blocks of the cloud, each
// block starting at its first kept point's rank, so no list of them is
// held (4 bytes a point).
bool Density(const std::vector<Eigen::Vector3f>& points, const NeighbourIndex& index,
             const NeighbourPass& pass, const std::vector<uint8_t>* kept, size_t m,
             size_t max_queries, Runner* runner, double* mean_m, size_t* queries) {
  const size_t n = points.size();
  const size_t stride = max_queries > 0 ? std::max<size_t>(1, m / max_queries) : 1;
  const size_t blocks = Runner::Blocks(n, kQueryBlock);
  const auto is_kept = [&](uint32_t j) { return kept == nullptr || (*kept)[j] != 0; };
  // The rank among the kept points of each block's first kept point.
  std::vector<size_t> first_rank(blocks + 1, 0);
  if (kept != nullptr) {
    for (size_t b = 0; b < blocks; ++b) {
      const size_t begin = b * kQueryBlock, end = std::min(n, begin + kQueryBlock);
      size_t c = 0;
      for (size_t i = begin; i < end; ++i) c += (*kept)[i];
      first_rank[b + 1] = first_rank[b] + c;
    }
  } else {
    for (size_t b = 0; b <= blocks; ++b) first_rank[b] = std::min(n, b * kQueryBlock);
  }
  std::vector<double> sums(blocks);
  std::vector<size_t> counts(blocks);
  if (!runner->For(n, kQueryBlock, [&](size_t b, size_t begin, size_t end) {
        double sum = 0.0;
        size_t count = 0;
        size_t rank = first_rank[b];
        for (size_t i = begin; i < end; ++i) {
          if (!is_kept(static_cast<uint32_t>(i))) continue;
          if (rank++ % stride != 0) continue;
          const uint32_t near = pass.nearest[i];
          if (near != kNone && is_kept(near)) {
            sum += std::sqrt(static_cast<double>(SquaredDistance(points[i], points[near])));
            ++count;
            continue;
          }
          // The nearest neighbour was an outlier: the nearest kept point
          // other than this one, in one walk of the tree.
          uint32_t j;
          float dj;
          const uint32_t self = static_cast<uint32_t>(i);
          if (index.NearestWhere(
                  points[i].data(),
                  [&](uint32_t s) {
                    const uint32_t o = index.order()[s];
                    return o != self && is_kept(o);
                  },
                  &j, &dj)) {
            sum += std::sqrt(static_cast<double>(dj));
            ++count;
          }
        }
        sums[b] = sum;
        counts[b] = count;
      })) {
    return false;
  }
  double sum = 0.0;
  size_t count = 0;
  for (size_t b = 0; b < blocks; ++b) {
    sum += sums[b];
    count += counts[b];
  }
  *mean_m = count > 0 ? sum / static_cast<double>(count) : 0.0;
  *queries = count;
  return true;
}

// FitPlane (core/geometry/plane.h) from moments about a reference point r:
// s1 = sum (p - r), s2 = sum (p - r)(p - r)^T.
bool PlaneFromMoments(size_t count, const Eigen::Vector3d& r, const Eigen::Vector3d& s1,
                      const Eigen::Matrix3d& s2, Plane* plane) {
  if (count < 3) return false;
  const double n = static_cast<double>(count);
  const Eigen::Vector3d mean = s1 / n;
  const Eigen::Matrix3d scatter = s2 - n * mean * mean.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
  const Eigen::Vector3d ev = eig.eigenvalues();
  if (ev[1] <= 1e-12 * std::max(1.0, ev[2])) return false;
  plane->normal = eig.eigenvectors().col(0).normalized();
  plane->centroid = r + mean;
  plane->d = -plane->normal.dot(plane->centroid);
  plane->rms = std::sqrt(std::max(0.0, ev[0]) / n);
  plane->count = count;
  return true;
}

struct Moments {
  size_t count = 0;
  Eigen::Vector3d s1 = Eigen::Vector3d::Zero();
  Eigen::Matrix3d s2 = Eigen::Matrix3d::Zero();
};

// The largest float t with (double)t < threshold: |dist| <= t in float is
// PCL's |dist| < threshold in double.
float FloatBelow(double threshold) {
  float t = static_cast<float>(threshold);
  while (static_cast<double>(t) >= threshold) t = std::nextafter(t, 0.0f);
  return t;
}

DeviationHistogram HistogramParallel(const std::vector<Eigen::Vector3f>& points,
                                     const std::vector<uint32_t>& indices, const Plane& plane,
                                     double bin_m, double half_range_m, Runner* runner,
                                     bool* ok) {
  DeviationHistogram h;
  h.bin_m = bin_m;
  const size_t bins =
      std::max<size_t>(1, static_cast<size_t>(std::ceil(2.0 * half_range_m / bin_m)));
  h.min_m = -0.5 * bins * bin_m;
  h.counts.assign(bins, 0);
  const size_t blocks = Runner::Blocks(indices.size(), kPassBlock);
  std::vector<std::vector<uint64_t>> counts(blocks);
  std::vector<double> sums(blocks), sums2(blocks);
  std::vector<uint64_t> belows(blocks), aboves(blocks);
  *ok = runner->For(indices.size(), kPassBlock, [&](size_t b, size_t begin, size_t end) {
    std::vector<uint64_t>& c = counts[b];
    c.assign(bins, 0);
    double sum = 0.0, sum2 = 0.0;
    uint64_t below = 0, above = 0;
    for (size_t k = begin; k < end; ++k) {
      const double r = plane.SignedDistance(points[indices[k]].cast<double>());
      sum += r;
      sum2 += r * r;
      const double f = std::floor((r - h.min_m) / bin_m);
      below += f < 0;
      above += f >= static_cast<double>(bins);
      const size_t bin = f < 0 ? 0 : std::min(bins - 1, static_cast<size_t>(f));
      ++c[bin];
    }
    sums[b] = sum;
    sums2[b] = sum2;
    belows[b] = below;
    aboves[b] = above;
  });
  if (!*ok) return h;
  double sum = 0.0, sum2 = 0.0;
  for (size_t b = 0; b < blocks; ++b) {
    for (size_t i = 0; i < bins; ++i) h.counts[i] += counts[b][i];
    h.below += belows[b];
    h.above += aboves[b];
    sum += sums[b];
    sum2 += sums2[b];
  }
  h.count = indices.size();
  if (h.count > 0) {
    h.mean_m = sum / h.count;
    h.stddev_m = std::sqrt(std::max(0.0, sum2 / h.count - h.mean_m * h.mean_m));
  }
  return h;
}

// Two in-plane unit axes: horizontal and (nearly) up for a wall; for a
// level plane x projected into it and n x u.
void PlaneAxes(const Eigen::Vector3d& n, Eigen::Vector3d* u, Eigen::Vector3d* v) {
  if (std::abs(n.z()) > 0.9) {
    *u = (Eigen::Vector3d::UnitX() - n.x() * n).normalized();
  } else {
    *u = Eigen::Vector3d::UnitZ().cross(n).normalized();
  }
  *v = n.cross(*u);
}

std::array<Eigen::Vector3d, 4> PlaneOutline(const std::vector<Eigen::Vector3f>& points,
                                            const std::vector<uint32_t>& inliers,
                                            const Plane& plane) {
  Eigen::Vector3d u, v;
  PlaneAxes(plane.normal, &u, &v);
  std::vector<float> pu(inliers.size()), pv(inliers.size());
  for (size_t k = 0; k < inliers.size(); ++k) {
    const Eigen::Vector3d d = points[inliers[k]].cast<double>() - plane.centroid;
    pu[k] = static_cast<float>(d.dot(u));
    pv[k] = static_cast<float>(d.dot(v));
  }
  auto quantile = [](std::vector<float>* x, double q) {
    if (x->empty()) return 0.0;
    const size_t i = std::min(x->size() - 1, static_cast<size_t>(q * (x->size() - 1) + 0.5));
    std::nth_element(x->begin(), x->begin() + static_cast<std::ptrdiff_t>(i), x->end());
    return static_cast<double>((*x)[i]);
  };
  const double u0 = quantile(&pu, 0.005), u1 = quantile(&pu, 0.995);
  const double v0 = quantile(&pv, 0.005), v1 = quantile(&pv, 0.995);
  const Eigen::Vector3d& c = plane.centroid;
  return {c + u0 * u + v0 * v, c + u1 * u + v0 * v, c + u1 * u + v1 * v, c + u0 * u + v1 * v};
}

// Iterative RANSAC planes (see ExtractPlanes). members may be null.
// The planes of the points `subset` indexes (in that order: RANSAC's
// subsample is drawn from it), as if they were the whole cloud.
Status ExtractPlanesWith(const std::vector<Eigen::Vector3f>& points, std::vector<uint32_t> subset,
                         const EvaluationOptions& options, Runner* runner,
                         std::vector<EvaluatedPlane>* planes,
                         std::vector<std::vector<size_t>>* members) {
  planes->clear();
  if (members != nullptr) members->clear();
  const size_t n = subset.size();
  if (n < 3) return Status::Error("plane extraction: " + std::to_string(n) + " points");
  double mean_z = 0.0;
  for (const uint32_t i : subset) mean_z += points[i].z();
  mean_z /= static_cast<double>(n);
  std::vector<uint32_t> remaining = std::move(subset), rest;
  const size_t min_count =
      std::max<size_t>(3, static_cast<size_t>(options.min_plane_fraction * static_cast<double>(n)));
  const double cos_level = std::cos(options.classify_angle_deg / kRadToDeg);
  const double sin_plumb = std::sin(options.classify_angle_deg / kRadToDeg);
  const float threshold = FloatBelow(options.plane_distance_m);
  PointsSoa sub;
  std::vector<uint8_t> in_band;
  while (static_cast<int>(planes->size()) < options.max_planes && remaining.size() >= min_count) {
    runner->Report(std::max(static_cast<double>(planes->size()) / options.max_planes,
                            1.0 - static_cast<double>(remaining.size()) / static_cast<double>(n)));
    if (runner->Cancelled()) return Cancelled();
    // The even subsample RANSAC runs on.
    size_t m = remaining.size();
    double step = 1.0;
    if (options.ransac_max_points > 0 && remaining.size() > options.ransac_max_points) {
      m = options.ransac_max_points;
      step = static_cast<double>(remaining.size()) / static_cast<double>(m);
    }
    sub.Resize(m);
    for (size_t k = 0; k < m; ++k) {
      const Eigen::Vector3f& p =
          points[remaining[step == 1.0 ? k : static_cast<size_t>(static_cast<double>(k) * step)]];
      sub.Set(k, p.x(), p.y(), p.z());
    }
    // RANSAC exactly as PCL's SACSegmentation runs it (so that the planes are
    // those of the PCL version): a fresh boost::mt19937 seeded 12345 per
    // plane (12345 + seed - 1 here), samples drawn by partial shuffles of
    // the subsample's indices, rejected when the cross product's norm is
    // below Eigen's float precision, coefficients and distances in float in
    // Eigen's order, the best by inlier count, stopping after
    // log(1 - 0.99) / log(1 - w^3) hypotheses. The hypotheses are drawn in
    // order and scored in batches on all threads; the stop is decided in
    // hypothesis order, so the result is PCL's on any thread count.
    boost::mt19937 rng_alg(static_cast<uint32_t>(12345u + options.seed - 1));
    boost::uniform_int<> rng_dist(0, std::numeric_limits<int>::max());
    boost::variate_generator<boost::mt19937&, boost::uniform_int<>> rnd(rng_alg, rng_dist);
    std::vector<uint32_t> shuffled(m);
    for (size_t k = 0; k < m; ++k) shuffled[k] = static_cast<uint32_t>(k);
    const auto draw = [&](Eigen::Vector4f* model) {
      for (int check = 0; check < 1000; ++check) {
        for (size_t i = 0; i < 3; ++i) {
          std::swap(shuffled[i], shuffled[i + static_cast<size_t>(rnd()) % (m - i)]);
        }
        const Eigen::Vector3f p0(sub.x[shuffled[0]], sub.y[shuffled[0]], sub.z[shuffled[0]]);
        const Eigen::Vector3f p1(sub.x[shuffled[1]], sub.y[shuffled[1]], sub.z[shuffled[1]]);
        const Eigen::Vector3f p2(sub.x[shuffled[2]], sub.y[shuffled[2]], sub.z[shuffled[2]]);
        const Eigen::Vector3f cross = (p1 - p0).cross(p2 - p0);
        const float norm = cross.stableNorm();
        if (norm < Eigen::NumTraits<float>::dummy_precision()) continue;
        const Eigen::Vector3f normal = cross / norm;
        *model << normal, -1.0f * normal.dot(p0);
        return true;
      }
      return false;  // PCL: no sample could be selected
    };
    const size_t m_size = m;
    const double one_over_indices = 1.0 / static_cast<double>(m_size);
    const double log_probability = std::log(1.0 - 0.99);
    double k_needed = std::numeric_limits<double>::max();
    int iterations = 0;
    size_t best_count = 0;
    Eigen::Vector4f best_model = Eigen::Vector4f::Zero();
    bool have_best = false, stop = false;
    std::vector<Eigen::Vector4f> batch;
    std::vector<size_t> batch_count(kHypothesisBatch);
    while (!stop) {
      batch.clear();
      for (int h = 0; h < kHypothesisBatch; ++h) {
        Eigen::Vector4f model;
        if (!draw(&model)) break;
        batch.push_back(model);
      }
      if (batch.size() < static_cast<size_t>(kHypothesisBatch)) stop = true;
      if (!runner->For(batch.size(), 1, [&](size_t h, size_t, size_t) {
            const Eigen::Vector4f& q = batch[h];
            batch_count[h] = CountWithinPlane(sub, q, threshold);
          })) {
        return Cancelled();
      }
      for (size_t h = 0; h < batch.size(); ++h) {
        if (batch_count[h] > best_count) {
          have_best = true;
          best_count = batch_count[h];
          best_model = batch[h];
          const double w = static_cast<double>(best_count) * one_over_indices;
          double p_outliers = 1.0 - std::pow(w, 3.0);
          p_outliers = std::max(std::numeric_limits<double>::epsilon(), p_outliers);
          p_outliers = std::min(1.0 - std::numeric_limits<double>::epsilon(), p_outliers);
          k_needed = log_probability / std::log(p_outliers);
        }
        ++iterations;
        if (iterations > k_needed || iterations > options.ransac_iterations) {
          stop = true;
          break;
        }
      }
    }
    const double scale = static_cast<double>(m) / static_cast<double>(remaining.size());
    if (!have_best || static_cast<double>(best_count) < scale * static_cast<double>(min_count)) {
      break;
    }
    std::vector<Eigen::Vector3d> in;
    in.reserve(best_count);
    for (size_t k = 0; k < m; ++k) {
      if (PlaneDistance(best_model, sub.x[k], sub.y[k], sub.z[k]) <= threshold) {
        in.emplace_back(sub.x[k], sub.y[k], sub.z[k]);
      }
    }
    EvaluatedPlane ep;
    if (!FitPlane(in, &ep.plane)) break;
    // One pass over the remaining points: the band of the least-squares
    // plane and the moments of its points (about the subsample's centroid).
    const Plane first = ep.plane;
    const Eigen::Vector3d ref = first.centroid;
    const size_t blocks = Runner::Blocks(remaining.size(), kPassBlock);
    std::vector<Moments> moments(blocks);
    in_band.resize(remaining.size());
    if (!runner->For(remaining.size(), kPassBlock, [&](size_t b, size_t begin, size_t end) {
          Moments& mo = moments[b];
          for (size_t k = begin; k < end; ++k) {
            const Eigen::Vector3d p = points[remaining[k]].cast<double>();
            const bool inside = std::abs(first.SignedDistance(p)) < options.plane_distance_m;
            in_band[k] = inside ? 1 : 0;
            if (inside) {
              const Eigen::Vector3d q = p - ref;
              ++mo.count;
              mo.s1 += q;
              mo.s2.noalias() += q * q.transpose();
            }
          }
        })) {
      return Cancelled();
    }
    Moments all;
    for (const Moments& mo : moments) {
      all.count += mo.count;
      all.s1 += mo.s1;
      all.s2 += mo.s2;
    }
    if (all.count < min_count) break;
    if (!PlaneFromMoments(all.count, ref, all.s1, all.s2, &ep.plane)) break;
    std::vector<uint32_t> mine;
    mine.reserve(all.count);
    rest.clear();
    rest.reserve(remaining.size() - all.count);
    for (size_t k = 0; k < remaining.size(); ++k) {
      (in_band[k] ? mine : rest).push_back(remaining[k]);
    }
    const double nz = std::abs(ep.plane.normal.z());
    if (nz >= cos_level) {
      // Orient the normal up; the floor has the room above it.
      if (ep.plane.normal.z() < 0) ep.plane.normal = -ep.plane.normal, ep.plane.d = -ep.plane.d;
      ep.tilt_deg = std::acos(std::min(1.0, nz)) * kRadToDeg;
      ep.kind = "level";  // floor or ceiling, decided below
    } else if (nz <= sin_plumb) {
      ep.kind = "wall";
      ep.tilt_deg = std::asin(std::min(1.0, nz)) * kRadToDeg;
    } else {
      ep.kind = "other";
      ep.tilt_deg = std::asin(std::min(1.0, nz)) * kRadToDeg;
    }
    ep.outline = PlaneOutline(points, mine, ep.plane);
    bool ok = true;
    ep.deviations = HistogramParallel(points, mine, ep.plane, options.histogram_bin_m,
                                      options.histogram_half_range_m, runner, &ok);
    if (!ok) return Cancelled();
    planes->push_back(ep);
    if (members != nullptr) members->emplace_back(mine.begin(), mine.end());
    remaining.swap(rest);
  }
  NameLevelPlanes(mean_z, planes);
  runner->Report(1.0);
  return Status::Ok();
}

Status CheckFinite(const std::vector<Eigen::Vector3f>& points, const char* what) {
  for (const auto& p : points) {
    if (!p.allFinite()) return Status::Error(std::string(what) + ": the cloud has non-finite points");
  }
  return Status::Ok();
}

}  // namespace

const char* EvaluationStageName(EvaluationStage stage) {
  switch (stage) {
    case EvaluationStage::kNeighbours: return "neighbours";
    case EvaluationStage::kOutliers: return "outliers";
    case EvaluationStage::kDensity: return "density";
    case EvaluationStage::kPlanes: return "planes";
    case EvaluationStage::kDone: return "done";
  }
  return "?";
}

bool EvaluationOptions::IsValid(std::string* error) const {
  if (outlier_k < 0 || !(outlier_stddev_mult > 0.0)) {
    *error = "evaluation: outlier_k must be >= 0 and outlier_stddev_mult > 0";
    return false;
  }
  if (!(plane_distance_m > 0.0) || max_planes < 1 || !(min_plane_fraction > 0.0) ||
      !(min_plane_fraction < 1.0) || ransac_iterations < 1) {
    *error = "evaluation: plane extraction parameters out of range";
    return false;
  }
  if (!(histogram_bin_m > 0.0) || !(histogram_half_range_m >= histogram_bin_m) ||
      !std::isfinite(histogram_half_range_m) || histogram_half_range_m / histogram_bin_m > 1e6) {
    *error = "evaluation: need 0 < histogram_bin_m <= histogram_half_range_m (at most 1e6 bins)";
    return false;
  }
  if (!(classify_angle_deg > 0.0 && classify_angle_deg < 45.0) ||
      !(parallel_angle_deg > 0.0 && parallel_angle_deg < 45.0) || !(min_dimension_m >= 0.0)) {
    *error = "evaluation: angles must be in (0, 45) deg and min_dimension_m >= 0";
    return false;
  }
  if (threads < 0) {
    *error = "evaluation: threads must be >= 0";
    return false;
  }
  return true;
}

Status RemoveStatisticalOutliers(const std::vector<Eigen::Vector3f>& points, int k,
                                 double stddev_mult, std::vector<size_t>* kept) {
  kept->clear();
  Status s = CheckFinite(points, "outlier removal");
  if (!s.ok()) return s;
  if (k <= 0 || points.size() <= static_cast<size_t>(k)) {
    for (size_t i = 0; i < points.size(); ++i) kept->push_back(i);
    return Status::Ok();
  }
  Runner runner(0, nullptr);
  NeighbourIndex index;
  index.Build(points, NeighbourBackend::kBatched, ForOf(&runner));
  NeighbourPass pass;
  RunNeighbourPass(index, k, &runner, &pass);
  std::vector<uint8_t> flags;
  OutlierFlags(pass, stddev_mult, &runner, &flags);
  for (size_t i = 0; i < points.size(); ++i) {
    if (flags[i]) kept->push_back(i);
  }
  return Status::Ok();
}

DeviationHistogram MakeDeviationHistogram(const std::vector<Eigen::Vector3f>& points,
                                          const std::vector<size_t>& indices, const Plane& plane,
                                          double bin_m, double half_range_m) {
  DeviationHistogram h;
  h.bin_m = bin_m;
  const size_t bins =
      std::max<size_t>(1, static_cast<size_t>(std::ceil(2.0 * half_range_m / bin_m)));
  h.min_m = -0.5 * bins * bin_m;
  h.counts.assign(bins, 0);
  double sum = 0.0, sum2 = 0.0;
  for (size_t i : indices) {
    const double r = plane.SignedDistance(points[i].cast<double>());
    sum += r;
    sum2 += r * r;
    const double f = std::floor((r - h.min_m) / bin_m);
    h.below += f < 0;
    h.above += f >= static_cast<double>(bins);
    const size_t b = f < 0 ? 0 : std::min(bins - 1, static_cast<size_t>(f));
    ++h.counts[b];
  }
  h.count = indices.size();
  if (h.count > 0) {
    h.mean_m = sum / h.count;
    h.stddev_m = std::sqrt(std::max(0.0, sum2 / h.count - h.mean_m * h.mean_m));
  }
  return h;
}

Status ExtractPlanes(const std::vector<Eigen::Vector3f>& points, const EvaluationOptions& options,
                     std::vector<EvaluatedPlane>* planes,
                     std::vector<std::vector<size_t>>* members) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  Runner runner(options.threads, nullptr);
  if (points.size() >= std::numeric_limits<uint32_t>::max()) {
    return Status::Error("plane extraction: more than 2^32 - 1 points");
  }
  std::vector<uint32_t> all(points.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<uint32_t>(i);
  return ExtractPlanesWith(points, std::move(all), options, &runner, planes, members);
}

Status MeanNearestNeighbourDistance(const std::vector<Eigen::Vector3f>& points, size_t max_queries,
                                    double* mean_m, size_t* queries) {
  if (points.size() < 2) {
    return Status::Error("density: need at least 2 points, got " + std::to_string(points.size()));
  }
  Status s = CheckFinite(points, "density");
  if (!s.ok()) return s;
  Runner runner(0, nullptr);
  NeighbourIndex index;
  index.Build(points, NeighbourBackend::kBatched, ForOf(&runner));
  NeighbourPass pass;
  RunNeighbourPass(index, 0, &runner, &pass);
  Density(points, index, pass, nullptr, points.size(), max_queries, &runner, mean_m, queries);
  if (*queries == 0) return Status::Error("density: no neighbours found");
  return Status::Ok();
}

Status EvaluateCloud(const std::vector<Eigen::Vector3f>& points, const EvaluationOptions& options,
                     CloudEvaluation* result) {
  return EvaluateCloud(points, options, result, EvaluationControl());
}

Status EvaluateCloud(const std::vector<Eigen::Vector3f>& points, const EvaluationOptions& options,
                     CloudEvaluation* result, const EvaluationControl& control) {
  using Clock = std::chrono::steady_clock;
  const auto t_start = Clock::now();
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  *result = CloudEvaluation();
  result->points_in = points.size();
  Status s = CheckFinite(points, "outlier removal");
  if (!s.ok()) return s;
  if (points.size() >= std::numeric_limits<uint32_t>::max()) {
    return Status::Error("evaluation: more than 2^32 - 1 points");
  }
  Runner runner(options.threads, &control);
  result->timing.threads = runner.threads();
  const size_t n = points.size();

  // 1. One neighbour structure; every point's k + 1 nearest (itself included).
  runner.Stage(EvaluationStage::kNeighbours);
  auto t = Clock::now();
  const int k = options.outlier_k > 0 && n > static_cast<size_t>(options.outlier_k)
                    ? options.outlier_k
                    : 0;
  NeighbourIndex index;
  NeighbourPass pass;
  if (n >= 2) {
    if (!index.Build(points, options.neighbours, ForOf(&runner))) return Cancelled();
    if (!RunNeighbourPass(index, k, &runner, &pass)) return Cancelled();
  }
  result->timing.neighbours_s = Seconds(t);

  // 2. Outliers: PCL's statistics on the mean neighbour distances.
  runner.Stage(EvaluationStage::kOutliers);
  t = Clock::now();
  std::vector<uint8_t> kept;
  if (k > 0) {
    if (!OutlierFlags(pass, options.outlier_stddev_mult, &runner, &kept)) return Cancelled();
  }
  pass.mean_dist = std::vector<float>();  // Its flags are all that is needed.
  size_t clean_count = n;
  if (!kept.empty()) clean_count = static_cast<size_t>(std::count(kept.begin(), kept.end(), 1));
  result->points_after_outliers = clean_count;
  result->timing.outliers_s = Seconds(t);

  // 3. Density on the clean cloud, from the same neighbours.
  runner.Stage(EvaluationStage::kDensity);
  t = Clock::now();
  double density = 0.0;
  size_t density_queries = 0;
  if (clean_count >= 2) {
    if (!Density(points, index, pass, kept.empty() ? nullptr : &kept, clean_count,
                 options.density_max_queries, &runner, &density, &density_queries)) {
      return Cancelled();
    }
  }
  // The neighbour structure is no longer needed: free it before the planes,
  // which index the kept points (4 bytes a point, not a copy of 12).
  index.Build({});
  pass = NeighbourPass();
  std::vector<uint32_t> clean;
  clean.reserve(clean_count);
  for (size_t i = 0; i < n; ++i) {
    if (kept.empty() || kept[i]) clean.push_back(static_cast<uint32_t>(i));
  }
  kept = std::vector<uint8_t>();
  result->timing.density_s = Seconds(t);

  // 4. Planes, histograms, dimensions.
  runner.Stage(EvaluationStage::kPlanes);
  t = Clock::now();
  s = ExtractPlanesWith(points, std::move(clean), options, &runner, &result->planes, nullptr);
  if (!s.ok()) return s;
  result->dimensions =
      RoomDimensions(result->planes, options.parallel_angle_deg, options.min_dimension_m);
  result->timing.planes_s = Seconds(t);

  if (clean_count < 2) {
    return Status::Error("density: need at least 2 points, got " + std::to_string(clean_count));
  }
  if (density_queries == 0) return Status::Error("density: no neighbours found");
  result->mean_nn_distance_m = density;
  result->density_queries = density_queries;
  result->timing.total_s = Seconds(t_start);
  if (runner.Cancelled()) return Cancelled();
  runner.Done();
  return Status::Ok();
}

std::vector<float> DeviationMapMm(const std::vector<Eigen::Vector3f>& points,
                                  const std::vector<EvaluatedPlane>& planes, double band_m) {
  // Each plane as its normal, offset and the outline's rectangle in the
  // plane's own axes (u0..u1, v0..v1 about the centroid), grown by the band.
  struct Patch {
    Eigen::Vector3f n, c, u, v;
    float d, u0, u1, v0, v1;
  };
  std::vector<Patch> patches;
  const float band = static_cast<float>(band_m);
  for (const EvaluatedPlane& ep : planes) {
    Eigen::Vector3d u, v;
    PlaneAxes(ep.plane.normal, &u, &v);
    Patch q;
    q.n = ep.plane.normal.cast<float>();
    q.d = static_cast<float>(ep.plane.d);
    q.c = ep.plane.centroid.cast<float>();
    q.u = u.cast<float>();
    q.v = v.cast<float>();
    const Eigen::Vector3d lo = ep.outline[0] - ep.plane.centroid;
    const Eigen::Vector3d hi = ep.outline[2] - ep.plane.centroid;
    q.u0 = static_cast<float>(lo.dot(u)) - band;
    q.u1 = static_cast<float>(hi.dot(u)) + band;
    q.v0 = static_cast<float>(lo.dot(v)) - band;
    q.v1 = static_cast<float>(hi.dot(v)) + band;
    patches.push_back(q);
  }
  std::vector<float> out(points.size(), std::numeric_limits<float>::quiet_NaN());
  Runner runner(0, nullptr);
  runner.For(points.size(), kPassBlock, [&](size_t, size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const Eigen::Vector3f& p = points[i];
      float best = band;
      for (const Patch& q : patches) {
        const float dist = q.n.dot(p) + q.d;
        if (std::abs(dist) > std::abs(best) || std::abs(dist) > band) continue;
        const Eigen::Vector3f r = p - q.c;
        const float a = r.dot(q.u), b = r.dot(q.v);
        if (a < q.u0 || a > q.u1 || b < q.v0 || b > q.v1) continue;
        best = dist;
        out[i] = 1e3f * dist;
      }
    }
  });
  return out;
}

}  // namespace sweepscan
