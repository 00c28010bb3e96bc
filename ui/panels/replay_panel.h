// Replay panel: the opened session, a time slider (seek), speed 1x..20x or
// as fast as possible, pause, and the pose source the session is made with
// (EKF, odometry, SfM; the same choice as Tools > Pose Source). GUI thread.
// Calls only the Workspace.
#ifndef SWEEPSCAN_UI_PANELS_REPLAY_PANEL_H_
#define SWEEPSCAN_UI_PANELS_REPLAY_PANEL_H_

#include <QWidget>

#include "ui/workspace/workspace.h"

class QComboBox;
class QLabel;
class QPushButton;
class QSlider;

namespace sweepscan::ui {

class ReplayPanel : public QWidget {
  Q_OBJECT
 public:
  explicit ReplayPanel(Workspace* workspace, QWidget* parent = nullptr);
  // 0 = as fast as possible.
  double speed() const;
  // Any speed >= 0 (one the list lacks is added to it); the workspace's
  // replay follows.
  void SetSpeed(double speed);
  QComboBox* pose_source_box() const { return pose_source_; }
  QString pose_source_text() const;  // What the cloud shown is made with.

 private:
  Workspace* workspace_;
  QLabel* session_;
  QLabel* damage_;  // What of the opened session could not be read; hidden if nothing.
  QSlider* slider_;
  QLabel* position_;
  QComboBox* speed_;
  QPushButton* pause_;
  QComboBox* pose_source_;
  QLabel* pose_note_;
  void ShowPoseSource();
  void ShowDamage();
  void UpdatePause();  // Enabled while a replay runs; "Resume" when paused.

  double length_s_ = 0.0;
  bool dragging_ = false;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PANELS_REPLAY_PANEL_H_
