#include "core/cloud/assembler.h"

#include <cmath>

namespace sweepscan {

bool AssemblyOptions::IsValid(std::string* error) const {
  if (!(min_range_m >= 0.0) || !(max_range_m > min_range_m) || !std::isfinite(max_range_m)) {
    *error = "assembly range limits must satisfy 0 <= min_range_m < max_range_m";
    return false;
  }
  return true;
}

template <typename Emit>
void Assembler::Place(const LidarScan& scan, const PoseBuffer& poses, Emit&& emit) {
  const Eigen::Matrix3f r_bl = body_from_lidar_.rotation().toRotationMatrix().cast<float>();
  const Eigen::Vector3f t_bl = body_from_lidar_.translation().cast<float>();
  // p_L = (0, rho sin theta, rho cos theta), so R_bl p_L only needs columns 1 and 2.
  const Eigen::Vector3f c1 = r_bl.col(1), c2 = r_bl.col(2);

  size_t hint = 0;
  Rigid3d world_from_body;
  // Initialised only to keep GCC 12's -Wmaybe-uninitialized quiet: both are
  // set before use (deskew: per interval; otherwise have_fixed_pose).
  Eigen::Matrix3f r_wb = Eigen::Matrix3f::Zero();
  Eigen::Vector3f t_wb = Eigen::Vector3f::Zero();
  // Deskew works interval by interval of the pose buffer: the poses at both
  // ends of the current interval are turned into matrices once, and each
  // sample blends them, R(s) = (1 - s) R_a + s R_b, t(s) likewise. Between
  // filter steps (10 ms, < 0.01 rad) the blend departs from the slerp
  // rotation by under 1e-5 rad (about delta^2 / 8), 0.1 mm at 10 m, at a
  // fraction of the cost of a quaternion per sample.
  size_t interval = static_cast<size_t>(-1);
  Eigen::Matrix3f r_a = Eigen::Matrix3f::Zero();  // R_a
  Eigen::Matrix3f r_d = Eigen::Matrix3f::Zero();  // R_b - R_a
  Eigen::Vector3f t_a = Eigen::Vector3f::Zero(), t_d = Eigen::Vector3f::Zero();
  bool have_fixed_pose = false;
  if (!options_.deskew) {
    if (!scan.samples.empty() && poses.Lookup(scan.start_time(), &world_from_body)) {
      r_wb = world_from_body.rotation().toRotationMatrix().cast<float>();
      t_wb = world_from_body.translation().cast<float>();
      have_fixed_pose = true;
    }
  }
  const float min_r = static_cast<float>(options_.min_range_m);
  const float max_r = static_cast<float>(options_.max_range_m);
  const uint8_t flags = options_.deskew ? 0 : 1;

  for (const LidarSample& s : scan.samples) {
    ++stats_.samples_in;
    if (!(s.range_m >= min_r && s.range_m <= max_r)) {
      ++stats_.invalid_range;
      continue;
    }
    if (options_.deskew) {
      size_t i;
      double frac;
      if (!poses.FindInterval(s.time, &hint, &i, &frac)) {
        ++stats_.no_pose;
        continue;
      }
      if (i != interval) {
        interval = i;
        const Rigid3d& a = poses.pose(i);
        const Rigid3d& b = i + 1 < poses.size() ? poses.pose(i + 1) : a;
        r_a = a.rotation().toRotationMatrix().cast<float>();
        r_d = b.rotation().toRotationMatrix().cast<float>() - r_a;
        t_a = a.translation().cast<float>();
        t_d = b.translation().cast<float>() - t_a;
      }
      const float f = static_cast<float>(frac);
      r_wb = r_a + f * r_d;
      t_wb = t_a + f * t_d;
    } else if (!have_fixed_pose) {
      ++stats_.no_pose;
      continue;
    }
    const Eigen::Vector3f p_b = s.range_m * (std::sin(s.theta) * c1 + std::cos(s.theta) * c2) + t_bl;
    const Eigen::Vector3f p_w = r_wb * p_b + t_wb;
    CloudPoint p;
    p.x = options_.snap_to_grid ? SnapToGrid(p_w.x()) : p_w.x();
    p.y = options_.snap_to_grid ? SnapToGrid(p_w.y()) : p_w.y();
    p.z = options_.snap_to_grid ? SnapToGrid(p_w.z()) : p_w.z();
    p.range_m = s.range_m;
    p.time_ns = ToNanoseconds(s.time);
    p.scan = scan.index;
    p.beam = s.beam;
    p.pose_source = static_cast<uint8_t>(source_);
    p.flags = flags;
    emit(p);
    ++stats_.points_out;
  }
}

void Assembler::AddScan(const LidarScan& scan, const PoseBuffer& poses, PointChunks* out) {
  Place(scan, poses, [out](const CloudPoint& p) { out->Append(p); });
}

void Assembler::AddScan(const LidarScan& scan, const PoseBuffer& poses, CloudChunk* out) {
  Place(scan, poses, [out](const CloudPoint& p) { out->push_back(p); });
}

}  // namespace sweepscan
