// A floor plan from a 3D cloud (issue 29): the horizontal section at a
// surveyor's cut height, the wall faces fitted to it as 2D segments, the
// openings (doors) where a face has a gap that is not a shadow, walls as pairs
// of close parallel faces back to back, and room dimensions as distances
// between parallel faces that face each other across free space.
//
//   FloorPlanOptions o;            // o.section.height_m = 1.0, band 0.05 m
//   FloorPlan plan;
//   Status s = BuildFloorPlan(cloud_xyz, o, &plan);
//   // plan.faces, plan.openings, plan.walls, plan.dimensions (metres, plan x y)
//
// The steps, what each assumes and the math are in floor_plan.cc and
// line_fit.h. In short, the plan assumes: z is up and the floor near z = 0;
// walls are vertical planes (so a straight line in the section); a face is
// seen over a length of at least min_face_length_m; the space in front of a
// face (towards the scanner) is free, behind it is solid or unseen.
//
// Pure functions; any thread. Deterministic (seeded RANSAC): the same cloud
// and options give the same plan.
#ifndef SWEEPSCAN_CORE_PLAN_FLOOR_PLAN_H_
#define SWEEPSCAN_CORE_PLAN_FLOOR_PLAN_H_

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/plan/section.h"

namespace sweepscan::plan {

struct FloorPlanOptions {
  HorizontalSectionOptions section;
  // Line detection (line_fit.h): a point belongs to a line within this
  // distance in the RANSAC; the refit keeps points within 3 sigma of the
  // least-squares line, at most this.
  double line_tolerance_m = 0.02;
  double min_face_length_m = 0.3;   // shorter runs (jambs, table legs) are not faces
  int min_face_points = 15;
  // A gap of at least this along a face (that is not a shadow) is an opening.
  double opening_width_m = 0.6;
  double max_opening_width_m = 3.0;  // wider gaps end the face without an opening
  // Two faces back to back this far apart are one wall.
  double min_wall_thickness_m = 0.05;
  double max_wall_thickness_m = 0.4;
  double parallel_tolerance_rad = 0.035;  // 2 deg
  double drawing_cell_m = 0.02;           // FloorPlan::points: one point per cell
  // Rooms (rooms.h): the raster's cell, and the least floor area of a room
  // (smaller closed regions are voids: inside a wall, behind a cabinet).
  double room_cell_m = 0.05;
  double min_room_area_m2 = 1.0;
  uint64_t seed = 1;                      // the RANSAC's std::mt19937_64
  bool IsValid(std::string* error) const;
};

// A wall face: one straight run of section points. a -> b runs along the
// fitted line; `normal` is the unit normal towards the free side (where the
// scanner stood), when known.
struct WallFace {
  Eigen::Vector2d a = Eigen::Vector2d::Zero(), b = Eigen::Vector2d::Zero();
  Eigen::Vector2d normal = Eigen::Vector2d::Zero();
  bool normal_known = false;
  // A wall's face (one of a wall pair, the outer shell, or a long face with
  // nothing close in front of another): false for furniture and lone lines.
  // Dimensions are taken between structural faces only.
  bool structural = false;
  int line = -1;          // faces on one fitted line (collinear) share it
  size_t points = 0;      // section points on the run
  double rms_m = 0.0;     // of their distances to the line
  double Length() const { return (b - a).norm(); }
};

// A gap in a face (or, for a wall, in both faces at once) that is not a
// shadow of something in front of it: a door, a passage. a, b are the jambs.
struct Opening {
  Eigen::Vector2d a = Eigen::Vector2d::Zero(), b = Eigen::Vector2d::Zero();
  double width_m = 0.0;
  int face = -1;  // the face on whose line it lies (the first, for a wall)
  int wall = -1;  // the wall whose both faces have it, or -1
};

// Two faces back to back: the wall between them.
struct Wall {
  Eigen::Vector2d a = Eigen::Vector2d::Zero(), b = Eigen::Vector2d::Zero();  // centre line, over the faces' overlap
  double thickness_m = 0.0;
  int face_a = -1, face_b = -1;
};

// An inner dimension: two parallel faces that face each other with free
// space between them. a on face_a, b on face_b (the dimension line).
struct Dimension {
  Eigen::Vector2d a = Eigen::Vector2d::Zero(), b = Eigen::Vector2d::Zero();
  double distance_m = 0.0;
  int face_a = -1, face_b = -1;
};

// A room: a connected region of free space closed by structural faces and,
// across its openings, by its faces' lines (the door closed flush with the
// room's wall). The outline runs on the fitted face lines, corner to corner
// (rooms.h says how it is found and traced).
struct Room {
  std::vector<Eigen::Vector2d> outline;  // closed polygon, counter-clockwise, last != first
  double area_m2 = 0.0;                  // of the outline (furniture inside included)
  double perimeter_m = 0.0;
  Eigen::Vector2d label = Eigen::Vector2d::Zero();  // a point well inside: where to write the name
  std::vector<int> faces;                // structural faces bounding it (indices into faces)
  std::vector<int> openings;             // openings on its outline (indices into openings)
};

struct FloorPlan {
  double height_m = 0.0, band_m = 0.0;
  SectionStats section;                 // the cut
  std::vector<Eigen::Vector2d> points;  // the section decimated (drawing)
  // The drawing's extent: of the section's points with at least two others
  // in their 0.5 m cell and the eight around it (all of them if none has);
  // the others, `stray_points`, lie anywhere (a glitch 200 km out would make
  // a page kilometres wide).
  Eigen::Vector2d min = Eigen::Vector2d::Zero(), max = Eigen::Vector2d::Zero();
  size_t stray_points = 0;
  std::vector<WallFace> faces;
  std::vector<Opening> openings;
  std::vector<Wall> walls;
  std::vector<Dimension> dimensions;
  // Ordered as a plan is read: by the outline's lowest y in 1 m bands (south
  // to north), then by its lowest x (west to east).
  std::vector<Room> rooms;
};

// The whole plan from a cloud. Refuses an empty cloud, bad options, or a
// section with fewer than min_face_points points (the cut missed the cloud).
Status BuildFloorPlan(const std::vector<Eigen::Vector3f>& cloud, const FloorPlanOptions& options, FloorPlan* plan);

// The same from a section's points (x, y) already cut.
Status BuildFloorPlanFromSection(const std::vector<Eigen::Vector2d>& section, const FloorPlanOptions& options,
                                 FloorPlan* plan);

}  // namespace sweepscan::plan

#endif  // SWEEPSCAN_CORE_PLAN_FLOOR_PLAN_H_
