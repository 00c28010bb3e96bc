#include "core/sim/truth_eval.h"

#include <algorithm>
#include <cmath>

namespace sweepscan::sim {
namespace {

Eigen::Vector3d P(const CloudPoint& p) { return {p.x, p.y, p.z}; }

Eigen::Vector3d ToBoxFrame(const Box& b, const Eigen::Vector3d& p) {
  const double c = std::cos(b.yaw), s = std::sin(b.yaw);
  const Eigen::Vector3d d = p - b.center;
  return {c * d.x() + s * d.y(), -s * d.x() + c * d.y(), d.z()};
}

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

}  // namespace

void SurfaceErrorAccumulator::Add(const CloudPoint* points, size_t n) {
  if (n > 0 && fine_.empty()) fine_.assign(kFineBins, 0);
  for (size_t i = 0; i < n; ++i) {
    const double e = scene_.DistanceToSurface(P(points[i]));
    sum_ += e;
    sum2_ += e * e;
    max_ = std::max(max_, e);
    if (e < 1.0) {
      ++fine_[static_cast<size_t>(e * 1e6)];
    } else {
      if (coarse_.empty()) coarse_.assign(kCoarseBins, 0);  // only a cloud that far off
      ++coarse_[std::min(kCoarseBins - 1, static_cast<size_t>(e * 1e3))];
    }
  }
  count_ += n;
}

SurfaceErrorStats SurfaceErrorAccumulator::Stats() const {
  SurfaceErrorStats s;
  s.count = count_;
  if (count_ == 0) return s;
  const double n = static_cast<double>(count_);
  s.mean = sum_ / n;
  s.rms = std::sqrt(sum2_ / n);
  s.max = max_;
  // The k-th smallest (0-based) is in the bin where the running count
  // first exceeds k; its centre, no farther than the largest distance.
  const uint64_t k = std::min<uint64_t>(count_ - 1, static_cast<uint64_t>(0.95 * (n - 1)));
  uint64_t below = 0;
  const auto kth = [&](const std::vector<uint64_t>& bins, double step) {
    for (size_t b = 0; b < bins.size(); ++b) {
      below += bins[b];
      if (below > k) return std::min(max_, (static_cast<double>(b) + 0.5) * step);
    }
    return -1.0;
  };
  s.p95 = kth(fine_, 1e-6);
  if (s.p95 < 0) s.p95 = kth(coarse_, 1e-3);
  return s;
}

SurfaceErrorStats SurfaceErrors(const Scene& scene, const std::vector<CloudPoint>& points) {
  SurfaceErrorAccumulator a(scene);
  a.Add(points.data(), points.size());
  return a.Stats();
}

RoomAccumulator::RoomAccumulator(const Scene& scene, const std::string& room_label, double band_m,
                                 double margin_m)
    : band_m_(band_m), margin_m_(margin_m) {
  room_ = scene.Find(room_label);
  if (room_ < 0 || !scene.boxes()[room_].inside) {
    room_ = -1;
    error_ = "no room box labelled '" + room_label + "'";
    return;
  }
  box_ = scene.boxes()[room_];
  // Everything but the room: points near these (the feet of a desk within
  // the floor's band, a handrail beside a wall) belong to them, not to a face.
  std::vector<Box> others;
  for (size_t i = 0; i < scene.boxes().size(); ++i) {
    if (static_cast<int>(i) != room_) others.push_back(scene.boxes()[i]);
  }
  furniture_ = Scene(std::move(others));
}

void RoomAccumulator::Add(const CloudPoint* points, size_t n) {
  if (room_ < 0) return;
  const Eigen::Vector3d h = 0.5 * box_.size;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d q = ToBoxFrame(box_, P(points[i]));
    for (int face = 0; face < 6; ++face) {
      const int axis = face / 2;
      const double wall = face % 2 == 0 ? -h[axis] : h[axis];
      if (std::abs(q[axis] - wall) > band_m_) continue;
      bool inside_edges = true;
      for (int a = 0; a < 3; ++a) {
        if (a != axis && std::abs(q[a]) > h[a] - margin_m_) inside_edges = false;
      }
      if (inside_edges &&
          (furniture_.boxes().empty() || furniture_.DistanceToSurface(P(points[i])) > band_m_)) {
        faces_[face].Add(q);
      }
    }
  }
}

RoomMeasurement RoomAccumulator::Result() const {
  RoomMeasurement m;
  if (room_ < 0) {
    m.error = error_;
    return m;
  }
  for (int face = 0; face < 6; ++face) {
    if (!faces_[face].Fit(&m.faces[face])) {
      m.error = std::string("too few points on the room's ") + FaceName(face) + " face";
      return m;
    }
  }
  m.true_size = box_.size;
  for (int axis = 0; axis < 3; ++axis) {
    m.measured[axis] = DistanceBetweenPlanes(m.faces[2 * axis], m.faces[2 * axis + 1]);
    m.relative_error[axis] = (m.measured[axis] - box_.size[axis]) / box_.size[axis];
  }
  m.ok = true;
  return m;
}

RoomMeasurement MeasureRoom(const Scene& scene, const std::string& room_label,
                            const std::vector<CloudPoint>& points, double band_m, double margin_m) {
  RoomAccumulator a(scene, room_label, band_m, margin_m);
  a.Add(points.data(), points.size());
  return a.Result();
}

TargetPassAccumulator::TargetPassAccumulator(const Scene& scene, const std::string& label,
                                             double band_m, double gap_s)
    : band_m_(band_m), gap_s_(gap_s) {
  box_index_ = scene.Find(label);
  if (box_index_ < 0) {
    error_ = "no box labelled '" + label + "'";
    return;
  }
  box_ = scene.boxes()[box_index_];
}

void TargetPassAccumulator::Add(const CloudPoint* points, size_t n) {
  if (box_index_ < 0) return;
  const Eigen::Vector3d h = 0.5 * box_.size + Eigen::Vector3d::Constant(band_m_);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d q = ToBoxFrame(box_, P(points[i])).cwiseAbs();
    if ((q.array() <= h.array()).all()) near_.push_back(points[i]);
  }
}

PassDisagreement TargetPassAccumulator::Result() const {
  PassDisagreement r;
  if (box_index_ < 0) {
    r.error = error_;
    return r;
  }
  std::vector<const CloudPoint*> near;
  near.reserve(near_.size());
  for (const CloudPoint& p : near_) near.push_back(&p);
  std::sort(near.begin(), near.end(),
            [](const CloudPoint* a, const CloudPoint* b) { return a->time_ns < b->time_ns; });
  std::vector<std::vector<Eigen::Vector3d>> passes;
  int64_t last = 0;
  for (const CloudPoint* p : near) {
    if (passes.empty() || static_cast<double>(p->time_ns - last) * 1e-9 > gap_s_)
      passes.emplace_back();
    passes.back().push_back(P(*p));
    last = p->time_ns;
  }
  r.passes = passes.size();
  if (passes.size() < 2) {
    r.error = "the target was seen in " + std::to_string(passes.size()) + " pass(es), need 2";
    return r;
  }
  double top[2];
  for (int k = 0; k < 2; ++k) {
    r.points[k] = passes[k].size();
    if (!FitPlane(passes[k], &r.planes[k])) {
      r.error = "too few target points in pass " + std::to_string(k + 1);
      return r;
    }
    r.centroid[k] = r.planes[k].centroid;
    std::vector<double> z;
    for (const auto& p : passes[k]) z.push_back(p.z());
    top[k] = Percentile(z, 0.98);
  }
  r.plane_angle_rad = AngleBetweenPlanes(r.planes[0], r.planes[1]);
  r.plane_offset_m = DistanceBetweenPlanes(r.planes[0], r.planes[1]);
  r.centroid_distance_m = (r.centroid[0] - r.centroid[1]).norm();
  r.edge_shift_m = std::abs(top[0] - top[1]);
  r.ok = true;
  return r;
}

PassDisagreement MeasureTargetPasses(const Scene& scene, const std::string& label,
                                     const std::vector<CloudPoint>& points, double band_m,
                                     double gap_s) {
  TargetPassAccumulator a(scene, label, band_m, gap_s);
  a.Add(points.data(), points.size());
  return a.Result();
}

}  // namespace sweepscan::sim
