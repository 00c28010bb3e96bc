// Sections of a 3D cloud (z up, metres): the points of a thin slab, laid
// flat in the slab's own 2D coordinates.
//
//   horizontal: |z - height| <= band       -> (x, y), the plan view
//   vertical:   |n . (p - a)| <= band and 0 <= s <= |b - a|, with
//               s = u . (p - a), u = (b - a) / |b - a|, n = u turned +90 deg
//                                           -> (s, z): what a viewer standing
//               right of a -> b sees looking across the line (along n), s
//               growing to the viewer's right, z up
//
// Bad input is refused with a Status: an empty cloud, a band <= 0 or not
// finite, a height or line that is not finite, a line shorter than 1 mm.
// Points with a non-finite coordinate are skipped and counted.
//
// Pure functions; any thread.
#ifndef SWEEPSCAN_CORE_PLAN_SECTION_H_
#define SWEEPSCAN_CORE_PLAN_SECTION_H_

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "core/common/status.h"

namespace sweepscan::plan {

struct HorizontalSectionOptions {
  double height_m = 1.0;  // the cut's height above z = 0 (a surveyor's 1 m)
  double band_m = 0.05;   // half thickness of the slab
  bool IsValid(std::string* error) const;
};

struct VerticalSectionOptions {
  Eigen::Vector2d a = Eigen::Vector2d::Zero();  // the section line in plan (m)
  Eigen::Vector2d b = Eigen::Vector2d::UnitX();
  double band_m = 0.05;  // half thickness either side of the line
  bool IsValid(std::string* error) const;
};

struct SectionStats {
  size_t points_in = 0;    // cloud points looked at
  size_t non_finite = 0;   // skipped for a NaN or infinite coordinate
  size_t points_out = 0;   // in the slab
};

// The plan view's points: (x, y) of every point in the slab.
Status HorizontalSection(const std::vector<Eigen::Vector3f>& cloud, const HorizontalSectionOptions& options,
                         std::vector<Eigen::Vector2d>* points, SectionStats* stats = nullptr);

// The vertical section's points: (s along a -> b, z).
Status VerticalSection(const std::vector<Eigen::Vector3f>& cloud, const VerticalSectionOptions& options,
                       std::vector<Eigen::Vector2d>* points, SectionStats* stats = nullptr);

// Whether a level surface (a floor, a ceiling: a centimetre of z holding at
// least 8 times the points of the median occupied centimetre within 1 m of
// the cut) lies within `reach_m` of the cut's slab. A cut through one draws
// its whole extent as points, which the wall fit turns into diagonal
// "walls". Sets *level_z to the surface's height (the middle of its
// centimetre) when found.
bool LevelSurfaceNearCut(const std::vector<Eigen::Vector3f>& cloud,
                         const HorizontalSectionOptions& options, double reach_m, double* level_z);

// LevelSurfaceNearCut's counting, for points that arrive one at a time (the
// app's plan transforms each session's points into the project's frame as
// it cuts them): a centimetre histogram of z within 1 m of the cut.
class CutLevels {
 public:
  explicit CutLevels(const HorizontalSectionOptions& options);
  void Add(double z) {
    const double k = std::floor((z - lo_) / kBin);
    if (k >= 0 && k < static_cast<double>(count_.size())) ++count_[static_cast<size_t>(k)];
  }
  // LevelSurfaceNearCut's answer for the points added.
  bool LevelNear(double reach_m, double* level_z) const;

 private:
  static constexpr double kBin = 0.01, kWindow = 1.0, kRatio = 8.0;
  HorizontalSectionOptions options_;
  double lo_;
  std::vector<size_t> count_;
};

// One representative point (the centroid) per occupied square cell of side
// `cell_m`, in a deterministic order (sorted by cell): a drawing's copy of a
// section, its density evened out. cell_m must be > 0.
std::vector<Eigen::Vector2d> DecimateGrid(const std::vector<Eigen::Vector2d>& points, double cell_m);

}  // namespace sweepscan::plan

#endif  // SWEEPSCAN_CORE_PLAN_SECTION_H_
