// A hand-held rig of 2D lidars for lidar-only structure from motion (Choi,
// Bok, Kim, Shim, Kweon, Sensors 2017, 17:242; issue 12): one or more 2D
// lidars with known extrinsics, carried along a smooth 6-DoF path through a
// Scene, with ground-truth poses and the true plane of every box face.
//
// Lidar frame: the scan plane is the lidar's x-y plane, beam angle a from
// +x towards +y, a return at range r is (r cos a, r sin a, 0). The default
// rig follows the paper's Fig. 5: two lidars facing up (the centre of their
// 270 deg field of view points at the ceiling), one scanning across the rig
// (the rig's y-z plane) and one along it (x-z), each tilted 20 deg out of the
// vertical, so every scan crosses the ceiling, two walls and usually the floor.
//
// Each scan is taken at one instant (a Hokuyo revolution lasts 25 ms; the
// pipeline, like the paper, treats a scan as rigid), and all lidars of the
// rig scan at the same instants (one rig pose per frame). Range noise is the
// X4's model (world.h): Gaussian sigma = sqrt(a^2 + (b r)^2), quantised to
// 1 mm, random dropouts, more at grazing incidence.
#ifndef SWEEPSCAN_CORE_SIM_RIG_H_
#define SWEEPSCAN_CORE_SIM_RIG_H_

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "core/geometry/transform.h"
#include "core/robot/sensor_data.h"
#include "core/sim/scene.h"

namespace sweepscan::sim {

struct RigLidarSpec {
  Rigid3d rig_from_lidar;
  double fov_start_rad = -135.0 * M_PI / 180.0;
  double fov_end_rad = 135.0 * M_PI / 180.0;
  double step_rad = 0.25 * M_PI / 180.0;
  double min_range_m = 0.12;
  double max_range_m = 10.0;
  double range_noise_m = 0.002;         // a (X4)
  double range_noise_fraction = 0.002;  // b (X4)
  double range_quantum_m = 0.001;
  double dropout_probability = 0.01;
  double grazing_dropout_start_deg = 70.0;
  double grazing_dropout_end_deg = 88.0;
};

// The paper's Fig. 5 rig: two lidars facing up, tilted by `tilt_deg`.
std::vector<RigLidarSpec> DefaultHandheldRig(double tilt_deg = 20.0);

// world_from_rig at time t (s); must be smooth for a realistic hand-held walk.
using RigPath = std::function<Rigid3d(double t_s)>;

struct RigSimConfig {
  std::string name;
  uint64_t seed = 1;
  Scene scene;
  std::vector<RigLidarSpec> lidars = DefaultHandheldRig();
  RigPath path;
  double rate_hz = 20.0;  // frames per second (every lidar scans once per frame)
  int frames = 650;
};

// One scan of one lidar: beam angles and ranges (0 = no return), and for each
// beam what it truly hit (primitive, face; -1 for nothing).
struct RigScan {
  double time_s = 0.0;
  int frame = 0;
  int lidar = 0;
  std::vector<double> angles;
  std::vector<double> ranges;
  std::vector<int> primitive;
  std::vector<int> face;
  // Points in the scan plane (lidar x, y), scan order; NaN for no return.
  std::vector<Eigen::Vector2d> Points() const;
};

struct RigRun {
  std::vector<RigScan> scans;           // frame by frame, lidar by lidar
  std::vector<double> frame_times_s;
  std::vector<Rigid3d> world_from_rig;  // ground truth per frame
  std::vector<Rigid3d> rig_from_lidar;  // the extrinsics
};

RigRun SimulateRig(const RigSimConfig& config);

// A small furnished room: 5 x 4 x 2.6 m, its corner at the origin, a cabinet
// and a desk. Eight large planes (six room faces, two furniture fronts).
Scene SmallRoomScene();

// Scenarios of issue 12: a 650-frame walk round the small room (yaw turning
// through a full circle, roll and pitch swaying by up to 8 deg, height by
// 0.15 m) and a walk up and down the stairwell (StairwellScene), `frames`
// long, at 20 Hz.
RigSimConfig SmallRoomRigScenario(int frames = 650, uint64_t seed = 1);
RigSimConfig StairwellRigScenario(int frames = 1750, uint64_t seed = 1);

// The true plane of each box face: n . x + d = 0, unit n pointing to the
// face's back side (out of a room, into a solid box), as sfm::WorldPlane.
struct TruthPlane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double d = 0.0;
  int primitive = -1;
  int face = -1;
  std::string label;  // "<box label>/<face name>"
};
std::vector<TruthPlane> ScenePlanes(const Scene& scene);
TruthPlane ScenePlane(const Scene& scene, int primitive, int face);

// The wheeled scanner's vertical X4 as a one-lidar rig: each LidarScan of a
// SimWorld / session log becomes one RigScan at its middle time (angles are
// Eq. 1's theta; the lidar point (0, r sin theta, r cos theta) is mapped to
// the scan-plane point (r cos theta, r sin theta)). `lidar_from_scan_plane`
// is the fixed rotation that maps scan-plane coordinates (x, y, 0) back to
// the X4 frame; compose it into the rig extrinsics:
// rig_from_lidar = body_from_lidar * lidar_from_scan_plane.
std::vector<RigScan> RigScansFromLidarScans(const std::vector<LidarScan>& scans);
Rigid3d X4LidarFromScanPlane();

}  // namespace sweepscan::sim

#endif  // SWEEPSCAN_CORE_SIM_RIG_H_
