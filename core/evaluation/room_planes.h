// Naming a cloud's level planes (floor, ceiling) from their sizes and
// heights; RoomDimensions (evaluation.h) is defined beside it. Internal to
// core/evaluation.
#ifndef SWEEPSCAN_CORE_EVALUATION_ROOM_PLANES_H_
#define SWEEPSCAN_CORE_EVALUATION_ROOM_PLANES_H_

#include <vector>

#include "core/evaluation/evaluation.h"

namespace sweepscan {

// Planes in size order, the level ones of kind "level", the cloud's mean
// height: sets each level plane's kind to "floor", "ceiling" or "other".
void NameLevelPlanes(double mean_z, std::vector<EvaluatedPlane>* planes);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_EVALUATION_ROOM_PLANES_H_
