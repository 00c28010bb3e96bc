// An evaluation as JSON: the keys `sweepscan-cli evaluate --json` prints for
// each cloud and the desktop app's evaluation report holds
// (docs/evaluation-report.md).
#ifndef SWEEPSCAN_CORE_EVALUATION_REPORT_H_
#define SWEEPSCAN_CORE_EVALUATION_REPORT_H_

#include <nlohmann/json.hpp>

#include "core/evaluation/evaluation.h"

namespace sweepscan {

// points, points_after_outlier_removal, planes (kind, normal, d_m, rms_m,
// points, tilt_deg, outline_m, histogram), dimensions, mean_nn_distance_m,
// density_queries.
nlohmann::json EvaluationToJson(const CloudEvaluation& e);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_EVALUATION_REPORT_H_
