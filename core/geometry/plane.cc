#include "core/geometry/plane.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace sweepscan {

namespace {

// The plane through centroid c of `n` points with scatter S (header).
bool PlaneFromScatter(const Eigen::Vector3d& c, const Eigen::Matrix3d& s, size_t n, Plane* plane) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(s);
  const Eigen::Vector3d ev = eig.eigenvalues();             // ascending
  if (ev[1] <= 1e-12 * std::max(1.0, ev[2])) return false;  // collinear or a single point
  plane->normal = eig.eigenvectors().col(0).normalized();
  plane->centroid = c;
  plane->d = -plane->normal.dot(c);
  plane->rms = std::sqrt(std::max(0.0, ev[0]) / static_cast<double>(n));
  plane->count = n;
  return true;
}

}  // namespace

bool FitPlane(const std::vector<Eigen::Vector3d>& points, Plane* plane) {
  if (points.size() < 3) return false;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : points) c += p;
  c /= static_cast<double>(points.size());
  Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
  for (const auto& p : points) {
    const Eigen::Vector3d q = p - c;
    s += q * q.transpose();
  }
  return PlaneFromScatter(c, s, points.size(), plane);
}

bool PlaneFit::Fit(Plane* plane) const {
  if (count_ < 3) return false;
  // The update's product is symmetric only to rounding.
  const Eigen::Matrix3d s = 0.5 * (scatter_ + scatter_.transpose());
  return PlaneFromScatter(centroid_, s, count_, plane);
}

double DistanceBetweenPlanes(const Plane& a, const Plane& b) {
  return 0.5 * (std::abs(b.SignedDistance(a.centroid)) + std::abs(a.SignedDistance(b.centroid)));
}

double AngleBetweenPlanes(const Plane& a, const Plane& b) {
  return std::acos(std::clamp(std::abs(a.normal.dot(b.normal)), 0.0, 1.0));
}

}  // namespace sweepscan
