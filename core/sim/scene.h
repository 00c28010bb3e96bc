// Scenes of boxes for the simulated world, with exact ray casting.
//
// Every primitive is a box that may be turned about the vertical axis (yaw)
// and about its own y axis (pitch: a board facing y becomes a diamond). A
// box is either solid (seen from outside: furniture, stairs, a target board)
// or a room (seen from inside: its six faces are floor, ceiling and walls).
// Boxes may overlap; a ray returns the nearest surface it meets. Each hit
// reports which primitive and which face it struck, so ground truth can say
// what every simulated point belongs to.
#ifndef SWEEPSCAN_CORE_SIM_SCENE_H_
#define SWEEPSCAN_CORE_SIM_SCENE_H_

#include <Eigen/Core>
#include <string>
#include <vector>

namespace sweepscan::sim {

// Faces of a box in its own frame: 0 -x, 1 +x, 2 -y, 3 +y, 4 -z (floor or
// bottom), 5 +z (ceiling or top).
const char* FaceName(int face);

struct Box {
  std::string label;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d size = Eigen::Vector3d::Ones();  // full extents along the box axes (m)
  double yaw = 0.0;        // rotation about the world z axis (rad)
  bool inside = false;     // true for a room seen from inside
  double dropout = 0.0;    // extra probability that a return from it is lost (dark, glossy)
  // Rotation about the box's own y axis, applied before yaw:
  // world_from_box = Rz(yaw) Ry(pitch). A board thin along y with
  // pitch = pi/4 is a square standing on a corner (a diamond).
  double pitch = 0.0;
};

struct RayHit {
  double range = 0.0;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // unit, facing the ray origin
  int primitive = -1;
  int face = -1;
};

class Scene {
 public:
  Scene() = default;
  explicit Scene(std::vector<Box> boxes) : boxes_(std::move(boxes)) {}

  void Add(const Box& box) { boxes_.push_back(box); }
  const std::vector<Box>& boxes() const { return boxes_; }
  // Index of the first box with this label, or -1.
  int Find(const std::string& label) const;

  // Nearest hit along origin + t * direction (direction unit) with
  // t in (min_range, max_range]; false if nothing is hit.
  bool Cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double min_range,
            double max_range, RayHit* hit) const;

  // Unsigned distance from p to the nearest surface of any box.
  double DistanceToSurface(const Eigen::Vector3d& p) const;

  // Checks sizes are positive and finite; `error` names the box.
  bool IsValid(std::string* error) const;

 private:
  std::vector<Box> boxes_;
};

// The seed paper's lab (Miao et al. 2022, section 5): a 10 x 5 x 2.5 m room
// with its corner at the origin, desks and cabinets, and a 0.6 x 0.6 m
// calibration target board standing on the window sill of the y = 0 wall,
// its front face 0.16 m from the wall, centred at x = 5 m, 1.2 m high.
//
// kDiamond mounts a thin (5 mm) 0.6 m board turned 45 deg in its plane,
// front face still 0.16 m from the wall, centred 1.35 m high (corners at
// 0.93 and 1.77 m, clear of the 0.85 m sill). Why:
// the vertical scan plane crosses a vertical board in vertical lines, so an
// upright board's side edges run parallel to the scan lines and are located
// only to the scan spacing (~5 cm); every edge of a diamond crosses the scan
// lines at 45 deg, so all four corners can be fitted to millimetres. Thin,
// because a beam passing just below a board's bottom edge hits its edge
// face: the board fit removes that given the thickness, and with less of
// it there is less to remove (docs/calibration.md, "The target").
enum class LabTarget { kSquare, kDiamond };
Scene LabScene(LabTarget target = LabTarget::kSquare);
// The target board's thickness: 20 mm upright, 5 mm for the diamond
// (CalibrationOptions::board_thickness_m of a refined calibration).
double LabTargetThickness(LabTarget target);
// A stairwell: a 9 x 3 x 6 m shaft with a flat run-up, a straight flight of
// 14 steps (0.28 m deep, 0.17 m high) along +x and a landing.
Scene StairwellScene();
// An office floor for projects of several sessions (issue 29): a 16 x 8 x
// 2.7 m storey with its corner at the origin, a 2 m corridor along y = 0 and
// three rooms north of it (A: x 0-5, B: 5.1-10.6, C: 10.7-16, all y 2.1-8),
// separated by 0.1 m solid walls (the corridor wall at y 2.0-2.1, A|B at x
// 5.0-5.1, B|C at x 10.6-10.7). Doors are 0.9 m gaps, 2.05 m high with a
// lintel above: from the corridor into A (x 2.0-2.9), B (7.0-7.9) and C
// (12.5-13.4), and between A and B (y 6.0-6.9). Desks, cabinets and shelves
// make each room different, so that no room matches another turned by a
// multiple of 90 deg; the corridor is bare (only its doors break it along x).
// OfficeFloorTruth() lists what a floor plan should find.
Scene OfficeFloorScene();

// The floor plan's truth of OfficeFloorScene: the rooms' inner faces (so
// their inner dimensions) and the doors.
struct RoomTruth {
  std::string label;
  double x0, x1, y0, y1;  // inner faces (m)
};
std::vector<RoomTruth> OfficeFloorRooms();
struct DoorTruth {
  std::string label;
  Eigen::Vector2d a, b;  // the opening's two jambs at the wall's centre line
};
std::vector<DoorTruth> OfficeFloorDoors();

}  // namespace sweepscan::sim

#endif  // SWEEPSCAN_CORE_SIM_SCENE_H_
