#include "ui/panels/ros_import_dialog.h"

#include <QCheckBox>
#include <QComboBox>
#include <QDialogButtonBox>
#include <QDir>
#include <QFileDialog>
#include <QFileInfo>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <QVBoxLayout>
#include <algorithm>
#include <cmath>

#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

// "x, y, z, roll, pitch, yaw" (m, rad) as base_from_sensor.
bool ParsePose(const QString& text, Rigid3d* pose) {
  const QStringList parts = text.split(QLatin1Char(','));
  if (parts.size() != 6) return false;
  double v[6];
  for (int i = 0; i < 6; ++i) {
    bool ok = false;
    v[i] = parts[i].trimmed().toDouble(&ok);
    if (!ok || !std::isfinite(v[i])) return false;
  }
  *pose = Rigid3d::FromPose(v[0], v[1], v[2], v[3], v[4], v[5]);
  return true;
}

QString TopicLabel(const io::RosTopicInfo& t) {
  const double span = static_cast<double>(t.last_ns - t.first_ns) * 1e-9;
  const QString rate = t.message_count > 1 && span > 0
                           ? QObject::tr(", %1 Hz").arg((t.message_count - 1) / span, 0, 'f', 1)
                           : QString();
  return QObject::tr("%1  (%2 messages%3)")
      .arg(QString::fromStdString(t.topic))
      .arg(t.message_count)
      .arg(rate);
}

}  // namespace

RosImportDialog::RosImportDialog(Workspace* workspace, const QString& bag, double replay_speed,
                                 QWidget* parent)
    : QDialog(parent), workspace_(workspace), bag_(bag), speed_(replay_speed) {
  setObjectName(QStringLiteral("rosImportDialog"));
  setWindowTitle(tr("Import ROS Recording"));
  setAttribute(Qt::WA_DeleteOnClose);
  // Modal to the window, as an import's options are: the discard was
  // confirmed when the dialog was made, so nothing may be recorded, opened
  // or imported meanwhile that Import would then replace unasked.
  setWindowModality(Qt::WindowModal);
  about_ = new QLabel(tr("Reading %1…").arg(bag), this);
  about_->setWordWrap(true);
  scan_ = new QComboBox(this);
  scan_->setObjectName(QStringLiteral("rosScanTopic"));
  odom_ = new QComboBox(this);
  odom_->setObjectName(QStringLiteral("rosOdomTopic"));
  imu_ = new QComboBox(this);
  imu_->setObjectName(QStringLiteral("rosImuTopic"));
  base_frame_ = new QLineEdit(this);
  base_frame_->setPlaceholderText(tr("the odometry's child frame, else base_footprint or base_link"));
  use_mount_ = new QCheckBox(tr("Lidar mount instead of tf:"), this);
  mount_ = new QLineEdit(this);
  mount_->setPlaceholderText(tr("x, y, z (m), roll, pitch, yaw (rad)"));
  mount_->setEnabled(false);
  use_imu_mount_ = new QCheckBox(tr("IMU mount instead of tf:"), this);
  imu_mount_ = new QLineEdit(this);
  imu_mount_->setPlaceholderText(tr("x, y, z (m), roll, pitch, yaw (rad)"));
  imu_mount_->setEnabled(false);
  connect(use_mount_, &QCheckBox::toggled, mount_, &QWidget::setEnabled);
  connect(use_imu_mount_, &QCheckBox::toggled, imu_mount_, &QWidget::setEnabled);
  session_dir_ = new QLineEdit(this);
  session_dir_->setObjectName(QStringLiteral("rosSessionDir"));
  const QString base = QFileInfo(bag).completeBaseName().isEmpty() ? QFileInfo(bag).fileName()
                                                                  : QFileInfo(bag).completeBaseName();
  session_dir_->setText(workspace->sessions_root() + QLatin1Char('/') + base + QStringLiteral(".sweepscan"));
  auto* browse = new QPushButton(tr("Browse…"), this);
  connect(browse, &QPushButton::clicked, this, [this] {
    const QString dir = QFileDialog::getSaveFileName(this, tr("New session folder"), session_dir_->text(),
                                                     tr("Sessions (*.sweepscan)"));
    if (!dir.isEmpty()) session_dir_->setText(dir.endsWith(QStringLiteral(".sweepscan")) ? dir : dir + ".sweepscan");
  });
  auto* out = new QHBoxLayout;
  out->addWidget(session_dir_, 1);
  out->addWidget(browse);

  auto* form = new QFormLayout;
  form->addRow(tr("&LaserScan:"), scan_);
  form->addRow(tr("&Odometry:"), odom_);
  form->addRow(tr("&IMU:"), imu_);
  form->addRow(tr("Robot &frame:"), base_frame_);
  form->addRow(use_mount_, mount_);
  form->addRow(use_imu_mount_, imu_mount_);
  // A row whose field is a layout gets no buddy from addRow: set it here,
  // or the mnemonic shows as a literal "&".
  auto* out_label = new QLabel(tr("&Session folder:"), this);
  out_label->setBuddy(session_dir_);
  form->addRow(out_label, out);
  error_ = new QLabel(this);
  error_->setObjectName(QStringLiteral("rosImportError"));
  error_->setStyleSheet(QStringLiteral("color: #b00020"));
  error_->setWordWrap(true);
  buttons_ = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel, this);
  buttons_->button(QDialogButtonBox::Ok)->setText(tr("&Import"));
  buttons_->button(QDialogButtonBox::Ok)->setEnabled(false);
  connect(buttons_, &QDialogButtonBox::accepted, this, &QDialog::accept);
  connect(buttons_, &QDialogButtonBox::rejected, this, &QDialog::reject);
  auto* layout = new QVBoxLayout(this);
  layout->addWidget(about_);
  layout->addLayout(form);
  layout->addWidget(error_);
  layout->addWidget(buttons_);
  setMinimumWidth(560);
  // Fields as wide as what they show: their hints and the session's path
  // were cut at 560 px ("the odometry's child frame, else base_fo").
  const auto fit = [](QLineEdit* field, const QString& text, int at_most) {
    const int need = field->fontMetrics().horizontalAdvance(text) + 24;
    field->setMinimumWidth(std::min(need, at_most));
  };
  fit(base_frame_, base_frame_->placeholderText(), 640);
  fit(mount_, mount_->placeholderText(), 640);
  fit(imu_mount_, imu_mount_->placeholderText(), 640);
  fit(session_dir_, session_dir_->text(), 640);

  auto done = std::make_shared<QMetaObject::Connection>();
  *done = connect(workspace_, &Workspace::rosBagInspected, this,
                  [this, done](const QString& which, bool ok, const QString&) {
                    if (which != bag_) return;
                    disconnect(*done);
                    if (ok) {
                      Fill(workspace_->ros_bag_summary());
                      show();
                    } else {
                      close();  // the workspace's jobFinished has said why
                    }
                    emit inspected(ok);
                  });
  workspace_->InspectRosBag(bag);
}

void RosImportDialog::Fill(const io::RosBagSummary& s) {
  about_->setText(tr("<b>%1</b><br>%2, compression %3, %4 messages over %5 s")
                      .arg(bag_.toHtmlEscaped(), QString::fromStdString(s.format),
                           QString::fromStdString(s.compression))
                      .arg(s.message_count)
                      .arg(static_cast<double>(s.end_ns - s.start_ns) * 1e-9, 0, 'f', 1));
  const std::pair<QComboBox*, io::RosMessageKind> choosers[] = {
      {scan_, io::RosMessageKind::kLaserScan}, {odom_, io::RosMessageKind::kOdometry}, {imu_, io::RosMessageKind::kImu}};
  for (const auto& [combo, kind] : choosers) {
    combo->clear();
    // What the import can read: the kind's topics with messages, in an
    // encoding read here; the one the CLI would choose first.
    std::string chosen;
    io::ChooseTopic(s, kind, std::string(), false, &chosen);
    for (const io::RosTopicInfo& t : s.topics) {
      if (t.kind() != kind || t.message_count == 0 || !s.Decodable(t)) continue;
      const int at = t.topic == chosen ? 0 : combo->count();
      combo->insertItem(at, TopicLabel(t), QString::fromStdString(t.topic));
    }
    // Scans are what a cloud is made of: "none" only offered when the bag has none.
    if (kind != io::RosMessageKind::kLaserScan || combo->count() == 0) {
      combo->addItem(tr("none"), QStringLiteral("none"));
    }
    combo->setCurrentIndex(0);
  }
  // Said before the import, not found out after it: the session then
  // holds a trajectory and no cloud (it imported 0 points without a word).
  if (scan_->currentData().toString() == QLatin1String("none")) {
    about_->setText(about_->text() +
                    tr("<br><b>No sensor_msgs/LaserScan topic this import reads:</b> the session "
                       "will hold the trajectory only, no cloud."));
  }
  ready_ = true;
  buttons_->button(QDialogButtonBox::Ok)->setEnabled(true);
}

bool RosImportDialog::Options(io::RosImportOptions* o, QString* why) const {
  *o = io::RosImportOptions();
  o->scan_topic = scan_->currentData().toString().toStdString();
  if (o->scan_topic == "none") o->scan_topic.clear();
  o->odom_topic = odom_->currentData().toString().toStdString();
  o->imu_topic = imu_->currentData().toString().toStdString();
  o->base_frame = base_frame_->text().trimmed().toStdString();
  if (use_mount_->isChecked()) {
    if (!ParsePose(mount_->text(), &o->base_from_scan)) {
      *why = tr("The lidar mount wants six numbers: x, y, z (m), roll, pitch, yaw (rad).");
      return false;
    }
    o->has_mount = true;
  }
  if (use_imu_mount_->isChecked()) {
    if (!ParsePose(imu_mount_->text(), &o->base_from_imu)) {
      *why = tr("The IMU mount wants six numbers: x, y, z (m), roll, pitch, yaw (rad).");
      return false;
    }
    o->has_imu_mount = true;
  }
  if (session_dir_->text().trimmed().isEmpty()) {
    *why = tr("Choose the session folder to write.");
    return false;
  }
  return true;
}

void RosImportDialog::accept() {
  io::RosImportOptions options;
  QString why;
  if (!Options(&options, &why)) {
    error_->setText(why);
    return;
  }
  if (QFileInfo::exists(session_dir_->text()) && !QDir(session_dir_->text()).isEmpty()) {
    error_->setText(tr("%1 exists already: choose a new session folder.").arg(session_dir_->text()));
    return;
  }
  workspace_->ImportRosRecording(bag_, session_dir_->text().trimmed(), options, speed_);
  QDialog::accept();
}

}  // namespace sweepscan::ui
