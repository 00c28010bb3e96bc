// The calibration panel's result, as rich text: the angles with their
// sigma, the ghost before and after, the poses, how the board's edges held,
// the parts of a combination with the room's planes, the raw picks'
// baseline and the warnings (docs/desktop-app.md, "Calibration", step 4).
#ifndef SWEEPSCAN_UI_PANELS_CALIBRATION_RESULT_TEXT_H_
#define SWEEPSCAN_UI_PANELS_CALIBRATION_RESULT_TEXT_H_

#include <QString>

#include "core/calibration/workflow.h"

namespace sweepscan::ui {

// `message` is shown for a calibration loaded from a file (method "file").
QString CalibrationResultText(const PickCalibrationResult& r, const QString& message);

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PANELS_CALIBRATION_RESULT_TEXT_H_
