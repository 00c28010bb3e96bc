#include "core/evaluation/report.h"

namespace sweepscan {

nlohmann::json EvaluationToJson(const CloudEvaluation& e) {
  nlohmann::json planes = nlohmann::json::array();
  for (const auto& p : e.planes) {
    nlohmann::json outline = nlohmann::json::array();
    for (const Eigen::Vector3d& c : p.outline) outline.push_back({c.x(), c.y(), c.z()});
    planes.push_back({{"kind", p.kind},
                      {"normal", {p.plane.normal.x(), p.plane.normal.y(), p.plane.normal.z()}},
                      {"d_m", p.plane.d},
                      {"rms_m", p.plane.rms},
                      {"points", p.plane.count},
                      {"tilt_deg", p.tilt_deg},
                      {"outline_m", outline},
                      {"histogram",
                       {{"bin_m", p.deviations.bin_m},
                        {"min_m", p.deviations.min_m},
                        {"mean_m", p.deviations.mean_m},
                        {"stddev_m", p.deviations.stddev_m},
                        {"counts", p.deviations.counts},
                        {"below", p.deviations.below},
                        {"above", p.deviations.above}}}});
  }
  nlohmann::json dims = nlohmann::json::array();
  for (const auto& d : e.dimensions) {
    dims.push_back({{"planes", {d.plane_a, d.plane_b}},
                    {"axis", d.axis},
                    {"distance_m", d.distance_m},
                    {"angle_deg", d.angle_deg}});
  }
  return {{"points", e.points_in},
          {"points_after_outlier_removal", e.points_after_outliers},
          {"planes", planes},
          {"dimensions", dims},
          {"mean_nn_distance_m", e.mean_nn_distance_m},
          {"density_queries", e.density_queries}};
}

}  // namespace sweepscan
