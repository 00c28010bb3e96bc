#include "ui/plan/plan_build.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/plan/section.h"

namespace sweepscan::ui {
namespace {

// Progress and the cancel flag every 64 k points: ~1 ms of work apart.
constexpr size_t kStep = 65536;

}  // namespace

Status BuildSectionOf(const std::vector<PlanInput>& inputs, const plan::VerticalSectionOptions& options,
                      const std::function<bool(double)>& progress, SectionOf* section) {
  *section = SectionOf();
  section->options = options;
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  size_t total = 0;
  for (const PlanInput& in : inputs) total += in.positions ? in.positions->size() : 0;
  if (total == 0) return Status::Error("no points to draw a section of");
  // core/plan's section (its s, n convention) of each 64 k points moved
  // into the common frame: the copy is one chunk, not a cloud.
  std::vector<Eigen::Vector3f> chunk;
  std::vector<Eigen::Vector2d> s_z, part;
  size_t done = 0;
  for (const PlanInput& in : inputs) {
    if (!in.positions) continue;
    const Eigen::Matrix3f r = in.frame_from_cloud.rotation().toRotationMatrix().cast<float>();
    const Eigen::Vector3f t = in.frame_from_cloud.translation().cast<float>();
    const std::vector<Eigen::Vector3f>& points = *in.positions;
    for (size_t from = 0; from < points.size(); from += kStep) {
      if (!progress(0.9 * static_cast<double>(done + from) / total)) return Status::Error(kPlanCancelled);
      const size_t to = std::min(points.size(), from + kStep);
      chunk.clear();
      for (size_t i = from; i < to; ++i) chunk.push_back(r * points[i] + t);
      plan::SectionStats stats;
      // Its only refusal after the options' check: a chunk of non-finite points, counted.
      plan::VerticalSection(chunk, options, &part, &stats);
      section->stats.non_finite += stats.non_finite;
      s_z.insert(s_z.end(), part.begin(), part.end());
    }
    done += points.size();
  }
  section->stats.points_in = total;
  section->stats.points_out = s_z.size();
  if (!progress(0.9)) return Status::Error(kPlanCancelled);
  section->s_z = plan::DecimateGrid(s_z, kSectionCellM);
  progress(1.0);
  return Status::Ok();
}

Status BuildPlanOf(const std::vector<PlanInput>& inputs, const plan::FloorPlanOptions& options,
                   const std::function<bool(double)>& progress, plan::FloorPlan* plan,
                   double* level_near_cut) {
  *plan = plan::FloorPlan();
  if (level_near_cut != nullptr) *level_near_cut = std::numeric_limits<double>::quiet_NaN();
  plan::CutLevels levels(options.section);
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  size_t total = 0;
  for (const PlanInput& in : inputs) total += in.positions ? in.positions->size() : 0;
  if (total == 0) return Status::Error("no points to draw a plan of");
  const double height = options.section.height_m, band = options.section.band_m;
  std::vector<Eigen::Vector2d> section;
  plan::SectionStats stats;
  size_t done = 0;
  for (const PlanInput& in : inputs) {
    if (!in.positions) continue;
    // Only z first (one row of the rotation): most points are not in the slab.
    const Eigen::Matrix3d r = in.frame_from_cloud.rotation().toRotationMatrix();
    const Eigen::Vector3d t = in.frame_from_cloud.translation();
    const Eigen::Vector3d z_row = r.row(2).transpose();
    const std::vector<Eigen::Vector3f>& points = *in.positions;
    for (size_t i = 0; i < points.size(); ++i) {
      if ((done + i) % kStep == 0 && !progress(0.6 * static_cast<double>(done + i) / total)) {
        return Status::Error(kPlanCancelled);
      }
      const Eigen::Vector3d p = points[i].cast<double>();
      if (!p.allFinite()) {
        ++stats.non_finite;
        continue;
      }
      const double z = z_row.dot(p) + t.z();
      levels.Add(z);
      if (std::abs(z - height) > band) continue;
      section.push_back((r.topRows<2>() * p + t.head<2>()).eval());
    }
    done += points.size();
  }
  stats.points_in = total;
  stats.points_out = section.size();
  if (!progress(0.6)) return Status::Error(kPlanCancelled);
  if (double level = 0.0; level_near_cut != nullptr && levels.LevelNear(0.03, &level))
    *level_near_cut = level;
  const Status s = plan::BuildFloorPlanFromSection(section, options, plan);
  plan->section = stats;
  if (!s.ok()) return s;
  progress(1.0);
  return Status::Ok();
}

}  // namespace sweepscan::ui
