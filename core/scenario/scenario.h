// Scenario files: everything the simulated world needs, as JSON
// (docs/scenario-format.md). Loading is strict: a missing required key, a
// wrong type, a non-positive size, an out-of-range value or an unknown key
// is refused with the file, the JSON path and the reason.
#ifndef SWEEPSCAN_CORE_SCENARIO_SCENARIO_H_
#define SWEEPSCAN_CORE_SCENARIO_SCENARIO_H_

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/sim/world.h"

namespace sweepscan {

constexpr int kScenarioFormatVersion = 1;

Status ScenarioFromJson(const nlohmann::json& j, const std::string& source, sim::SimConfig* config);
Status LoadScenario(const std::string& path, sim::SimConfig* config);
// A drive script (`sweepscan-cli record --drive-script`, docs/scenario-format.md
// "Drive scripts"): {"segments": [...]} with the segments of a scenario's
// path, or a whole scenario file (its path's segments).
Status LoadDriveScript(const std::string& path, std::vector<sim::DriveSegment>* segments);
// The full, explicit form of a configuration (every default written out);
// loading it back gives the same configuration.
nlohmann::json ScenarioToJson(const sim::SimConfig& config);

// Helpers for paths: a circle of `radius` at `speed`, `turns` times, turning
// left (w > 0) or right.
sim::DriveSegment CircleSegment(double radius_m, double speed_mps, double turns, bool left = true);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_SCENARIO_SCENARIO_H_
