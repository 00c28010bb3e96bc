// All PCL templates of the evaluation live in this translation unit.
#include "core/evaluation/evaluation.h"

#include <pcl/ModelCoefficients.h>
#include <pcl/PointIndices.h>
#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <algorithm>
#include <cmath>

namespace sweepscan {
namespace {

pcl::PointCloud<pcl::PointXYZ>::Ptr ToPcl(const std::vector<Eigen::Vector3f>& points,
                                          const std::vector<size_t>* indices = nullptr) {
  auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  const size_t n = indices != nullptr ? indices->size() : points.size();
  cloud->resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = points[indices != nullptr ? (*indices)[i] : i];
    (*cloud)[i] = pcl::PointXYZ(p.x(), p.y(), p.z());
  }
  cloud->width = static_cast<uint32_t>(n);
  cloud->height = 1;
  cloud->is_dense = true;
  return cloud;
}

constexpr double kRadToDeg = 180.0 / M_PI;

}  // namespace

bool EvaluationOptions::IsValid(std::string* error) const {
  if (outlier_k < 0 || !(outlier_stddev_mult > 0.0)) {
    *error = "evaluation: outlier_k must be >= 0 and outlier_stddev_mult > 0";
    return false;
  }
  if (!(plane_distance_m > 0.0) || max_planes < 1 || !(min_plane_fraction > 0.0) ||
      !(min_plane_fraction < 1.0) || ransac_iterations < 1) {
    *error = "evaluation: plane extraction parameters out of range";
    return false;
  }
  if (!(histogram_bin_m > 0.0) || !(histogram_half_range_m >= histogram_bin_m) ||
      !std::isfinite(histogram_half_range_m) || histogram_half_range_m / histogram_bin_m > 1e6) {
    *error = "evaluation: need 0 < histogram_bin_m <= histogram_half_range_m (at most 1e6 bins)";
    return false;
  }
  if (!(classify_angle_deg > 0.0 && classify_angle_deg < 45.0) ||
      !(parallel_angle_deg > 0.0 && parallel_angle_deg < 45.0) || !(min_dimension_m >= 0.0)) {
    *error = "evaluation: angles must be in (0, 45) deg and min_dimension_m >= 0";
    return false;
  }
  return true;
}

Status RemoveStatisticalOutliers(const std::vector<Eigen::Vector3f>& points, int k,
                                 double stddev_mult, std::vector<size_t>* kept) {
  kept->clear();
  for (const auto& p : points) {
    if (!p.allFinite()) return Status::Error("outlier removal: the cloud has non-finite points");
  }
  if (k <= 0 || points.size() <= static_cast<size_t>(k)) {
    for (size_t i = 0; i < points.size(); ++i) kept->push_back(i);
    return Status::Ok();
  }
  pcl::StatisticalOutlierRemoval<pcl::PointXYZ> sor;
  sor.setInputCloud(ToPcl(points));
  sor.setMeanK(k);
  sor.setStddevMulThresh(stddev_mult);
  pcl::Indices indices;
  sor.filter(indices);
  kept->assign(indices.begin(), indices.end());
  return Status::Ok();
}

DeviationHistogram MakeDeviationHistogram(const std::vector<Eigen::Vector3f>& points,
                                          const std::vector<size_t>& indices, const Plane& plane,
                                          double bin_m, double half_range_m) {
  DeviationHistogram h;
  h.bin_m = bin_m;
  const size_t bins =
      std::max<size_t>(1, static_cast<size_t>(std::ceil(2.0 * half_range_m / bin_m)));
  h.min_m = -0.5 * bins * bin_m;
  h.counts.assign(bins, 0);
  double sum = 0.0, sum2 = 0.0;
  for (size_t i : indices) {
    const double r = plane.SignedDistance(points[i].cast<double>());
    sum += r;
    sum2 += r * r;
    const double f = std::floor((r - h.min_m) / bin_m);
    const size_t b = f < 0 ? 0 : std::min(bins - 1, static_cast<size_t>(f));
    ++h.counts[b];
  }
  h.count = indices.size();
  if (h.count > 0) {
    h.mean_m = sum / h.count;
    h.stddev_m = std::sqrt(std::max(0.0, sum2 / h.count - h.mean_m * h.mean_m));
  }
  return h;
}

Status ExtractPlanes(const std::vector<Eigen::Vector3f>& points, const EvaluationOptions& options,
                     std::vector<EvaluatedPlane>* planes,
                     std::vector<std::vector<size_t>>* members) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  planes->clear();
  members->clear();
  if (points.size() < 3) {
    return Status::Error("plane extraction: " + std::to_string(points.size()) + " points");
  }
  std::vector<size_t> remaining(points.size());
  for (size_t i = 0; i < points.size(); ++i) remaining[i] = i;
  const size_t min_count =
      std::max<size_t>(3, static_cast<size_t>(options.min_plane_fraction * points.size()));
  pcl::SACSegmentation<pcl::PointXYZ> seg;
  seg.setOptimizeCoefficients(false);  // our least-squares refit below
  seg.setModelType(pcl::SACMODEL_PLANE);
  seg.setMethodType(pcl::SAC_RANSAC);
  seg.setDistanceThreshold(options.plane_distance_m);
  seg.setMaxIterations(options.ransac_iterations);
  const double cos_level = std::cos(options.classify_angle_deg / kRadToDeg);
  const double sin_plumb = std::sin(options.classify_angle_deg / kRadToDeg);
  while (static_cast<int>(planes->size()) < options.max_planes && remaining.size() >= min_count) {
    // Seeded per plane so that the result is reproducible.
    srand(static_cast<unsigned>(options.seed + planes->size()));
    std::vector<size_t> sample;
    const std::vector<size_t>* ransac_input = &remaining;
    if (options.ransac_max_points > 0 && remaining.size() > options.ransac_max_points) {
      const double step =
          static_cast<double>(remaining.size()) / static_cast<double>(options.ransac_max_points);
      sample.reserve(options.ransac_max_points);
      for (size_t k = 0; k < options.ransac_max_points; ++k) {
        sample.push_back(remaining[static_cast<size_t>(k * step)]);
      }
      ransac_input = &sample;
    }
    seg.setInputCloud(ToPcl(points, ransac_input));
    pcl::PointIndices inliers;
    pcl::ModelCoefficients coefficients;
    seg.segment(inliers, coefficients);
    // The subsample holds the plane in proportion.
    const double scale =
        static_cast<double>(ransac_input->size()) / static_cast<double>(remaining.size());
    if (static_cast<double>(inliers.indices.size()) < scale * static_cast<double>(min_count) ||
        coefficients.values.size() != 4) {
      break;
    }
    std::vector<Eigen::Vector3d> in;
    in.reserve(inliers.indices.size());
    for (int i : inliers.indices) in.push_back(points[(*ransac_input)[i]].cast<double>());
    EvaluatedPlane ep;
    if (!FitPlane(in, &ep.plane)) break;
    // Final inliers: within the band of the least-squares plane.
    std::vector<size_t> mine, rest;
    for (size_t i : remaining) {
      (std::abs(ep.plane.SignedDistance(points[i].cast<double>())) < options.plane_distance_m
           ? mine
           : rest)
          .push_back(i);
    }
    if (mine.size() < min_count) break;
    in.clear();
    for (size_t i : mine) in.push_back(points[i].cast<double>());
    if (!FitPlane(in, &ep.plane)) break;
    const double nz = std::abs(ep.plane.normal.z());
    if (nz >= cos_level) {
      // Orient the normal up; the floor has the room above it.
      if (ep.plane.normal.z() < 0) ep.plane.normal = -ep.plane.normal, ep.plane.d = -ep.plane.d;
      ep.tilt_deg = std::acos(std::min(1.0, nz)) * kRadToDeg;
      ep.kind = "level";  // floor or ceiling, decided below
    } else if (nz <= sin_plumb) {
      ep.kind = "wall";
      ep.tilt_deg = std::asin(std::min(1.0, nz)) * kRadToDeg;
    } else {
      ep.kind = "other";
      ep.tilt_deg = std::asin(std::min(1.0, nz)) * kRadToDeg;
    }
    ep.deviations = MakeDeviationHistogram(points, mine, ep.plane, options.histogram_bin_m,
                                           options.histogram_half_range_m);
    planes->push_back(ep);
    members->push_back(std::move(mine));
    remaining.swap(rest);
  }
  // Level planes come in size order: the largest below the cloud's mean
  // height is the floor, the largest above it the ceiling (by size, not by
  // extreme height: an uncalibrated cloud holds tilted ghost copies of both).
  double mean_z = 0.0;
  for (const auto& p : points) mean_z += p.z();
  mean_z /= static_cast<double>(points.size());
  bool have_floor = false, have_ceiling = false;
  for (EvaluatedPlane& ep : *planes) {
    if (ep.kind != "level") continue;
    const bool below = ep.plane.centroid.z() < mean_z;
    if (below && !have_floor) {
      ep.kind = "floor";
      have_floor = true;
    } else if (!below && !have_ceiling) {
      ep.kind = "ceiling";
      have_ceiling = true;
    } else {
      ep.kind = "other";
    }
  }
  return Status::Ok();
}

Status MeanNearestNeighbourDistance(const std::vector<Eigen::Vector3f>& points, size_t max_queries,
                                    double* mean_m, size_t* queries) {
  if (points.size() < 2) {
    return Status::Error("density: need at least 2 points, got " + std::to_string(points.size()));
  }
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  const auto cloud = ToPcl(points);
  tree.setInputCloud(cloud);
  const size_t n = points.size();
  const size_t stride = max_queries > 0 ? std::max<size_t>(1, n / max_queries) : 1;
  pcl::Indices idx(2);
  std::vector<float> d2(2);
  double sum = 0.0;
  size_t count = 0;
  for (size_t i = 0; i < n; i += stride) {
    // k = 2: the first neighbour is the point itself (distance 0). Exact
    // duplicates count as distance 0, as Eq. 18 does.
    if (tree.nearestKSearch((*cloud)[i], 2, idx, d2) < 2) continue;
    sum += std::sqrt(static_cast<double>(d2[1]));
    ++count;
  }
  if (count == 0) return Status::Error("density: no neighbours found");
  *mean_m = sum / static_cast<double>(count);
  *queries = count;
  return Status::Ok();
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
      const double dist = DistanceBetweenPlanes(pa, pb);
      if (dist < min_dimension_m) continue;
      const bool level = std::abs(pa.normal.z()) > 0.7;
      out.push_back({static_cast<int>(a), static_cast<int>(b), level ? "vertical" : "horizontal",
                     dist, angle});
    }
  }
  return out;
}

Status EvaluateCloud(const std::vector<Eigen::Vector3f>& points, const EvaluationOptions& options,
                     CloudEvaluation* result) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  *result = CloudEvaluation();
  result->points_in = points.size();
  std::vector<size_t> kept;
  Status s =
      RemoveStatisticalOutliers(points, options.outlier_k, options.outlier_stddev_mult, &kept);
  if (!s.ok()) return s;
  std::vector<Eigen::Vector3f> clean;
  clean.reserve(kept.size());
  for (size_t i : kept) clean.push_back(points[i]);
  result->points_after_outliers = clean.size();
  std::vector<std::vector<size_t>> members;
  s = ExtractPlanes(clean, options, &result->planes, &members);
  if (!s.ok()) return s;
  result->dimensions =
      RoomDimensions(result->planes, options.parallel_angle_deg, options.min_dimension_m);
  return MeanNearestNeighbourDistance(clean, options.density_max_queries,
                                      &result->mean_nn_distance_m, &result->density_queries);
}

}  // namespace sweepscan
