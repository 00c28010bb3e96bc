#include "core/sim/rig.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace sweepscan::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

Eigen::Matrix3d Columns(const Eigen::Vector3d& x, const Eigen::Vector3d& y, const Eigen::Vector3d& z) {
  Eigen::Matrix3d m;
  m.col(0) = x;
  m.col(1) = y;
  m.col(2) = z;
  return m;
}

Box RoomBox(const std::string& label, double x0, double x1, double y0, double y1, double z0, double z1,
            bool inside) {
  Box b;
  b.label = label;
  b.center = {0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * (z0 + z1)};
  b.size = {x1 - x0, y1 - y0, z1 - z0};
  b.inside = inside;
  return b;
}

// Box -> world rotation: Rz(yaw) Ry(pitch) (scene.h).
Eigen::Matrix3d WorldFromBox(const Box& b) { return RotZ(b.yaw) * RotY(b.pitch); }

}  // namespace

std::vector<RigLidarSpec> DefaultHandheldRig(double tilt_deg) {
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(),
                        z = Eigen::Vector3d::UnitZ();
  std::vector<RigLidarSpec> rig(2);
  // Lidar 0 scans across the rig: lidar x (centre of view) -> rig up, lidar
  // y -> rig left; then the scan plane leans forward by tilt (about rig y).
  const Eigen::Matrix3d across = RotY(tilt_deg * kDeg) * Columns(z, y, -x);
  // Lidar 1 scans along the rig: lidar x -> up, lidar y -> backwards; leaning
  // sideways by tilt (about rig x).
  const Eigen::Matrix3d along = RotX(tilt_deg * kDeg) * Columns(z, -x, -y);
  rig[0].rig_from_lidar = Rigid3d({0.08, 0.0, 0.05}, Eigen::Quaterniond(across));
  rig[1].rig_from_lidar = Rigid3d({-0.08, 0.0, 0.05}, Eigen::Quaterniond(along));
  return rig;
}

std::vector<Eigen::Vector2d> RigScan::Points() const {
  std::vector<Eigen::Vector2d> p(ranges.size());
  for (size_t i = 0; i < ranges.size(); ++i) {
    if (ranges[i] > 0.0) {
      p[i] = ranges[i] * Eigen::Vector2d(std::cos(angles[i]), std::sin(angles[i]));
    } else {
      p[i] = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
    }
  }
  return p;
}

RigRun SimulateRig(const RigSimConfig& config) {
  RigRun run;
  std::mt19937_64 rng(config.seed * 7 + 5);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (const RigLidarSpec& l : config.lidars) run.rig_from_lidar.push_back(l.rig_from_lidar);
  const Scene& scene = config.scene;
  for (int f = 0; f < config.frames; ++f) {
    const double t = f / config.rate_hz;
    const Rigid3d world_from_rig = config.path(t);
    run.frame_times_s.push_back(t);
    run.world_from_rig.push_back(world_from_rig);
    for (size_t li = 0; li < config.lidars.size(); ++li) {
      const RigLidarSpec& spec = config.lidars[li];
      const Rigid3d world_from_lidar = world_from_rig * spec.rig_from_lidar;
      const Eigen::Matrix3d R = world_from_lidar.rotation().toRotationMatrix();
      const Eigen::Vector3d origin = world_from_lidar.translation();
      const double cos_start = std::cos(spec.grazing_dropout_start_deg * kDeg);
      const double span = (spec.grazing_dropout_end_deg - spec.grazing_dropout_start_deg) * kDeg;
      RigScan scan;
      scan.time_s = t;
      scan.frame = f;
      scan.lidar = static_cast<int>(li);
      const int beams = static_cast<int>(std::floor((spec.fov_end_rad - spec.fov_start_rad) / spec.step_rad + 1e-9)) + 1;
      for (int k = 0; k < beams; ++k) {
        const double a = spec.fov_start_rad + k * spec.step_rad;
        const Eigen::Vector3d dir = R * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0);
        RayHit hit;
        double range = 0.0;
        int prim = -1, face = -1;
        if (scene.Cast(origin, dir, 1e-6, spec.max_range_m, &hit)) {
          prim = hit.primitive;
          face = hit.face;
          // Returns fade out at grazing incidence (as the X4 in world.cc).
          const double cos_inc = std::abs(hit.normal.dot(dir));
          double p_keep = (1.0 - spec.dropout_probability) * (1.0 - scene.boxes()[hit.primitive].dropout);
          if (cos_inc < cos_start) {
            const double inc = std::acos(std::clamp(cos_inc, 0.0, 1.0));
            p_keep *= std::clamp(1.0 - (inc - spec.grazing_dropout_start_deg * kDeg) / span, 0.0, 1.0);
          }
          const double sigma = std::hypot(spec.range_noise_m, spec.range_noise_fraction * hit.range);
          const double noisy = hit.range + sigma * gauss(rng);
          if (uniform(rng) < p_keep && noisy >= spec.min_range_m && noisy <= spec.max_range_m) {
            range = spec.range_quantum_m > 0.0 ? std::round(noisy / spec.range_quantum_m) * spec.range_quantum_m
                                               : noisy;
          }
        }
        scan.angles.push_back(a);
        scan.ranges.push_back(range);
        scan.primitive.push_back(prim);
        scan.face.push_back(face);
      }
      run.scans.push_back(std::move(scan));
    }
  }
  return run;
}

Scene SmallRoomScene() {
  Scene s;
  s.Add(RoomBox("room", 0, 5, 0, 4, 0, 2.6, /*inside=*/true));
  s.Add(RoomBox("cabinet", 4.4, 5.0, 0.5, 1.7, 0.0, 1.9, false));
  s.Add(RoomBox("desk", 1.5, 3.0, 3.3, 4.0, 0.0, 0.75, false));
  return s;
}

RigSimConfig SmallRoomRigScenario(int frames, uint64_t seed) {
  RigSimConfig c;
  c.name = "room";
  c.seed = seed;
  c.scene = SmallRoomScene();
  c.frames = frames;
  const double period = std::max(1, frames) / c.rate_hz;  // one loop
  const double w = 2.0 * M_PI / period;
  // An ellipse round the room's middle, the rig turning with the walk
  // (yaw through a full circle), swaying in roll and pitch, bobbing.
  c.path = [w](double t) {
    const double a = w * t;
    const double x = 2.5 + 1.1 * std::cos(a), y = 2.0 + 0.8 * std::sin(a);
    const double z = 1.3 + 0.15 * std::sin(3.0 * a);
    const double yaw = a + M_PI / 2 + 0.3 * std::sin(2.0 * a);
    const double roll = 8.0 * kDeg * std::sin(2.0 * M_PI * t / 5.3);
    const double pitch = 8.0 * kDeg * std::sin(2.0 * M_PI * t / 7.1 + 0.5);
    return Rigid3d::FromPose(x, y, z, roll, pitch, yaw);
  };
  return c;
}

RigSimConfig StairwellRigScenario(int frames, uint64_t seed) {
  RigSimConfig c;
  c.name = "stairwell";
  c.seed = seed;
  c.scene = StairwellScene();
  c.frames = frames;
  const double period = std::max(1, frames) / c.rate_hz / 2.0;  // up and down twice
  const double w = 2.0 * M_PI / period;
  // Along the flight (x from 1.2 to 7.2 m and back), the head 1.35 m above
  // the (smoothed) stair surface: the flight rises 2.38 m over x = 3 .. 6.92.
  c.path = [w](double t) {
    const double a = w * t;
    const double x = 1.2 + 3.0 * (1.0 - std::cos(a));
    const double y = 1.4 + 0.25 * std::sin(1.7 * a);
    const double s = std::clamp((x - 3.14) / 3.92, 0.0, 1.0);
    const double ground = 2.38 * s * s * (3.0 - 2.0 * s);
    const double z = ground + 1.35 + 0.05 * std::sin(5.0 * a);
    const double yaw = 0.5 * std::sin(0.9 * a) + 0.2 * std::sin(2.3 * a);
    const double roll = 8.0 * kDeg * std::sin(2.0 * M_PI * t / 5.3);
    const double pitch = 8.0 * kDeg * std::sin(2.0 * M_PI * t / 7.1 + 0.5);
    return Rigid3d::FromPose(x, y, z, roll, pitch, yaw);
  };
  return c;
}

TruthPlane ScenePlane(const Scene& scene, int primitive, int face) {
  const Box& b = scene.boxes()[primitive];
  Eigen::Vector3d outward = Eigen::Vector3d::Zero();
  outward[face / 2] = (face % 2 == 0) ? -1.0 : 1.0;
  const Eigen::Matrix3d R = WorldFromBox(b);
  const Eigen::Vector3d n_out = R * outward;
  const Eigen::Vector3d on_face = b.center + R * (0.5 * b.size[face / 2] * outward);
  TruthPlane p;
  // A room is seen from inside: its back side is outwards. A solid box is
  // seen from outside: its back side is inwards.
  p.normal = b.inside ? n_out : Eigen::Vector3d(-n_out);
  p.d = -p.normal.dot(on_face);
  p.primitive = primitive;
  p.face = face;
  p.label = b.label + "/" + FaceName(face);
  return p;
}

std::vector<TruthPlane> ScenePlanes(const Scene& scene) {
  std::vector<TruthPlane> planes;
  for (size_t i = 0; i < scene.boxes().size(); ++i) {
    for (int f = 0; f < 6; ++f) planes.push_back(ScenePlane(scene, static_cast<int>(i), f));
  }
  return planes;
}

Rigid3d X4LidarFromScanPlane() {
  // Scan-plane (x, y, 0) = (r cos theta, r sin theta, 0) -> X4 frame
  // (0, r sin theta, r cos theta) (Eq. 1): x -> z, y -> y, z -> -x.
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(),
                        z = Eigen::Vector3d::UnitZ();
  return Rigid3d::Rotation(Eigen::Quaterniond(Columns(z, y, -x)));
}

std::vector<RigScan> RigScansFromLidarScans(const std::vector<LidarScan>& scans) {
  std::vector<RigScan> out;
  out.reserve(scans.size());
  for (size_t i = 0; i < scans.size(); ++i) {
    const LidarScan& s = scans[i];
    if (s.samples.empty()) continue;
    RigScan r;
    r.time_s = 0.5 * (ToSeconds(s.start_time()) + ToSeconds(s.end_time()));
    r.frame = static_cast<int>(out.size());
    r.lidar = 0;
    for (const LidarSample& sample : s.samples) {
      r.angles.push_back(sample.theta);
      r.ranges.push_back(sample.range_m);
      r.primitive.push_back(-1);
      r.face.push_back(-1);
    }
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace sweepscan::sim
