// Planes: n . p + d = 0 with |n| = 1.
//
// The least-squares plane through points p_i is the one through their
// centroid c whose normal is the eigenvector of the smallest eigenvalue of
// the scatter matrix S = sum (p_i - c)(p_i - c)^T; its RMS residual is
// sqrt(lambda_min / N).
#ifndef SWEEPSCAN_CORE_GEOMETRY_PLANE_H_
#define SWEEPSCAN_CORE_GEOMETRY_PLANE_H_

#include <Eigen/Core>
#include <vector>

namespace sweepscan {

struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double d = 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double rms = 0.0;
  size_t count = 0;

  double SignedDistance(const Eigen::Vector3d& p) const { return normal.dot(p) + d; }
};

// False if fewer than 3 points or all collinear.
bool FitPlane(const std::vector<Eigen::Vector3d>& points, Plane* plane);

// FitPlane for points that arrive one at a time and are not kept (a
// streamed cloud): the centroid and S updated per point (Welford's update,
// S += (p - c_old)(p - c_new)^T, so no large sums cancel). 96 bytes,
// whatever the count; the plane is FitPlane's to rounding.
class PlaneFit {
 public:
  void Add(const Eigen::Vector3d& p) {
    ++count_;
    const Eigen::Vector3d before = p - centroid_;
    centroid_ += before / static_cast<double>(count_);
    scatter_ += before * (p - centroid_).transpose();
  }
  size_t count() const { return count_; }
  // False as FitPlane.
  bool Fit(Plane* plane) const;

 private:
  size_t count_ = 0;
  Eigen::Vector3d centroid_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d scatter_ = Eigen::Matrix3d::Zero();
};

// Distance between two nearly parallel planes: the mean of each centroid's
// distance to the other plane (symmetric, robust to a small tilt between them).
double DistanceBetweenPlanes(const Plane& a, const Plane& b);

// Angle between the planes' normals, ignoring orientation (radians, [0, pi/2]).
double AngleBetweenPlanes(const Plane& a, const Plane& b);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_GEOMETRY_PLANE_H_
