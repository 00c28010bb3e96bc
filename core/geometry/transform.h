// Rigid transforms and SO(3) helpers.
//
// Naming rule (Cartographer's): a transform is named `a_from_b`; it maps
// coordinates expressed in frame b into frame a, so chains read right:
//   world_from_lidar = world_from_body * body_from_lidar.
//
// Rotations are unit quaternions; angles are radians. Euler angles follow
// the aerospace z-y-x convention used by the seed paper (Miao et al. 2022,
// Eq. 13) and by the HI219: R = Rz(yaw) * Ry(pitch) * Rx(roll).
#ifndef SWEEPSCAN_CORE_GEOMETRY_TRANSFORM_H_
#define SWEEPSCAN_CORE_GEOMETRY_TRANSFORM_H_

#include <algorithm>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace sweepscan {

// Wraps an angle to (-pi, pi].
inline double WrapAngle(double a) {
  a = std::fmod(a + M_PI, 2.0 * M_PI);
  if (a <= 0.0) a += 2.0 * M_PI;
  return a - M_PI;
}

inline Eigen::Matrix3d RotZ(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}
inline Eigen::Matrix3d RotY(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).toRotationMatrix();
}
inline Eigen::Matrix3d RotX(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()).toRotationMatrix();
}

// R = Rz(yaw) Ry(pitch) Rx(roll).
inline Eigen::Quaterniond QuaternionFromRollPitchYaw(double roll, double pitch, double yaw) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()));
}

// Inverse of QuaternionFromRollPitchYaw; pitch in [-pi/2, pi/2].
inline Eigen::Vector3d RollPitchYawFromQuaternion(const Eigen::Quaterniond& q) {
  const Eigen::Matrix3d r = q.normalized().toRotationMatrix();
  const double pitch = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
  const double roll = std::atan2(r(2, 1), r(2, 2));
  const double yaw = std::atan2(r(1, 0), r(0, 0));
  return {roll, pitch, yaw};
}

inline double YawFromQuaternion(const Eigen::Quaterniond& q) {
  return RollPitchYawFromQuaternion(q)[2];
}

// A rigid transform: p_a = rotation * p_b + translation.
class Rigid3d {
 public:
  Rigid3d() : translation_(Eigen::Vector3d::Zero()), rotation_(Eigen::Quaterniond::Identity()) {}
  Rigid3d(const Eigen::Vector3d& translation, const Eigen::Quaterniond& rotation)
      : translation_(translation), rotation_(rotation.normalized()) {}

  static Rigid3d Identity() { return Rigid3d(); }
  static Rigid3d Translation(const Eigen::Vector3d& t) {
    return Rigid3d(t, Eigen::Quaterniond::Identity());
  }
  static Rigid3d Rotation(const Eigen::Quaterniond& q) { return Rigid3d(Eigen::Vector3d::Zero(), q); }
  // Planar pose: position (x, y, z) with yaw and optional roll and pitch.
  static Rigid3d FromPose(double x, double y, double z, double roll, double pitch, double yaw) {
    return Rigid3d({x, y, z}, QuaternionFromRollPitchYaw(roll, pitch, yaw));
  }

  const Eigen::Vector3d& translation() const { return translation_; }
  const Eigen::Quaterniond& rotation() const { return rotation_; }

  Rigid3d inverse() const {
    const Eigen::Quaterniond inv = rotation_.conjugate();
    return Rigid3d(-(inv * translation_), inv);
  }

  Eigen::Isometry3d ToIsometry() const {
    Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
    iso.linear() = rotation_.toRotationMatrix();
    iso.translation() = translation_;
    return iso;
  }

  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return rotation_ * p + translation_; }
  Rigid3d operator*(const Rigid3d& rhs) const {
    return Rigid3d(rotation_ * rhs.translation_ + translation_, rotation_ * rhs.rotation_);
  }

 private:
  Eigen::Vector3d translation_;
  Eigen::Quaterniond rotation_;
};

// Interpolates between two transforms: linear in translation, slerp in
// rotation; s = 0 gives a, s = 1 gives b.
inline Rigid3d Interpolate(const Rigid3d& a, const Rigid3d& b, double s) {
  return Rigid3d(a.translation() + s * (b.translation() - a.translation()),
                 a.rotation().slerp(s, b.rotation()));
}

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_GEOMETRY_TRANSFORM_H_
