// Room outlines of a floor plan (issue 29: "room outlines"), the last step
// of BuildFloorPlanFromSection (floor_plan.h), which calls FindRooms with the
// plan's own options; exposed for tests and for plans built by other means.
//
// A room is what a surveyor outlines: the free floor between the walls, the
// doors closed flush with the room's side of the wall, furniture inside it.
// The steps (the why and the thresholds are in rooms.cc):
//
// (1) Barriers on a square raster (cell c = FloorPlanOptions::room_cell_m):
//     every structural face extended at both ends (so that two faces that
//     stop short of their corner still meet), every wall's body (the band
//     between its two faces), every opening's jamb-to-jamb line; all grown
//     by one cell so that a line one cell wide cannot leak diagonally.
// (2) Regions: the 4-connected free cells; those touching the raster's edge
//     are outside the building, those under min_room_area_m2 are voids
//     (inside a wall, behind a cabinet) and a region is kept only when the
//     faces seen from inside it (their free side towards it) bound at least
//     half its perimeter: an unscanned room closed by other rooms' walls
//     is not a room of the plan.
// (3) Outline: the region's outer boundary traced on the raster's cell
//     edges (counter-clockwise, the region on the left). Every boundary
//     point within snap distance of the line of a face that bounds the
//     region takes that line; runs of one line shorter than a side are
//     absorbed by their neighbours; each corner is the intersection of two
//     consecutive lines (a jog between parallel lines gets both feet). So the
//     corners are the fitted faces' (millimetres), not the raster's (5 cm).
//     A stretch that no face bounds (an unseen gap) keeps its traced points,
//     simplified (Douglas-Peucker, 1.5 cells).
//
// Pure function; any thread; deterministic.
#ifndef SWEEPSCAN_CORE_PLAN_ROOMS_H_
#define SWEEPSCAN_CORE_PLAN_ROOMS_H_

#include <string>

#include "core/plan/floor_plan.h"

namespace sweepscan::plan {

// Fills plan->rooms from plan->faces, walls and openings (any earlier rooms
// replaced). options: room_cell_m, min_room_area_m2 (and IsValid()).
void FindRooms(const FloorPlanOptions& options, FloorPlan* plan);

// Why `plan` has no room, in words an operator can act on; "" when it has
// one. A straight drive sees the walls beside it but not the ones ahead and
// behind, which the vertical scan plane never crosses: its free floor runs
// out of the drawing and no room closes (step 2 above).
std::string NoRoomsReason(const FloorPlan& plan);

}  // namespace sweepscan::plan

#endif  // SWEEPSCAN_CORE_PLAN_ROOMS_H_
