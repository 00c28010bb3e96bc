// Drive panel: speed and turn-rate limits, lidar motor, the emergency stop
// (also bound to Space, whatever has focus: MainWindow's event filter), and
// the scripted calibration circle (radius, speed, turns) with start / abort.
// Keyboard teleop (arrows, WASD) is handled by MainWindow; this panel shows
// the command being sent. GUI thread. Calls only the Workspace.
#ifndef SWEEPSCAN_UI_PANELS_DRIVE_PANEL_H_
#define SWEEPSCAN_UI_PANELS_DRIVE_PANEL_H_

#include <QWidget>

#include "ui/workspace/workspace.h"

class QCheckBox;
class QDoubleSpinBox;
class QLabel;
class QPushButton;

namespace sweepscan::ui {

class DrivePanel : public QWidget {
  Q_OBJECT
 public:
  explicit DrivePanel(Workspace* workspace, QWidget* parent = nullptr);

  void ShowCommand(const Twist2d& commanded);
  QPushButton* emergency_stop_button() const { return estop_; }

 private:
  Workspace* workspace_;
  QDoubleSpinBox* v_max_;
  QDoubleSpinBox* w_max_;
  QCheckBox* lidar_;
  QPushButton* estop_;
  QPushButton* clear_;
  QDoubleSpinBox* radius_;
  QDoubleSpinBox* speed_;
  QDoubleSpinBox* turns_;
  QPushButton* start_circle_;
  QPushButton* abort_;
  QLabel* command_;
  QLabel* script_state_;  // shown while a scripted drive runs
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PANELS_DRIVE_PANEL_H_
