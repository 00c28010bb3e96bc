#include "core/plan/line_fit.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>
#include <unordered_map>

#include "core/plan/section.h"

namespace sweepscan::plan {
namespace {

// Hypotheses are scored on at most this many of the remaining cells (a
// uniform subsample, redrawn for every line); the winner is refitted on all.
constexpr size_t kScoreSample = 3000;
// The second point of a hypothesis is drawn at 5-50 cm from the first: close
// enough that both lie on the same face most of the time, far enough that
// the direction is known to about tolerance / distance.
constexpr double kPairMin = 0.05, kPairMax = 0.5;
constexpr double kBucket = 0.5;

uint64_t BucketKey(int64_t i, int64_t j) {
  return (static_cast<uint64_t>(static_cast<uint32_t>(i)) << 32) | static_cast<uint32_t>(j);
}

}  // namespace

bool FitLine(const std::vector<Eigen::Vector2d>& points, const std::vector<size_t>& idx, Line2d* line,
             double* rms) {
  if (idx.size() < 2) return false;
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (size_t i : idx) c += points[i];
  c /= static_cast<double>(idx.size());
  Eigen::Matrix2d s = Eigen::Matrix2d::Zero();
  for (size_t i : idx) {
    const Eigen::Vector2d d = points[i] - c;
    s += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(s);
  if (eig.info() != Eigen::Success || eig.eigenvalues()(1) <= 0.0) return false;
  // Eigenvalues ascending: column 1 is the direction, column 0 the normal.
  line->c = c;
  line->u = eig.eigenvectors().col(1).normalized();
  // A fixed sign (u pointing into x >= 0, or +y) keeps results reproducible.
  if (line->u.x() < -1e-12 || (std::abs(line->u.x()) <= 1e-12 && line->u.y() < 0)) line->u = -line->u;
  if (rms != nullptr) *rms = std::sqrt(std::max(0.0, eig.eigenvalues()(0)) / static_cast<double>(idx.size()));
  return true;
}

std::vector<Line2d> DetectLines(const std::vector<Eigen::Vector2d>& points, const LineDetectionOptions& o) {
  std::vector<Line2d> lines;
  const std::vector<Eigen::Vector2d> cells = DecimateGrid(points, 0.5 * o.tolerance_m);
  if (cells.size() < 2) return lines;
  std::unordered_map<uint64_t, std::vector<size_t>> buckets;
  for (size_t i = 0; i < cells.size(); ++i) {
    buckets[BucketKey(static_cast<int64_t>(std::floor(cells[i].x() / kBucket)),
                      static_cast<int64_t>(std::floor(cells[i].y() / kBucket)))]
        .push_back(i);
  }
  std::vector<char> alive(cells.size(), 1);
  std::vector<size_t> remaining(cells.size());
  for (size_t i = 0; i < cells.size(); ++i) remaining[i] = i;
  std::mt19937_64 rng(o.seed);
  std::vector<size_t> near, sample, inliers;
  while (static_cast<int>(lines.size()) < o.max_lines && remaining.size() >= static_cast<size_t>(o.min_cells)) {
    sample = remaining;
    if (sample.size() > kScoreSample) {
      std::shuffle(sample.begin(), sample.end(), rng);
      sample.resize(kScoreSample);
    }
    std::uniform_int_distribution<size_t> pick(0, remaining.size() - 1);
    Line2d best;
    int best_score = -1;
    for (int h = 0; h < o.hypotheses; ++h) {
      const Eigen::Vector2d& p = cells[remaining[pick(rng)]];
      const int64_t bi = static_cast<int64_t>(std::floor(p.x() / kBucket));
      const int64_t bj = static_cast<int64_t>(std::floor(p.y() / kBucket));
      near.clear();
      for (int64_t di = -1; di <= 1; ++di) {
        for (int64_t dj = -1; dj <= 1; ++dj) {
          const auto it = buckets.find(BucketKey(bi + di, bj + dj));
          if (it == buckets.end()) continue;
          for (size_t k : it->second) {
            const double d = (cells[k] - p).norm();
            if (alive[k] && d >= kPairMin && d <= kPairMax) near.push_back(k);
          }
        }
      }
      if (near.empty()) continue;
      const Eigen::Vector2d& q = cells[near[std::uniform_int_distribution<size_t>(0, near.size() - 1)(rng)]];
      Line2d l;
      l.c = p;
      l.u = (q - p).normalized();
      int score = 0;
      for (size_t k : sample) score += std::abs(l.Distance(cells[k])) <= o.tolerance_m;
      if (score > best_score) {
        best_score = score;
        best = l;
      }
    }
    if (best_score < 0) break;
    // Refit on every remaining cell within the tolerance; three rounds let
    // the line settle onto the face the hypothesis touched.
    for (int round = 0; round < 3; ++round) {
      inliers.clear();
      for (size_t k : remaining) {
        if (std::abs(best.Distance(cells[k])) <= o.tolerance_m) inliers.push_back(k);
      }
      Line2d refit;
      if (!FitLine(cells, inliers, &refit, nullptr)) break;
      best = refit;
    }
    if (static_cast<int>(inliers.size()) < o.min_cells) break;
    // Cells up to 1.5 tolerances away go too: the tail of a noisy face's
    // residuals must not come back as a second line beside it.
    for (size_t k : remaining) {
      if (std::abs(best.Distance(cells[k])) <= 1.5 * o.tolerance_m) alive[k] = 0;
    }
    remaining.erase(std::remove_if(remaining.begin(), remaining.end(), [&](size_t k) { return !alive[k]; }),
                    remaining.end());
    lines.push_back(best);
  }
  return lines;
}

}  // namespace sweepscan::plan
