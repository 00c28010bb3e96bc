// Tools > Device Check: an X4 lidar or HI219 IMU plugged straight into this
// computer (USB adapter), checked without a robot agent: port, device, a few
// seconds of listening, and a verdict with what arrived and the decoders'
// error counters. Non-modal; the check runs on the workspace's I/O thread.
#ifndef SWEEPSCAN_UI_PANELS_DEVICE_CHECK_DIALOG_H_
#define SWEEPSCAN_UI_PANELS_DEVICE_CHECK_DIALOG_H_

#include <QDialog>

#include "ui/workspace/workspace.h"

class QComboBox;
class QLabel;
class QPlainTextEdit;
class QPushButton;

namespace sweepscan::ui {

class DeviceCheckDialog : public QDialog {
  Q_OBJECT
 public:
  explicit DeviceCheckDialog(Workspace* workspace, QWidget* parent = nullptr);
  void SetPort(const QString& port);
  void SetKind(hardware::DirectDevice::Kind kind);
  void StartCheck();
  QString report() const;
  bool passed() const { return passed_; }

 signals:
  void finished(bool ok);

 private:
  Workspace* workspace_;
  QComboBox* port_;
  QComboBox* kind_;
  QPushButton* check_;
  QLabel* verdict_;
  QPlainTextEdit* report_;
  bool passed_ = false;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PANELS_DEVICE_CHECK_DIALOG_H_
