// Calibration files (docs/calibration.md, "Calibration file").
#include "core/calibration/calibration_file.h"

#include <cmath>
#include <string>

#include "core/calibration/file_internal.h"
#include "core/common/json_reader.h"

namespace sweepscan {

using calibration_internal::CheckHeader;
using calibration_internal::ParseJsonNoThrow;
using calibration_internal::ReadText;

Status SaveCalibrationFile(const std::string& path, const MountingError& c,
                           const CalibrationSummary* summary) {
  if (!std::isfinite(c.alpha) || !std::isfinite(c.beta) || !std::isfinite(c.gamma)) {
    return Status::Error(path + ": refusing to save non-finite angles");
  }
  // What the reader accepts (ParseCalibration), so that nothing written here
  // is refused when read back.
  if (std::abs(c.alpha) > 0.5 || std::abs(c.beta) > 0.5 || std::abs(c.gamma) > 0.5) {
    return Status::Error(
        path + ": refusing to save angles beyond 0.5 rad (no mounting error is that large)");
  }
  nlohmann::json root = {
      {"format", "sweepscan-calibration"},
      {"version", 1},
      {"mounting_error_rad", {{"alpha", c.alpha}, {"beta", c.beta}, {"gamma", c.gamma}}}};
  if (summary != nullptr) {
    root["method"] = summary->method;
    root["converged"] = summary->converged;
    if (summary->sigma_rad.minCoeff() >= 0.0 && summary->sigma_rad.allFinite()) {
      root["sigma_rad"] = {{"alpha", summary->sigma_rad[0]},
                           {"beta", summary->sigma_rad[1]},
                           {"gamma", summary->sigma_rad[2]}};
    }
    root["rms_before_m"] = summary->initial_rms_m;
    root["rms_after_m"] = summary->final_rms_m;
  }
  return WriteFileAtomically(path, root.dump(2) + "\n");
}

Status ParseCalibration(const std::string& text, const std::string& source, MountingError* c) {
  nlohmann::json j;
  Status s = ParseJsonNoThrow(text, source, &j);
  if (!s.ok()) return s;
  try {
    const JsonObject root(j, "");
    // The format first: a pairs file given as a calibration says what it
    // is, not "pairs: unknown key".
    CheckHeader(root, "sweepscan-calibration");
    root.AllowOnly({"format", "version", "mounting_error_rad", "method", "converged", "sigma_rad",
                    "rms_before_m", "rms_after_m", "comment"});
    const JsonObject m = root.Object("mounting_error_rad");
    m.AllowOnly({"alpha", "beta", "gamma"});
    // A mounting error is a small angle; beyond 0.5 rad the file is wrong
    // (degrees written as radians, most likely).
    MountingError out;
    out.alpha = m.InRange("alpha", -0.5, 0.5, 0.0);
    out.beta = m.InRange("beta", -0.5, 0.5, 0.0);
    out.gamma = m.InRange("gamma", -0.5, 0.5, 0.0);
    for (const char* k : {"alpha", "beta", "gamma"}) {
      if (!m.Has(k)) m.Fail(k, "missing");
    }
    if (root.Has("method")) root.String("method");
    root.Bool("converged", true);
    if (root.Has("sigma_rad")) {
      const JsonObject sg = root.Object("sigma_rad");
      sg.AllowOnly({"alpha", "beta", "gamma"});
      for (const char* k : {"alpha", "beta", "gamma"}) sg.NonNegative(k, 0.0);
    }
    root.NonNegative("rms_before_m", 0.0);
    root.NonNegative("rms_after_m", 0.0);
    *c = out;
  } catch (const JsonError& e) {
    return Status::Error(source + ": " + e.what());
  }
  return Status::Ok();
}

Status LoadCalibrationFile(const std::string& path, MountingError* c) {
  std::string text;
  Status s = ReadText(path, &text);
  if (!s.ok()) return s;
  return ParseCalibration(text, path, c);
}

}  // namespace sweepscan
