// The room read from a cloud's planes: which level plane is the floor and
// which the ceiling, and the distances between parallel planes (the paper's
// Table 3). Split from evaluation.cc, which finds the planes.
#include "core/evaluation/room_planes.h"

#include <cmath>

#include "core/geometry/plane.h"

namespace sweepscan {

namespace {
constexpr double kRadToDeg = 180.0 / M_PI;
}  // namespace

void NameLevelPlanes(double mean_z, std::vector<EvaluatedPlane>* planes) {
  // Level planes come in size order: the largest at or below the cloud's
  // mean height is the floor (the largest of all if none is), the largest
  // above it and at least kMinRoomHeightM above the floor the ceiling (by
  // size, not by extreme height: an uncalibrated cloud holds tilted ghost
  // copies of both). A cloud of a floor alone once had it called the
  // ceiling (its centroid is the mean), and a table 0.7 m over a floor was
  // the ceiling of a room 0.7 m high.
  constexpr double kMinRoomHeightM = 1.8;
  EvaluatedPlane* floor = nullptr;
  for (EvaluatedPlane& ep : *planes) {
    if (ep.kind == "level" && ep.plane.centroid.z() <= mean_z) {
      ep.kind = "floor";
      floor = &ep;
      break;
    }
  }
  // No level plane at or below the mean (a floor with a pit in it): the
  // largest level plane is the floor; a ceiling alone is not scanned.
  for (EvaluatedPlane& ep : *planes) {
    if (floor != nullptr) break;
    if (ep.kind == "level") {
      ep.kind = "floor";
      floor = &ep;
    }
  }
  bool have_ceiling = false;
  for (EvaluatedPlane& ep : *planes) {
    if (ep.kind != "level") continue;
    const double z = ep.plane.centroid.z();
    const bool high =
        z > mean_z && (floor == nullptr || z - floor->plane.centroid.z() >= kMinRoomHeightM);
    ep.kind = high && !have_ceiling ? "ceiling" : "other";
    have_ceiling = have_ceiling || ep.kind == "ceiling";
  }
}

std::vector<RoomDimension> RoomDimensions(const std::vector<EvaluatedPlane>& planes,
                                          double parallel_angle_deg, double min_dimension_m) {
  std::vector<RoomDimension> out;
  for (size_t a = 0; a < planes.size(); ++a) {
    for (size_t b = a + 1; b < planes.size(); ++b) {
      const Plane& pa = planes[a].plane;
      const Plane& pb = planes[b].plane;
      const double angle = AngleBetweenPlanes(pa, pb) * kRadToDeg;
      if (angle > parallel_angle_deg) continue;
      // Level: the room's height, between its floor and its ceiling only
      // (a table's top is parallel to the floor too, 0.7 m over it).
      const bool level = std::abs(pa.normal.z()) > 0.7;
      if (level && !((planes[a].kind == "floor" && planes[b].kind == "ceiling") ||
                     (planes[a].kind == "ceiling" && planes[b].kind == "floor"))) {
        continue;
      }
      const double dist = DistanceBetweenPlanes(pa, pb);
      if (dist < min_dimension_m) continue;
      out.push_back({static_cast<int>(a), static_cast<int>(b), level ? "vertical" : "horizontal",
                     dist, angle});
    }
  }
  return out;
}

}  // namespace sweepscan
