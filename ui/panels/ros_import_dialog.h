// File > Import ROS Recording…: the topic chooser. Given a bag, it asks the
// workspace to inspect it (a job: progress and cancel in the status bar),
// fills one chooser each for the LaserScan, the odometry and the IMU from
// the bag's topics (with counts and rates; "none" where the bag may do
// without), and the session folder to write; OK starts the import job, and
// the imported session then opens like any other. The same choices and
// rules as `sweepscan-cli import` (docs/ros-bags.md).
//
// GUI thread only.
#ifndef SWEEPSCAN_UI_PANELS_ROS_IMPORT_DIALOG_H_
#define SWEEPSCAN_UI_PANELS_ROS_IMPORT_DIALOG_H_

#include <QDialog>

#include "core/io/ros/import.h"

class QComboBox;
class QDialogButtonBox;
class QLabel;
class QLineEdit;
class QCheckBox;

namespace sweepscan::ui {

class Workspace;

class RosImportDialog : public QDialog {
  Q_OBJECT
 public:
  // Starts inspecting `bag` at once; shows itself when the bag is read
  // (and closes with an error message from the workspace if it is not a bag).
  RosImportDialog(Workspace* workspace, const QString& bag, double replay_speed, QWidget* parent);

  bool ready() const { return ready_; }  // The bag is read and the choosers filled.
  QComboBox* scan_topic() const { return scan_; }
  QComboBox* odom_topic() const { return odom_; }
  QComboBox* imu_topic() const { return imu_; }
  QLineEdit* session_dir() const { return session_dir_; }
  QLineEdit* lidar_mount() const { return mount_; }
  QCheckBox* use_lidar_mount() const { return use_mount_; }
  QDialogButtonBox* buttons() const { return buttons_; }
  QLabel* error_label() const { return error_; }

  // The choices as import options; false with *why when one is malformed.
  bool Options(io::RosImportOptions* options, QString* why) const;

  void accept() override;

  // Fills the choosers from a bag's summary (the inspect job's result):
  // each kind's topics with messages in an encoding read here, the one the
  // CLI would choose first. Public so that a test can show it summaries no
  // test bag has.
  void Fill(const io::RosBagSummary& summary);

 signals:
  void inspected(bool ok);

 private:
  Workspace* workspace_;
  QString bag_;
  double speed_;
  bool ready_ = false;
  QLabel* about_;
  QComboBox* scan_;
  QComboBox* odom_;
  QComboBox* imu_;
  QLineEdit* base_frame_;
  QCheckBox* use_mount_;
  QLineEdit* mount_;
  QCheckBox* use_imu_mount_;
  QLineEdit* imu_mount_;
  QLineEdit* session_dir_;
  QLabel* error_;
  QDialogButtonBox* buttons_;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PANELS_ROS_IMPORT_DIALOG_H_
