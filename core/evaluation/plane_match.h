// Which plane of an earlier evaluation of the same room is which plane of
// a later one (before and after a calibration): the planes are listed by
// size, and a calibration that straightens a wall changes its inlier
// count, so row i of one evaluation need not be row i of the other.
#ifndef SWEEPSCAN_CORE_EVALUATION_PLANE_MATCH_H_
#define SWEEPSCAN_CORE_EVALUATION_PLANE_MATCH_H_

#include <vector>

#include "core/evaluation/evaluation.h"

namespace sweepscan {

struct PlaneMatchOptions {
  // A calibration turns a surface by milliradians to a few degrees and
  // moves it by centimetres; two walls of a room are further apart.
  double max_angle_deg = 10.0;
  double max_offset_m = 0.3;
};

// For each plane of `now`, the index of the plane of `before` that is the
// same surface, or -1. The same kind, normals within max_angle_deg (either
// sign), each centroid within max_offset_m of the other's plane; of several,
// the nearest (the sum of the two offsets). Each plane of `before` is given
// once, to the largest of `now`'s planes that claims it (now's planes in
// their order, which is by size).
std::vector<int> MatchPlanes(const CloudEvaluation& now, const CloudEvaluation& before,
                             const PlaneMatchOptions& options = {});

// For each dimension of `now`, the index of the dimension of `before`
// between the same two surfaces (by MatchPlanes' `match`), or -1.
std::vector<int> MatchDimensions(const CloudEvaluation& now, const CloudEvaluation& before,
                                 const std::vector<int>& match);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_EVALUATION_PLANE_MATCH_H_
