#include "core/geometry/path_cover.h"

#include <algorithm>
#include <cmath>

namespace sweepscan {

uint64_t PathCover::Key(const Eigen::Vector2d& p) const {
  const auto ix = static_cast<int32_t>(std::floor(p.x() / cell_));
  const auto iy = static_cast<int32_t>(std::floor(p.y() / cell_));
  return (static_cast<uint64_t>(static_cast<uint32_t>(ix)) << 32) | static_cast<uint32_t>(iy);
}

double PathCover::bound() const { return cell_ * (std::sqrt(2.0) + 0.25); }

void PathCover::Add(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const double len = (b - a).norm();
  const int n = std::max(1, static_cast<int>(std::ceil(len / (0.5 * cell_))));
  auto sample = [&](int j) -> Eigen::Vector2d { return a + (b - a) * (static_cast<double>(j) / n); };
  auto arc = [&](int j) { return arc_ + len * j / n; };

  std::vector<char> covered(n + 1), drawn(n + 1);
  for (int j = 0; j <= n; ++j) {
    const auto it = marked_.find(Key(sample(j)));
    covered[j] = it != marked_.end() && it->second <= arc(j) - revisit_;
  }
  for (int j = 0; j <= n; ++j) {
    drawn[j] = !covered[j] || (j > 0 && !covered[j - 1]) || (j < n && !covered[j + 1]);
  }
  if (open_) drawn[0] = true;  // The open run ends at a.

  auto push = [&](const Eigen::Vector2d& p) {
    std::vector<Eigen::Vector2d>& run = runs_.back();
    if (!run.empty()) drawn_ += (p - run.back()).norm();
    run.push_back(p);
  };
  bool in = open_;
  int pending = -1;  // The stretch's last drawn sample, not yet a vertex.
  auto close = [&] {
    if (pending >= 0) push(sample(pending));
    if (runs_.back().size() < 2) runs_.pop_back();
    pending = -1;
    in = false;
  };
  for (int j = 0; j <= n; ++j) {
    if (drawn[j]) {
      if (!in) {
        runs_.emplace_back();
        push(sample(j));
        in = true;
      } else if (j > 0) {
        pending = j;
      }
    } else if (in) {
      close();
    }
  }
  if (in && pending >= 0) push(sample(pending));  // pending == n: the run goes on at b.
  open_ = in;

  // The drawn samples mark their cells, and so do the midpoints between
  // them: a line crossing a cell's corner would otherwise leave it unmarked
  // and the next pass there drawn again.
  for (int j = 0; j <= n; ++j) {
    if (!drawn[j]) continue;
    marked_.try_emplace(Key(sample(j)), arc(j));
    if (j < n && drawn[j + 1]) {
      marked_.try_emplace(Key(0.5 * (sample(j) + sample(j + 1))), 0.5 * (arc(j) + arc(j + 1)));
    }
  }
  arc_ += len;
}

void PathCover::Clear() {
  arc_ = drawn_ = 0.0;
  open_ = false;
  marked_.clear();
  runs_.clear();
}

void DrawnPath::Add(const Eigen::Vector2d& p) {
  simplifier_.Add(p);
  // The simplifier's vertices are fixed but for the last: segment i (from
  // vertex i to i + 1) is final once vertex i + 1 is not the last.
  const std::vector<Eigen::Vector2d>& v = simplifier_.vertices();
  for (; committed_ + 2 < v.size(); ++committed_) cover_.Add(v[committed_], v[committed_ + 1]);
}

void DrawnPath::Clear() {
  simplifier_.Clear();
  cover_.Clear();
  committed_ = 0;
}

std::vector<std::vector<Eigen::Vector2d>> DrawnPath::Polylines() const {
  std::vector<std::vector<Eigen::Vector2d>> out;
  for (const auto& run : cover_.runs()) {
    if (run.size() >= 2) out.push_back(run);
  }
  const std::vector<Eigen::Vector2d>& v = simplifier_.vertices();
  if (v.size() >= 2) {
    out.push_back({v[v.size() - 2], v.back()});
  } else if (v.size() == 1) {
    out.push_back({v[0]});
  }
  return out;
}

}  // namespace sweepscan
