// The desktop app's scripted tours (documentation screenshots).
#ifndef SWEEPSCAN_APP_GUI_TOUR_H_
#define SWEEPSCAN_APP_GUI_TOUR_H_

#include <QString>

namespace sweepscan::ui {
class MainWindow;
class Workspace;
}  // namespace sweepscan::ui

namespace sweepscan::app {

// --calibration-tour DIR, with --replay SESSION (a circle drive past the
// target) and --pairs FILE (world picks of its corners): once the session is
// shown, goes through the calibration panel's steps as an operator would
// and saves a window screenshot at each into DIR (calibration-1-passes.png
// .. calibration-5-calibrated.png, evaluation-panel.png), then closes the
// window. Prints one JSON line per step (file, seconds since the start).
void StartCalibrationTour(const QString& pairs, const QString& out_dir, ui::Workspace* workspace,
                          ui::MainWindow* window);

// --pose-source-tour PNG, with --replay SESSION: once the session is shown
// (with the EKF), chooses Tools > Pose Source > SfM as an operator would,
// waits for the SfM re-processing, and saves a screenshot of the window
// with that menu open into PNG, then closes the window. Prints one JSON
// line (file, seconds the SfM re-processing took, the status bar's text).
void StartPoseSourceTour(const QString& png, ui::Workspace* workspace, ui::MainWindow* window);

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_GUI_TOUR_H_
