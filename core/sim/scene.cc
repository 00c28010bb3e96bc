#include "core/sim/scene.h"

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

namespace sweepscan::sim {
namespace {

// World -> box frame: Ry(pitch)^T Rz(yaw)^T (p - center).
Eigen::Vector3d DirToBox(const Box& b, const Eigen::Vector3d& v) {
  const double c = std::cos(b.yaw), s = std::sin(b.yaw);
  const Eigen::Vector3d r(c * v.x() + s * v.y(), -s * v.x() + c * v.y(), v.z());
  if (b.pitch == 0.0) return r;
  const double cp = std::cos(b.pitch), sp = std::sin(b.pitch);
  return {cp * r.x() - sp * r.z(), r.y(), sp * r.x() + cp * r.z()};
}
Eigen::Vector3d ToBox(const Box& b, const Eigen::Vector3d& p) { return DirToBox(b, p - b.center); }
// Box -> world direction: Rz(yaw) Ry(pitch) v.
Eigen::Vector3d DirToWorld(const Box& b, const Eigen::Vector3d& v) {
  Eigen::Vector3d r = v;
  if (b.pitch != 0.0) {
    const double cp = std::cos(b.pitch), sp = std::sin(b.pitch);
    r = {cp * v.x() + sp * v.z(), v.y(), -sp * v.x() + cp * v.z()};
  }
  const double c = std::cos(b.yaw), s = std::sin(b.yaw);
  return {c * r.x() - s * r.y(), s * r.x() + c * r.y(), r.z()};
}

// Slab intersection in the box frame: entry and exit parameters and the axes
// (with sign) of the faces crossed there.
bool Slabs(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& h,
           double* t_in, int* face_in, double* t_out, int* face_out) {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  int f_lo = -1, f_hi = -1;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-15) {
      if (o[a] < -h[a] || o[a] > h[a]) return false;
      continue;
    }
    double t1 = (-h[a] - o[a]) / d[a];  // plane of face 2a (negative side)
    double t2 = (h[a] - o[a]) / d[a];   // plane of face 2a+1
    int f1 = 2 * a, f2 = 2 * a + 1;
    if (t1 > t2) {
      std::swap(t1, t2);
      std::swap(f1, f2);
    }
    if (t1 > lo) {
      lo = t1;
      f_lo = f1;
    }
    if (t2 < hi) {
      hi = t2;
      f_hi = f2;
    }
    if (lo > hi) return false;
  }
  *t_in = lo;
  *face_in = f_lo;
  *t_out = hi;
  *face_out = f_hi;
  return true;
}

Eigen::Vector3d FaceNormalOutward(int face) {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  n[face / 2] = (face % 2 == 0) ? -1.0 : 1.0;
  return n;
}

}  // namespace

const char* FaceName(int face) {
  static const char* kNames[] = {"-x", "+x", "-y", "+y", "-z", "+z"};
  return face >= 0 && face < 6 ? kNames[face] : "?";
}

int Scene::Find(const std::string& label) const {
  for (size_t i = 0; i < boxes_.size(); ++i) {
    if (boxes_[i].label == label) return static_cast<int>(i);
  }
  return -1;
}

bool Scene::Cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double min_range,
                 double max_range, RayHit* hit) const {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < boxes_.size(); ++i) {
    const Box& b = boxes_[i];
    const Eigen::Vector3d o = ToBox(b, origin), d = DirToBox(b, direction);
    double t_in, t_out;
    int f_in, f_out;
    if (!Slabs(o, d, 0.5 * b.size, &t_in, &f_in, &t_out, &f_out)) continue;
    // Solid box: first surface is the entry (if ahead); a room: the exit.
    double t;
    int face;
    Eigen::Vector3d n_box;
    if (b.inside) {
      t = t_out;
      face = f_out;
      n_box = -FaceNormalOutward(face);  // inner face looks into the room
    } else {
      t = t_in;
      face = f_in;
      n_box = FaceNormalOutward(face);
      if (t <= min_range) continue;  // origin inside or behind: ignore
    }
    if (t > min_range && t <= max_range && t < best) {
      best = t;
      hit->range = t;
      hit->primitive = static_cast<int>(i);
      hit->face = face;
      hit->normal = DirToWorld(b, n_box);
    }
  }
  return std::isfinite(best);
}

double Scene::DistanceToSurface(const Eigen::Vector3d& p) const {
  double best = std::numeric_limits<double>::infinity();
  for (const Box& b : boxes_) {
    const Eigen::Vector3d q = ToBox(b, p).cwiseAbs();
    const Eigen::Vector3d h = 0.5 * b.size;
    const Eigen::Vector3d excess = q - h;
    double d;
    if ((excess.array() <= 0.0).all()) {
      d = -excess.maxCoeff();  // inside: distance to the nearest face
    } else {
      d = excess.cwiseMax(0.0).norm();
    }
    best = std::min(best, d);
  }
  return best;
}

bool Scene::IsValid(std::string* error) const {
  for (size_t i = 0; i < boxes_.size(); ++i) {
    const Box& b = boxes_[i];
    const std::string name = "box " + std::to_string(i) + " ('" + b.label + "')";
    if (!b.center.allFinite() || !std::isfinite(b.yaw) || !std::isfinite(b.pitch)) {
      *error = name + ": centre, yaw and pitch must be finite";
      return false;
    }
    if (!b.size.allFinite() || (b.size.array() <= 0.0).any()) {
      *error = name + ": size must be positive and finite";
      return false;
    }
    if (!(b.dropout >= 0.0 && b.dropout <= 1.0)) {
      *error = name + ": dropout must be within [0, 1]";
      return false;
    }
  }
  return true;
}

namespace {
Box MakeBox(const std::string& label, double x0, double x1, double y0, double y1, double z0,
            double z1, bool inside = false, double dropout = 0.0) {
  Box b;
  b.label = label;
  b.center = {0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * (z0 + z1)};
  b.size = {x1 - x0, y1 - y0, z1 - z0};
  b.inside = inside;
  b.dropout = dropout;
  return b;
}
}  // namespace

double LabTargetThickness(LabTarget target) {
  return target == LabTarget::kSquare ? 0.02 : 0.005;
}

Scene LabScene(LabTarget target) {
  Scene s;
  s.Add(MakeBox("room", 0, 10, 0, 5, 0, 2.5, /*inside=*/true));
  // Desks and cabinets against the long walls, clear of the drive paths.
  s.Add(MakeBox("desk_north_1", 1.0, 3.0, 4.2, 5.0, 0.0, 0.75));
  s.Add(MakeBox("desk_north_2", 3.6, 5.6, 4.2, 5.0, 0.0, 0.75));
  s.Add(MakeBox("cabinet_north", 6.4, 7.4, 4.55, 5.0, 0.0, 1.9));
  s.Add(MakeBox("desk_south", 7.2, 8.8, 0.0, 0.7, 0.0, 0.75));
  s.Add(MakeBox("cabinet_south", 1.0, 2.0, 0.0, 0.45, 0.0, 1.2));
  // The window sill and the target board standing on it.
  s.Add(MakeBox("window_sill", 4.0, 6.0, 0.0, 0.14, 0.0, 0.85));
  const double front = 0.16, back = front - LabTargetThickness(target);
  if (target == LabTarget::kSquare) {
    s.Add(MakeBox("target", 4.7, 5.3, back, front, 0.9, 1.5));
  } else {
    Box b = MakeBox("target", 4.7, 5.3, back, front, 1.05, 1.65);
    b.pitch = M_PI / 4;
    s.Add(b);
  }
  return s;
}

Scene StairwellScene() {
  Scene s;
  s.Add(MakeBox("stairwell", 0, 9, 0, 3, 0, 6, /*inside=*/true));
  const double x0 = 3.0, run = 0.28, rise = 0.17;
  const int steps = 14;
  for (int k = 0; k < steps; ++k) {
    s.Add(MakeBox("step_" + std::to_string(k + 1), x0 + run * k, 9.0, 0.0, 3.0, 0.0,
                  rise * (k + 1)));
  }
  s.Add(MakeBox("handrail", x0, x0 + run * steps, 2.9, 2.95, 0.0, rise * steps + 0.9));
  return s;
}

namespace {
constexpr double kFloorHeight = 2.7, kDoorHeight = 2.05;
}  // namespace

std::vector<RoomTruth> OfficeFloorRooms() {
  return {{"corridor", 0.0, 16.0, 0.0, 2.0},
          {"room_a", 0.0, 5.0, 2.1, 8.0},
          {"room_b", 5.1, 10.6, 2.1, 8.0},
          {"room_c", 10.7, 16.0, 2.1, 8.0}};
}

std::vector<DoorTruth> OfficeFloorDoors() {
  return {{"door_a", {2.0, 2.05}, {2.9, 2.05}},
          {"door_b", {7.0, 2.05}, {7.9, 2.05}},
          {"door_c", {12.5, 2.05}, {13.4, 2.05}},
          {"door_ab", {5.05, 6.0}, {5.05, 6.9}}};
}

Scene OfficeFloorScene() {
  Scene s;
  const double h = kFloorHeight;
  s.Add(MakeBox("building", 0, 16, 0, 8, 0, h, /*inside=*/true));
  // The corridor wall, cut by three doors, each with its lintel.
  s.Add(MakeBox("wall_corridor_1", 0.0, 2.0, 2.0, 2.1, 0, h));
  s.Add(MakeBox("wall_corridor_2", 2.9, 7.0, 2.0, 2.1, 0, h));
  s.Add(MakeBox("wall_corridor_3", 7.9, 12.5, 2.0, 2.1, 0, h));
  s.Add(MakeBox("wall_corridor_4", 13.4, 16.0, 2.0, 2.1, 0, h));
  s.Add(MakeBox("lintel_a", 2.0, 2.9, 2.0, 2.1, kDoorHeight, h));
  s.Add(MakeBox("lintel_b", 7.0, 7.9, 2.0, 2.1, kDoorHeight, h));
  s.Add(MakeBox("lintel_c", 12.5, 13.4, 2.0, 2.1, kDoorHeight, h));
  // A|B with a door at its north end; B|C closed.
  s.Add(MakeBox("wall_ab_1", 5.0, 5.1, 2.1, 6.0, 0, h));
  s.Add(MakeBox("wall_ab_2", 5.0, 5.1, 6.9, 8.0, 0, h));
  s.Add(MakeBox("lintel_ab", 5.0, 5.1, 6.0, 6.9, kDoorHeight, h));
  s.Add(MakeBox("wall_bc", 10.6, 10.7, 2.1, 8.0, 0, h));
  // Furniture, different in every room (below 1 m only where a plan's
  // section at 1 m should not see it).
  s.Add(MakeBox("desk_a", 0.3, 1.7, 7.2, 7.9, 0, 0.75));
  s.Add(MakeBox("cabinet_a", 4.4, 4.95, 3.0, 4.0, 0, 1.9));
  s.Add(MakeBox("desk_b", 6.0, 8.0, 7.3, 8.0, 0, 0.75));
  s.Add(MakeBox("table_b", 8.2, 9.4, 4.8, 5.6, 0, 0.75));
  s.Add(MakeBox("cabinet_b", 9.95, 10.55, 3.0, 3.5, 0, 1.2));
  s.Add(MakeBox("shelves_c", 15.5, 15.95, 3.0, 6.0, 0, 2.0));
  s.Add(MakeBox("desk_c", 11.5, 13.0, 7.3, 8.0, 0, 0.75));
  return s;
}

}  // namespace sweepscan::sim
