#include "ui/panels/drive_panel.h"

#include <QCheckBox>
#include <QDoubleSpinBox>
#include <QFormLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QLabel>
#include <QPushButton>
#include <QSettings>
#include <QVBoxLayout>
#include <cmath>

namespace sweepscan::ui {
namespace {

QDoubleSpinBox* Spin(double lo, double hi, double step, double value, const QString& suffix,
                     int decimals = 2) {
  auto* s = new QDoubleSpinBox;
  s->setRange(lo, hi);
  s->setSingleStep(step);
  s->setDecimals(decimals);
  s->setValue(value);
  s->setSuffix(suffix);
  return s;
}

// A spin box that starts at the value the operator left it at (QSettings
// `key`, else `value`) and keeps each change there: the limits an operator
// sets for a robot and a room hold from one start to the next.
QDoubleSpinBox* KeptSpin(const QString& key, double lo, double hi, double step, double value,
                         const QString& suffix, int decimals = 2) {
  bool ok = false;
  const double kept = QSettings().value(key).toDouble(&ok);
  QDoubleSpinBox* s =
      Spin(lo, hi, step, ok && std::isfinite(kept) ? kept : value, suffix, decimals);
  s->setObjectName(key);
  QObject::connect(s, QOverload<double>::of(&QDoubleSpinBox::valueChanged), s,
                   [key](double v) { QSettings().setValue(key, v); });
  return s;
}

}  // namespace

DrivePanel::DrivePanel(Workspace* workspace, QWidget* parent)
    : QWidget(parent), workspace_(workspace) {
  auto* layout = new QVBoxLayout(this);

  estop_ = new QPushButton(tr("EMERGENCY STOP  (Space)"));
  estop_->setObjectName(QStringLiteral("emergencyStop"));
  estop_->setMinimumHeight(56);
  estop_->setFocusPolicy(Qt::NoFocus);
  estop_->setStyleSheet(QStringLiteral(
      "QPushButton { background: #c62828; color: white; font-weight: bold; font-size: 15px;"
      " border-radius: 6px; } QPushButton:pressed { background: #8e0000; }"));
  connect(estop_, &QPushButton::clicked, workspace_, &Workspace::EmergencyStop);
  layout->addWidget(estop_);
  clear_ = new QPushButton(tr("Clear emergency stop"));
  connect(clear_, &QPushButton::clicked, workspace_, &Workspace::ClearEmergencyStop);
  layout->addWidget(clear_);

  auto* teleop = new QGroupBox(tr("Keyboard"));
  auto* teleop_form = new QFormLayout(teleop);
  v_max_ = KeptSpin(QStringLiteral("drive/speed_limit_mps"), 0.01, 1.0, 0.05,
                    workspace_->limits().v_max_mps, tr(" m/s"));
  w_max_ = KeptSpin(QStringLiteral("drive/turn_rate_limit_radps"), 0.05, 3.0, 0.1,
                    workspace_->limits().w_max_radps, tr(" rad/s"));
  auto apply_limits = [this] { workspace_->SetLimits({v_max_->value(), w_max_->value()}); };
  apply_limits();  // the kept ones
  connect(v_max_, QOverload<double>::of(&QDoubleSpinBox::valueChanged), this, apply_limits);
  connect(w_max_, QOverload<double>::of(&QDoubleSpinBox::valueChanged), this, apply_limits);
  teleop_form->addRow(tr("Speed limit"), v_max_);
  teleop_form->addRow(tr("Turn-rate limit"), w_max_);
  // One short line: a word-wrapped label in a form row is clipped when the dock is squeezed.
  auto* hint = new QLabel(tr("Hold arrows or W A S D to drive."));
  teleop_form->addRow(hint);
  // The command alone, short: a longer line (it once said "(scripted)"
  // here) widened the panel past its dock and cut off the emergency stop.
  command_ = new QLabel;
  command_->setObjectName(QStringLiteral("driveCommand"));
  teleop_form->addRow(tr("Command"), command_);
  lidar_ = new QCheckBox(tr("Lidar motor on"));
  lidar_->setChecked(true);
  connect(lidar_, &QCheckBox::toggled, workspace_, &Workspace::SetLidarMotor);
  teleop_form->addRow(lidar_);
  layout->addWidget(teleop);

  auto* script = new QGroupBox(tr("Calibration circle"));
  auto* script_form = new QFormLayout(script);
  // The calibration drive's defaults (docs/calibration.md), or the operator's.
  radius_ = KeptSpin(QStringLiteral("drive/circle_radius_m"), 0.2, 5.0, 0.1, 1.0, tr(" m"));
  speed_ = KeptSpin(QStringLiteral("drive/circle_speed_mps"), 0.01, 0.5, 0.01, 0.05, tr(" m/s"));
  turns_ = KeptSpin(QStringLiteral("drive/circle_turns"), 0.25, 5.0, 0.25, 3.0, QString());
  script_form->addRow(tr("Radius"), radius_);
  script_form->addRow(tr("Speed"), speed_);
  script_form->addRow(tr("Turns"), turns_);
  auto* row = new QHBoxLayout;
  start_circle_ = new QPushButton(tr("Start"));
  abort_ = new QPushButton(tr("Abort"));
  row->addWidget(start_circle_);
  row->addWidget(abort_);
  script_form->addRow(row);
  script_state_ = new QLabel;
  script_state_->setObjectName(QStringLiteral("driveScriptState"));
  script_state_->setVisible(false);
  script_form->addRow(script_state_);
  connect(start_circle_, &QPushButton::clicked, this, [this] {
    workspace_->StartScriptedDrive(
        Workspace::CirclePath(radius_->value(), speed_->value(), turns_->value()),
        tr("the circle"));
  });
  connect(abort_, &QPushButton::clicked, workspace_, &Workspace::AbortScriptedDrive);
  layout->addWidget(script);
  layout->addStretch(1);
  ShowCommand(Twist2d());
}

void DrivePanel::ShowCommand(const Twist2d& c) {
  command_->setText(tr("v %1 m/s, w %2 rad/s").arg(c.v, 0, 'f', 2).arg(c.w, 0, 'f', 2));
  script_state_->setText(tr("Driving %1: Abort ends it.").arg(workspace_->scripted_drive_name()));
  script_state_->setVisible(workspace_->scripted_drive_running());
  abort_->setEnabled(workspace_->scripted_drive_running());
  const bool can_drive = workspace_->authenticated();
  start_circle_->setEnabled(can_drive && !workspace_->scripted_drive_running());
}

}  // namespace sweepscan::ui
