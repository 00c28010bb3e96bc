#include "core/plan/section.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace sweepscan::plan {
namespace {

bool Finite(const Eigen::Vector3f& p) { return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z()); }

Status CheckBand(double band_m) {
  if (!std::isfinite(band_m) || band_m <= 0.0) {
    return Status::Error("section band must be a finite number > 0 m, got " + std::to_string(band_m));
  }
  return Status::Ok();
}

}  // namespace

bool HorizontalSectionOptions::IsValid(std::string* error) const {
  if (!std::isfinite(height_m)) {
    *error = "section height is not a finite number";
    return false;
  }
  const Status s = CheckBand(band_m);
  if (!s.ok()) *error = s.message();
  return s.ok();
}

bool VerticalSectionOptions::IsValid(std::string* error) const {
  if (!a.allFinite() || !b.allFinite()) {
    *error = "section line has a coordinate that is not a finite number";
    return false;
  }
  if ((b - a).norm() < 1e-3) {
    *error = "section line is shorter than 1 mm (its two ends coincide)";
    return false;
  }
  const Status s = CheckBand(band_m);
  if (!s.ok()) *error = s.message();
  return s.ok();
}

Status HorizontalSection(const std::vector<Eigen::Vector3f>& cloud, const HorizontalSectionOptions& options,
                         std::vector<Eigen::Vector2d>* points, SectionStats* stats) {
  points->clear();
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  if (cloud.empty()) return Status::Error("the cloud is empty: nothing to cut");
  SectionStats st;
  st.points_in = cloud.size();
  for (const Eigen::Vector3f& p : cloud) {
    if (!Finite(p)) {
      ++st.non_finite;
      continue;
    }
    if (std::abs(static_cast<double>(p.z()) - options.height_m) <= options.band_m) {
      points->emplace_back(p.x(), p.y());
    }
  }
  st.points_out = points->size();
  if (stats != nullptr) *stats = st;
  if (st.non_finite == st.points_in) return Status::Error("the cloud has no finite point");
  return Status::Ok();
}

Status VerticalSection(const std::vector<Eigen::Vector3f>& cloud, const VerticalSectionOptions& options,
                       std::vector<Eigen::Vector2d>* points, SectionStats* stats) {
  points->clear();
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  if (cloud.empty()) return Status::Error("the cloud is empty: nothing to cut");
  const double length = (options.b - options.a).norm();
  const Eigen::Vector2d u = (options.b - options.a) / length;
  const Eigen::Vector2d n(-u.y(), u.x());
  SectionStats st;
  st.points_in = cloud.size();
  for (const Eigen::Vector3f& p : cloud) {
    if (!Finite(p)) {
      ++st.non_finite;
      continue;
    }
    const Eigen::Vector2d d = Eigen::Vector2d(p.x(), p.y()) - options.a;
    const double s = u.dot(d);
    if (std::abs(n.dot(d)) <= options.band_m && s >= 0.0 && s <= length) points->emplace_back(s, p.z());
  }
  st.points_out = points->size();
  if (stats != nullptr) *stats = st;
  if (st.non_finite == st.points_in) return Status::Error("the cloud has no finite point");
  return Status::Ok();
}

CutLevels::CutLevels(const HorizontalSectionOptions& options)
    : options_(options), lo_(options.height_m - kWindow) {
  if (std::isfinite(lo_)) count_.assign(static_cast<size_t>(std::lround(2.0 * kWindow / kBin)), 0);
}

bool CutLevels::LevelNear(double reach_m, double* level_z) const {
  std::vector<size_t> occupied;
  for (size_t c : count_) {
    if (c > 0) occupied.push_back(c);
  }
  if (occupied.size() < 3) return false;
  std::nth_element(occupied.begin(), occupied.begin() + occupied.size() / 2, occupied.end());
  const double median = static_cast<double>(occupied[occupied.size() / 2]);
  const double near = options_.band_m + reach_m;
  int best = -1;
  for (int k = 0; k < static_cast<int>(count_.size()); ++k) {
    const double z = lo_ + (k + 0.5) * kBin;
    if (std::abs(z - options_.height_m) > near + 0.5 * kBin || count_[k] < kRatio * median)
      continue;
    if (best < 0 || count_[k] > count_[best]) best = k;
  }
  if (best < 0) return false;
  *level_z = lo_ + (best + 0.5) * kBin;
  return true;
}

bool LevelSurfaceNearCut(const std::vector<Eigen::Vector3f>& cloud,
                         const HorizontalSectionOptions& options, double reach_m, double* level_z) {
  CutLevels levels(options);
  for (const Eigen::Vector3f& p : cloud) levels.Add(p.z());
  return levels.LevelNear(reach_m, level_z);
}

std::vector<Eigen::Vector2d> DecimateGrid(const std::vector<Eigen::Vector2d>& points, double cell_m) {
  struct Cell {
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    int count = 0;
  };
  std::unordered_map<uint64_t, Cell> cells;
  const auto key = [cell_m](const Eigen::Vector2d& p) {
    const int64_t i = static_cast<int64_t>(std::floor(p.x() / cell_m));
    const int64_t j = static_cast<int64_t>(std::floor(p.y() / cell_m));
    return (static_cast<uint64_t>(static_cast<uint32_t>(i)) << 32) | static_cast<uint32_t>(j);
  };
  for (const Eigen::Vector2d& p : points) {
    Cell& c = cells[key(p)];
    c.sum += p;
    ++c.count;
  }
  std::vector<std::pair<uint64_t, Eigen::Vector2d>> out;
  out.reserve(cells.size());
  for (const auto& [k, c] : cells) out.emplace_back(k, c.sum / c.count);
  std::sort(out.begin(), out.end(), [](const auto& l, const auto& r) { return l.first < r.first; });
  std::vector<Eigen::Vector2d> result;
  result.reserve(out.size());
  for (const auto& e : out) result.push_back(e.second);
  return result;
}

}  // namespace sweepscan::plan
