// The plane work that the evaluation's RANSAC and the automatic
// calibration's segmentation share: points as a structure of arrays, and
// hypotheses scored by a vectorised count of the points within a band of
// the plane, many hypotheses at once on every core.
//
// Both run sequential RANSAC (the largest plane first, its inliers removed)
// with hypotheses drawn in order from one seeded generator; scoring them in
// parallel and choosing the best in draw order gives the serial answer on
// any thread count.
#ifndef SWEEPSCAN_CORE_EVALUATION_PLANE_SCORING_H_
#define SWEEPSCAN_CORE_EVALUATION_PLANE_SCORING_H_

#include <Eigen/Core>
#include <cstddef>
#include <functional>
#include <vector>

namespace sweepscan {

struct PointsSoa {
  std::vector<float> x, y, z;
  std::vector<float> band;  // per-point band (optional; empty: one band for all)

  size_t size() const { return x.size(); }
  void Resize(size_t n) {
    x.resize(n);
    y.resize(n);
    z.resize(n);
  }
  void Set(size_t i, float px, float py, float pz) {
    x[i] = px;
    y[i] = py;
    z[i] = pz;
  }
};

// |a x + b y + c z + d| summed as Eigen's SSE dot of two Vector4f does
// ((ax + cz) + (by + d)), as PCL's plane model computes it.
inline float PlaneDistance(const Eigen::Vector4f& q, float x, float y, float z) {
  return std::abs((q[0] * x + q[2] * z) + (q[1] * y + q[3]));
}

// Number of points with PlaneDistance <= band (or <= s.band[i] when `band`
// is negative and s.band is set).
size_t CountWithinPlane(const PointsSoa& s, const Eigen::Vector4f& q, float band);

// Runs body(begin, end) over [0, n) in blocks of `block`, on every core when
// `parallel` (oneTBB), else here. Blocks are independent (no shared writes).
void ForBlocks(size_t n, size_t block, bool parallel,
               const std::function<void(size_t, size_t)>& body);

// counts[h] = CountWithinPlane(s, hypotheses[h], band) for every h, in
// parallel when `parallel`.
void ScoreHypotheses(const PointsSoa& s, const std::vector<Eigen::Vector4f>& hypotheses,
                     float band, bool parallel, std::vector<size_t>* counts);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_EVALUATION_PLANE_SCORING_H_
