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

SurfaceErrorStats SurfaceErrors(const Scene& scene, const std::vector<CloudPoint>& points) {
  SurfaceErrorStats s;
  std::vector<double> d;
  d.reserve(points.size());
  double sum = 0.0, sum2 = 0.0;
  for (const CloudPoint& p : points) {
    const double e = scene.DistanceToSurface(P(p));
    d.push_back(e);
    sum += e;
    sum2 += e * e;
    s.max = std::max(s.max, e);
  }
  s.count = d.size();
  if (s.count == 0) return s;
  s.mean = sum / static_cast<double>(s.count);
  s.rms = std::sqrt(sum2 / static_cast<double>(s.count));
  s.p95 = Percentile(std::move(d), 0.95);
  return s;
}

RoomMeasurement MeasureRoom(const Scene& scene, const std::string& room_label,
                            const std::vector<CloudPoint>& points, double band_m, double margin_m) {
  RoomMeasurement m;
  const int idx = scene.Find(room_label);
  if (idx < 0 || !scene.boxes()[idx].inside) {
    m.error = "no room box labelled '" + room_label + "'";
    return m;
  }
  const Box& room = scene.boxes()[idx];
  const Eigen::Vector3d h = 0.5 * room.size;
  // Everything but the room: points near these (the feet of a desk within
  // the floor's band, a handrail beside a wall) belong to them, not to a face.
  std::vector<Box> others;
  for (size_t i = 0; i < scene.boxes().size(); ++i) {
    if (static_cast<int>(i) != idx) others.push_back(scene.boxes()[i]);
  }
  const Scene furniture(others);
  std::vector<Eigen::Vector3d> face_points[6];
  for (const CloudPoint& cp : points) {
    const Eigen::Vector3d q = ToBoxFrame(room, P(cp));
    for (int face = 0; face < 6; ++face) {
      const int axis = face / 2;
      const double wall = face % 2 == 0 ? -h[axis] : h[axis];
      if (std::abs(q[axis] - wall) > band_m) continue;
      bool inside_edges = true;
      for (int a = 0; a < 3; ++a) {
        if (a != axis && std::abs(q[a]) > h[a] - margin_m) inside_edges = false;
      }
      if (inside_edges && (others.empty() || furniture.DistanceToSurface(P(cp)) > band_m)) {
        face_points[face].push_back(q);
      }
    }
  }
  for (int face = 0; face < 6; ++face) {
    if (!FitPlane(face_points[face], &m.faces[face])) {
      m.error = std::string("too few points on the room's ") + FaceName(face) + " face";
      return m;
    }
  }
  m.true_size = room.size;
  for (int axis = 0; axis < 3; ++axis) {
    m.measured[axis] = DistanceBetweenPlanes(m.faces[2 * axis], m.faces[2 * axis + 1]);
    m.relative_error[axis] = (m.measured[axis] - room.size[axis]) / room.size[axis];
  }
  m.ok = true;
  return m;
}

PassDisagreement MeasureTargetPasses(const Scene& scene, const std::string& label,
                                     const std::vector<CloudPoint>& points, double band_m,
                                     double gap_s) {
  PassDisagreement r;
  const int idx = scene.Find(label);
  if (idx < 0) {
    r.error = "no box labelled '" + label + "'";
    return r;
  }
  const Box& box = scene.boxes()[idx];
  const Eigen::Vector3d h = 0.5 * box.size + Eigen::Vector3d::Constant(band_m);
  std::vector<const CloudPoint*> near;
  for (const CloudPoint& p : points) {
    const Eigen::Vector3d q = ToBoxFrame(box, P(p)).cwiseAbs();
    if ((q.array() <= h.array()).all()) near.push_back(&p);
  }
  std::sort(near.begin(), near.end(),
            [](const CloudPoint* a, const CloudPoint* b) { return a->time_ns < b->time_ns; });
  std::vector<std::vector<Eigen::Vector3d>> passes;
  int64_t last = 0;
  for (const CloudPoint* p : near) {
    if (passes.empty() || static_cast<double>(p->time_ns - last) * 1e-9 > gap_s) passes.emplace_back();
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

}  // namespace sweepscan::sim
