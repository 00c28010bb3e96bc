// The initialisation file of `sweepscan-cli sfm --init INIT.json`
// (docs/sfm.md): three planes and, for each, the lines of the first frame
// that lie on it:
//   {"planes": [{"normal": [nx, ny, nz], "d": d,
//                "lines": [{"lidar": 0, "line": 2}, {"lidar": 1, "near": [x, y]}]}, x3]}
// "normal" and "d" are given for all three planes (world = the planes'
// frame) or for none (world = the first rig frame; each plane then needs two
// non-parallel lines). A line is the extracted line index of that lidar's
// first scan, or the extracted line passing nearest a point of the scan plane.
#ifndef SWEEPSCAN_CORE_SFM_SEQUENCE_JSON_H_
#define SWEEPSCAN_CORE_SFM_SEQUENCE_JSON_H_

#include <nlohmann/json.hpp>

#include "core/common/status.h"
#include "core/sfm/sequence.h"

namespace sweepscan::sfm {

Status ParseSequenceInit(const nlohmann::json& doc, SequenceInit* init);
nlohmann::json SequenceInitToJson(const SequenceInit& init);

}  // namespace sweepscan::sfm

#endif  // SWEEPSCAN_CORE_SFM_SEQUENCE_JSON_H_
