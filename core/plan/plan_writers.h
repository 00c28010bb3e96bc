// Drawings of a FloorPlan (floor_plan.h) and of a vertical section, written
// by our own code: plain SVG 1.1 and ASCII DXF R12 (AC1009). The exact
// structure of both (groups and layers, units, what each entity means) is in
// docs/plan-formats.md.
//
//   SVG: paper millimetres at a chosen scale (1:50 draws 1 m as 20 mm), y
//        flipped so that +y (north) is up; groups (layers) rooms, points,
//        walls, openings, dimensions in that order (later ones drawn on top).
//   DXF: model space in metres ($INSUNITS 6), layers WALLS, OPENINGS,
//        DIMENSIONS, SECTION, ROOMS; LINE, POINT, TEXT and closed POLYLINE
//        (the room outlines) entities only.
//
// Files go through the checked writer (core/common/checked_file.h): each
// exists under its name only when complete.
//
// Pure functions; any thread.
#ifndef SWEEPSCAN_CORE_PLAN_PLAN_WRITERS_H_
#define SWEEPSCAN_CORE_PLAN_PLAN_WRITERS_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/plan/floor_plan.h"

namespace sweepscan::plan {

// Labels along a line read left to right, or bottom to top for a line
// within this many degrees of vertical (a wall a hair off plumb is vertical
// to the reader; ISO 129-1 reads vertical dimensions from the right).
inline constexpr double kUprightBandDeg = 5.0;

struct SvgOptions {
  double scale = 50.0;          // 1:scale (paper mm = model mm / scale)
  double margin_mm = 15.0;      // paper around the drawing
  double text_height_mm = 2.5;  // dimension and opening labels
  bool points = true;           // draw the (decimated) section points
  std::string title;            // a line of text under the drawing; empty: none
  bool IsValid(std::string* error) const;
};

// The plan as an SVG document (text). Refuses bad options or a plan whose
// coordinates are not finite.
Status PlanSvg(const FloorPlan& plan, const SvgOptions& options, std::string* svg);
Status WritePlanSvg(const std::string& path, const FloorPlan& plan, const SvgOptions& options);

// A vertical section's points (s along the line, z), drawn at the same
// scale with z up, a ground line at z = 0 and s, z ticks every metre (a
// coarser step over a long extent: axis_ticks.h).
Status SectionSvg(const std::vector<Eigen::Vector2d>& s_z, const SvgOptions& options, std::string* svg);
Status WriteSectionSvg(const std::string& path, const std::vector<Eigen::Vector2d>& s_z, const SvgOptions& options);

struct DxfOptions {
  bool section_points = true;  // POINT entities on layer SECTION
  double text_height_m = 0.12;  // model-space height of the TEXT labels
  bool IsValid(std::string* error) const;
};

// Layer names, in the LAYER table's order after "0".
inline constexpr const char* kDxfLayerWalls = "WALLS";
inline constexpr const char* kDxfLayerOpenings = "OPENINGS";
inline constexpr const char* kDxfLayerDimensions = "DIMENSIONS";
inline constexpr const char* kDxfLayerSection = "SECTION";
inline constexpr const char* kDxfLayerRooms = "ROOMS";
inline constexpr const char* kDxfLayerAxes = "AXES";  // a vertical section's ground line and scales

Status PlanDxf(const FloorPlan& plan, const DxfOptions& options, std::string* dxf);
Status WritePlanDxf(const std::string& path, const FloorPlan& plan, const DxfOptions& options);

// A vertical section's points (s along the line, z) as DXF R12 in metres
// (x = s, y = z): layers SECTION (a POINT per point) and AXES (the ground
// line z = 0, a tick and a label every metre along s and up z, or
// axis_ticks.h's coarser step).
Status SectionDxf(const std::vector<Eigen::Vector2d>& s_z, const DxfOptions& options, std::string* dxf);
Status WriteSectionDxf(const std::string& path, const std::vector<Eigen::Vector2d>& s_z, const DxfOptions& options);

// "5.000" : a length in metres as the drawings label it (millimetre digits).
std::string FormatMetres(double m);
// "Room 2": the name of plan.rooms[index] on the drawings (1-based, the
// rooms' reading order); "29.50 m2": its area (ASCII, as DXF R12 needs).
std::string RoomName(size_t index);
std::string FormatArea(double m2);

}  // namespace sweepscan::plan

#endif  // SWEEPSCAN_CORE_PLAN_PLAN_WRITERS_H_
