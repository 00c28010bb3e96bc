// Evaluation of a cloud (Miao et al. 2022, section 5): statistical outlier
// removal, RANSAC planes of the floor, ceiling and walls with their normals
// and RMS, the signed point-to-plane deviation histogram (its Fig. 9), the
// average nearest-neighbour distance as density (its Eq. 18-19) and the
// distances between parallel planes as room dimensions (its Table 3).
//
// One neighbour structure (core/evaluation/neighbours.h) is built per
// evaluation and shared: the k neighbours that outlier removal asks for also
// give each point its nearest neighbour, so the density needs new queries
// only for points whose nearest neighbour was removed as an outlier. The
// outlier statistics are PCL's StatisticalOutlierRemoval's, to the point.
// Neighbour queries, RANSAC scoring and the passes over all points run on
// oneTBB's threads in blocks of a fixed size whose results are combined in
// block order: the result does not depend on the thread count, bit for bit.
// RANSAC scores its hypotheses on an even subsample held as a structure of
// arrays (vectorised loops) and draws the sample sequence of PCL's
// SACSegmentation (boost::mt19937 seeded 12345 per plane, partial shuffles),
// so its planes are those of the PCL version this replaced; each plane's
// band of inliers and its least-squares refit take one pass over the
// remaining points.
//
// Pure functions, callable from any thread; progress and cancel through
// EvaluationControl. docs/performance.md ("Evaluation") has the figures.
#ifndef SWEEPSCAN_CORE_EVALUATION_EVALUATION_H_
#define SWEEPSCAN_CORE_EVALUATION_EVALUATION_H_

#include <Eigen/Core>
#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/evaluation/neighbours.h"
#include "core/geometry/plane.h"

namespace sweepscan {

struct EvaluationOptions {
  // Statistical outlier removal (PCL): a point is dropped when its mean
  // distance to its k nearest neighbours exceeds mean + stddev_mult * sd of
  // that quantity over the cloud. k = 0 disables it.
  int outlier_k = 20;
  double outlier_stddev_mult = 2.0;
  // Plane extraction: iterative RANSAC (PCL SACSegmentation, plane model),
  // the largest plane first, its inliers removed, until max_planes or a
  // plane holds fewer than min_plane_fraction of the points.
  double plane_distance_m = 0.03;
  int max_planes = 10;
  double min_plane_fraction = 0.01;
  int ransac_iterations = 500;
  // RANSAC runs on an even subsample of at most this many of the remaining
  // points (0 = all); the plane's inliers and its least-squares refit then
  // use every remaining point. 50 000 points locate a plane holding 1 % of
  // them from 500 points, far more than a plane needs, and cut the
  // 1 M-point extraction from 22.8 s to about a second (docs/performance.md).
  size_t ransac_max_points = 50000;
  // A plane within this angle of horizontal is floor or ceiling, within this
  // angle of vertical a wall; anything else is "other".
  double classify_angle_deg = 10.0;
  // Deviation histogram: bins of bin_m over [-half_range_m, half_range_m]
  // (values outside go to the first / last bin).
  double histogram_bin_m = 0.002;
  double histogram_half_range_m = 0.04;
  // Room dimensions: planes closer than this to parallel give a dimension.
  double parallel_angle_deg = 2.0;
  double min_dimension_m = 0.5;
  // Density: at most this many query points (evenly spaced), 0 = all.
  size_t density_max_queries = 0;
  // RANSAC's generator starts at 12345 + seed - 1 for every plane (seed 1:
  // PCL's own sequence).
  uint64_t seed = 1;
  // Worker threads (0 = every hardware thread; never more than those). The
  // result does not depend on it.
  int threads = 0;
  // The shared neighbour structure (docs/performance.md compares them).
  NeighbourBackend neighbours = NeighbourBackend::kBatched;

  bool IsValid(std::string* error) const;
};

// Stages in order; kDone is reported once, with fraction 1, at the end of a
// successful evaluation.
enum class EvaluationStage { kNeighbours, kOutliers, kDensity, kPlanes, kDone };
const char* EvaluationStageName(EvaluationStage stage);

struct EvaluationProgress {
  EvaluationStage stage = EvaluationStage::kNeighbours;
  double stage_fraction = 0.0;  // 0..1 within the stage
  double fraction = 0.0;        // 0..1 of the whole; never decreases
};

// Progress and cancel. `progress` is called one call at a time but from the
// evaluation's worker threads (not necessarily the caller's), at most about
// 50 times a second; returning false cancels. `cancel` may be set from any
// thread. A cancelled evaluation returns within 100 ms with a Status whose
// message is kEvaluationCancelled.
struct EvaluationControl {
  std::function<bool(const EvaluationProgress&)> progress;
  const std::atomic<bool>* cancel = nullptr;
};
extern const char* const kEvaluationCancelled;

// Wall-clock seconds per stage of the last EvaluateCloud.
struct EvaluationTiming {
  double neighbours_s = 0.0;  // spatial sort, kd-tree build, k-neighbour queries
  double outliers_s = 0.0;    // statistics, the clean cloud
  double density_s = 0.0;     // Eq. 18-19 from the shared neighbours
  double planes_s = 0.0;      // RANSAC, bands, refits, histograms, dimensions
  double total_s = 0.0;
  int threads = 0;
};

struct DeviationHistogram {
  double bin_m = 0.0;
  double min_m = 0.0;  // left edge of bin 0
  std::vector<uint64_t> counts;
  // Deviations beyond the bins' range, below bin 0's left edge and at or
  // above the last bin's right edge; they are counted in the first and last
  // bins too (so that the counts sum to `count`), and are told apart here.
  uint64_t below = 0, above = 0;
  double mean_m = 0.0, stddev_m = 0.0;
  size_t count = 0;
  double BinCentre(size_t i) const { return min_m + (static_cast<double>(i) + 0.5) * bin_m; }
};

struct EvaluatedPlane {
  std::string kind;  // "floor", "ceiling", "wall", "other"
  Plane plane;       // least-squares on the inliers: normal, d, centroid, rms, count
  // Angle of the normal from vertical (floor, ceiling) or from horizontal
  // (walls), degrees: how far the surface is from level / plumb.
  double tilt_deg = 0.0;
  DeviationHistogram deviations;  // signed n . p + d of its inliers (Fig. 9)
  // The inliers' extent in the plane, for drawing it: a rectangle on two
  // in-plane axes (horizontal and up for walls, x-aligned for level planes)
  // spanning the 0.5th to 99.5th percentile of the inliers along each axis
  // (a few stray inliers far away do not stretch it). Corners in order.
  std::array<Eigen::Vector3d, 4> outline;
};

struct RoomDimension {
  int plane_a = -1, plane_b = -1;  // indices into CloudEvaluation::planes
  std::string axis;                // "vertical" or "horizontal"
  double distance_m = 0.0;         // DistanceBetweenPlanes (core/geometry/plane.h)
  double angle_deg = 0.0;          // between the two normals
};

struct CloudEvaluation {
  size_t points_in = 0;
  size_t points_after_outliers = 0;
  std::vector<EvaluatedPlane> planes;
  std::vector<RoomDimension> dimensions;
  double mean_nn_distance_m = 0.0;  // Eq. 18-19
  size_t density_queries = 0;
  EvaluationTiming timing;
};

// PCL StatisticalOutlierRemoval's statistics (mean distance to the k
// nearest neighbours, dropped above mean + stddev_mult * sd); `kept` gets
// the indices of the survivors, ascending.
Status RemoveStatisticalOutliers(const std::vector<Eigen::Vector3f>& points, int k,
                                 double stddev_mult, std::vector<size_t>* kept);

// Iterative RANSAC plane extraction (PCL SACSegmentation's RANSAC with its
// adaptive stop at 99 % confidence) with a least-squares refit on each
// plane's inliers. `members[i]` gets the indices of plane i's inliers.
Status ExtractPlanes(const std::vector<Eigen::Vector3f>& points, const EvaluationOptions& options,
                     std::vector<EvaluatedPlane>* planes,
                     std::vector<std::vector<size_t>>* members);

// Signed deviations n . p + d binned as in EvaluationOptions.
DeviationHistogram MakeDeviationHistogram(const std::vector<Eigen::Vector3f>& points,
                                          const std::vector<size_t>& indices, const Plane& plane,
                                          double bin_m, double half_range_m);

// Eq. 18-19: rho = (1/N) sum_i min_{j != i} |p_i - p_j|, the nearest
// neighbour found with the neighbour index. With max_queries > 0
// the mean runs over that many evenly spaced points (the tree always holds
// all of them).
Status MeanNearestNeighbourDistance(const std::vector<Eigen::Vector3f>& points, size_t max_queries,
                                    double* mean_m, size_t* queries);

// Pairs of (nearly) parallel planes, facing each other across at least
// min_dimension_m: the room's height (floor-ceiling) and widths (walls).
// Level planes only as the floor and the ceiling (their kinds set): a
// table's top is parallel to the floor too. Walls: every parallel pair (a
// cabinet's front and the wall behind it included: which faces face each
// other cannot be told from one global point, and a cloud of several rooms
// has walls on both sides of any such point).
std::vector<RoomDimension> RoomDimensions(const std::vector<EvaluatedPlane>& planes,
                                          double parallel_angle_deg, double min_dimension_m);

// Everything above: outliers, density (on the points after outlier
// removal, from the same neighbour structure), planes, histograms,
// dimensions.
// The deviation map: every point's signed distance n . p + d to the plane
// it lies on, in millimetres, for colouring a cloud by flatness. A point
// lies on the nearest of `planes` if within `band_m` of it and inside its
// outline grown by `band_m`; other points get NaN. Runs over the points in
// parallel blocks; the result does not depend on the thread count.
std::vector<float> DeviationMapMm(const std::vector<Eigen::Vector3f>& points,
                                  const std::vector<EvaluatedPlane>& planes, double band_m);

Status EvaluateCloud(const std::vector<Eigen::Vector3f>& points, const EvaluationOptions& options,
                     CloudEvaluation* result);
Status EvaluateCloud(const std::vector<Eigen::Vector3f>& points, const EvaluationOptions& options,
                     CloudEvaluation* result, const EvaluationControl& control);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_EVALUATION_EVALUATION_H_
