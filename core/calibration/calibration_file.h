// Calibration files (docs/calibration.md, "Calibration file"): the three
// mounting angles and, optionally, how they were found.
#ifndef SWEEPSCAN_CORE_CALIBRATION_CALIBRATION_FILE_H_
#define SWEEPSCAN_CORE_CALIBRATION_CALIBRATION_FILE_H_

#include <string>

#include "core/calibration/pairs_solver.h"
#include "core/common/status.h"
#include "core/robot/robot_model.h"

namespace sweepscan {

Status SaveCalibrationFile(const std::string& path, const MountingError& calibration,
                           const CalibrationSummary* summary);
Status LoadCalibrationFile(const std::string& path, MountingError* calibration);
Status ParseCalibration(const std::string& text, const std::string& source,
                        MountingError* calibration);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CALIBRATION_CALIBRATION_FILE_H_
