// Measurements of a reconstructed cloud against the simulated world's
// ground truth. Used by the tests and by `sweepscan-cli simulate --json`.
#ifndef SWEEPSCAN_CORE_SIM_TRUTH_EVAL_H_
#define SWEEPSCAN_CORE_SIM_TRUTH_EVAL_H_

#include <cstdint>
#include <string>
#include <vector>

#include "core/cloud/cloud.h"
#include "core/geometry/plane.h"
#include "core/sim/scene.h"

namespace sweepscan::sim {

struct SurfaceErrorStats {
  size_t count = 0;
  double mean = 0.0;
  double rms = 0.0;
  double p95 = 0.0;
  double max = 0.0;
};

// Distance of every point to the nearest true surface (p95 as
// SurfaceErrorAccumulator::Stats says).
SurfaceErrorStats SurfaceErrors(const Scene& scene, const std::vector<CloudPoint>& points);

// The room's size measured from the cloud: for each face of the room box,
// the points within `band_m` of the true face plane (and at least
// `margin_m` inside its edges, and farther than `band_m` from every other
// box, so that the feet of furniture standing on the floor do not count) get
// a least-squares plane; opposite planes give a dimension.
struct RoomMeasurement {
  bool ok = false;
  std::string error;
  Eigen::Vector3d true_size = Eigen::Vector3d::Zero();
  Eigen::Vector3d measured = Eigen::Vector3d::Zero();  // along the room's x, y, z
  Eigen::Vector3d relative_error = Eigen::Vector3d::Zero();  // (measured - true) / true
  Plane faces[6];
};
RoomMeasurement MeasureRoom(const Scene& scene, const std::string& room_label,
                            const std::vector<CloudPoint>& points, double band_m = 0.10,
                            double margin_m = 0.3);

// Points within `band_m` of the front face of a box (the face nearest the
// room's interior, i.e. facing -y for the lab's target), split into passes
// by gaps in time longer than `gap_s`; each pass gets a plane and the
// disagreement between the first two passes is reported.
struct PassDisagreement {
  bool ok = false;
  std::string error;
  size_t passes = 0;
  size_t points[2] = {0, 0};
  Eigen::Vector3d centroid[2];
  Plane planes[2];
  double plane_angle_rad = 0.0;        // between the two passes' board planes
  double plane_offset_m = 0.0;         // distance between them along the normal
  double centroid_distance_m = 0.0;    // between the two passes' board centroids
  double edge_shift_m = 0.0;           // shift of the board's top edge height between passes
};
PassDisagreement MeasureTargetPasses(const Scene& scene, const std::string& label,
                                     const std::vector<CloudPoint>& points, double band_m = 0.05,
                                     double gap_s = 1.0);

// The three measurements above over a cloud that arrives in pieces, in
// time order, and is not kept (sweepscan-cli simulate streams a 12-hour
// drive's 200 M points): each Add takes the next piece; the functions
// above are these over one piece. What is held does not grow with the
// cloud, but for the target's points (a board's, a few per scan line).
class SurfaceErrorAccumulator {
 public:
  explicit SurfaceErrorAccumulator(const Scene& scene) : scene_(scene) {}
  void Add(const CloudPoint* points, size_t n);
  // count, mean, rms and max exact; p95 the exact order statistic's
  // (the k-th smallest, k = floor(0.95 (N - 1))) to half a bin: a
  // histogram of 1 um bins below 1 m, 1 mm bins above to 1 km (and
  // farther in the last): 8 MB, 16 with a distance over 1 m.
  SurfaceErrorStats Stats() const;

 private:
  static constexpr size_t kFineBins = 1000000;    // 1 um each, to 1 m
  static constexpr size_t kCoarseBins = 1000000;  // 1 mm each, to 1 km
  const Scene& scene_;
  size_t count_ = 0;
  double sum_ = 0.0, sum2_ = 0.0, max_ = 0.0;
  std::vector<uint64_t> fine_, coarse_;  // allocated by the first point there
};

class RoomAccumulator {
 public:
  RoomAccumulator(const Scene& scene, const std::string& room_label, double band_m = 0.10,
                  double margin_m = 0.3);
  void Add(const CloudPoint* points, size_t n);
  RoomMeasurement Result() const;

 private:
  int room_ = -1;
  Box box_;
  Scene furniture_;  // every box but the room
  double band_m_, margin_m_;
  std::string error_;
  PlaneFit faces_[6];  // in the room box's frame
};

class TargetPassAccumulator {
 public:
  TargetPassAccumulator(const Scene& scene, const std::string& label, double band_m = 0.05,
                        double gap_s = 1.0);
  void Add(const CloudPoint* points, size_t n);
  PassDisagreement Result() const;

 private:
  int box_index_ = -1;
  Box box_;
  double band_m_, gap_s_;
  std::string error_;
  std::vector<CloudPoint> near_;  // within the band of the box
};

}  // namespace sweepscan::sim

#endif  // SWEEPSCAN_CORE_SIM_TRUTH_EVAL_H_
