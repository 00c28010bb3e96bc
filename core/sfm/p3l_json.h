// The P3L problem file of `sweepscan-cli p3l` (docs/sfm.md):
//   {"planes": [{"normal": [nx, ny, nz], "d": d}, x3],
//    "lines": [[[x, y, z], [x, y, z]], x3]}
// three world planes n . x + d = 0 (unit n to the back side) and, for plane
// i, two (or more) points of its scan line in the sensor frame. Further
// plane/line pairs beyond the third rank the candidates; an optional
// "previous": {"R": 3x3, "t": [3]} ranks them by distance to a previous pose.
// The answer: {"solutions": [{"R": 3x3, "t": [3]}, ...]}, best first.
#ifndef SWEEPSCAN_CORE_SFM_P3L_JSON_H_
#define SWEEPSCAN_CORE_SFM_P3L_JSON_H_

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/sfm/p3l.h"

namespace sweepscan::sfm {

struct P3lProblem {
  std::array<WorldPlane, 3> planes;
  std::array<RigLine, 3> lines;
  Disambiguation disambiguation;
};

// Parses and checks a problem document; errors say where and why
// ("lines[1][0]: expected 3 numbers").
Status ParseP3lProblem(const nlohmann::json& doc, P3lProblem* problem);

nlohmann::json P3lSolutionsToJson(const std::vector<PoseCandidate>& candidates);

}  // namespace sweepscan::sfm

#endif  // SWEEPSCAN_CORE_SFM_P3L_JSON_H_
