#include "ui/panels/replay_panel.h"

#include <QComboBox>
#include <QFileInfo>
#include <QHBoxLayout>
#include <QLabel>
#include <QPushButton>
#include <QSignalBlocker>
#include <QSlider>
#include <QStringList>
#include <QVBoxLayout>

namespace sweepscan::ui {

ReplayPanel::ReplayPanel(Workspace* workspace, QWidget* parent)
    : QWidget(parent), workspace_(workspace) {
  auto* layout = new QVBoxLayout(this);
  session_ = new QLabel(tr("No session"));
  session_->setObjectName(QStringLiteral("replaySession"));
  session_->setWordWrap(true);
  session_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  // Kept in sight while the session is open, beside its name (the panel
  // has no height to spare): the status bar's message of it lasts seconds,
  // and a replay that stops at a cut looks like a whole drive.
  auto* name_row = new QHBoxLayout;
  name_row->addWidget(session_, 1);
  layout->addLayout(name_row);
  damage_ = new QLabel;
  damage_->setObjectName(QStringLiteral("replayDamage"));
  damage_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  damage_->setStyleSheet(QStringLiteral("color: #b35900;"));
  damage_->hide();
  name_row->addWidget(damage_);
  slider_ = new QSlider(Qt::Horizontal);
  slider_->setObjectName(QStringLiteral("replaySlider"));
  slider_->setRange(0, 1000);
  slider_->setEnabled(false);
  slider_->setToolTip(tr("Replay position: drag to seek"));
  layout->addWidget(slider_);
  auto* row = new QHBoxLayout;
  // A dash until a replay reports its time: a live cloud or a recording has
  // no position in a session ("0.0 / 0.0 s" read as a replay of nothing).
  position_ = new QLabel(QString(QChar(0x2014)));
  position_->setObjectName(QStringLiteral("replayPosition"));
  position_->setToolTip(tr("Replay position / length of the opened session"));
  speed_ = new QComboBox;
  speed_->setObjectName(QStringLiteral("replaySpeed"));
  for (double s : {1.0, 2.0, 5.0, 10.0, 20.0}) speed_->addItem(QStringLiteral("%1x").arg(s), s);
  speed_->addItem(tr("max"), 0.0);
  speed_->setCurrentIndex(speed_->count() - 1);
  speed_->setToolTip(tr("Replay speed"));
  pause_ = new QPushButton(tr("Pause"));
  pause_->setObjectName(QStringLiteral("replayPause"));
  pause_->setCheckable(true);
  pause_->setEnabled(false);  // While a replay runs (UpdatePause).
  row->addWidget(position_, 1);
  row->addWidget(speed_);
  row->addWidget(pause_);
  layout->addLayout(row);
  // The pose source: the same choice as Tools > Pose Source.
  auto* poses_row = new QHBoxLayout;
  auto* poses_label = new QLabel(tr("Poses"));
  pose_source_ = new QComboBox;
  pose_source_->setObjectName(QStringLiteral("poseSourceBox"));
  for (PoseSource s : {PoseSource::kEkf, PoseSource::kOdometry, PoseSource::kSfm}) {
    pose_source_->addItem(PoseSourceTitle(s), static_cast<int>(s));
  }
  pose_source_->setToolTip(
      tr("Which poses place the opened session's scans: the wheel + IMU EKF, wheel odometry "
         "alone, or SfM (the EKF corrected by the planes the scans cross, computed over the "
         "whole session). Live scans always use the EKF."));
  poses_label->setBuddy(pose_source_);
  poses_row->addWidget(poses_label);
  poses_row->addWidget(pose_source_, 1);
  layout->addLayout(poses_row);
  pose_note_ = new QLabel;
  pose_note_->setObjectName(QStringLiteral("poseSourceNote"));
  pose_note_->setWordWrap(true);
  pose_note_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  layout->addWidget(pose_note_);
  setSizePolicy(QSizePolicy::Preferred, QSizePolicy::Maximum);

  connect(speed_, QOverload<int>::of(&QComboBox::currentIndexChanged), this,
          [this] { workspace_->SetReplaySpeed(speed()); });
  connect(pause_, &QPushButton::toggled, this, [this](bool paused) {
    workspace_->SetReplayPaused(paused);
    UpdatePause();
  });
  connect(workspace_, &Workspace::replayFinished, this, &ReplayPanel::UpdatePause);
  connect(slider_, &QSlider::sliderPressed, this, [this] { dragging_ = true; });
  connect(slider_, &QSlider::sliderReleased, this, [this] {
    dragging_ = false;
    workspace_->SeekReplay(length_s_ * slider_->value() / 1000.0);
  });
  connect(workspace_, &Workspace::replayProgress, this, [this](double pos, double len) {
    // A replay stopped by a new session or a live cloud may have reported
    // last after the panel was reset for it.
    if (!workspace_->replaying()) return;
    length_s_ = len;
    slider_->setEnabled(len > 0);
    UpdatePause();
    if (!dragging_ && len > 0) slider_->setValue(static_cast<int>(1000.0 * pos / len));
    position_->setText(QStringLiteral("%1 / %2 s").arg(pos, 0, 'f', 1).arg(len, 0, 'f', 1));
  });
  connect(workspace_, &Workspace::sessionRenamed, this, [this](const QString& dir) {
    session_->setText(QFileInfo(dir).fileName());
    session_->setToolTip(dir);
  });
  connect(workspace_, &Workspace::sessionChanged, this, [this](const QString& dir) {
    // A new replay starts unpaused (the processor resets it): so does the button.
    {
      const QSignalBlocker block(pause_);
      pause_->setChecked(false);
    }
    session_->setText(dir.isEmpty() ? tr("No session") : QFileInfo(dir).fileName());
    session_->setToolTip(dir);
    // The position and length were the previous session's: a new replay
    // reports its own (replayProgress), a live cloud or a recording has none.
    length_s_ = 0.0;
    dragging_ = false;
    {
      const QSignalBlocker block(slider_);
      slider_->setValue(0);
    }
    slider_->setEnabled(false);
    position_->setText(QString(QChar(0x2014)));
    UpdatePause();
    ShowPoseSource();
    ShowDamage();
  });
  connect(pose_source_, QOverload<int>::of(&QComboBox::activated), this, [this] {
    workspace_->SetPoseSource(static_cast<PoseSource>(pose_source_->currentData().toInt()));
  });
  connect(workspace_, &Workspace::poseSourceChanged, this, &ReplayPanel::ShowPoseSource);
  connect(workspace_, &Workspace::shownPoseSourceChanged, this, &ReplayPanel::ShowPoseSource);
  connect(workspace_, &Workspace::recordingChanged, this, &ReplayPanel::ShowPoseSource);
  ShowPoseSource();
}

void ReplayPanel::ShowPoseSource() {
  {
    const QSignalBlocker block(pose_source_);
    const int i = pose_source_->findData(static_cast<int>(workspace_->pose_source()));
    if (i >= 0) pose_source_->setCurrentIndex(i);
  }
  const bool opened = workspace_->recording_opened() != nullptr && !workspace_->recording();
  const PoseSource shown = workspace_->shown_pose_source();
  QString note;
  if (!opened) {
    note = tr("Applies to opened sessions; live scans always use the EKF.");
  } else if (workspace_->pose_source() != shown) {
    note = tr("Computing the %1 poses; showing %2.")
               .arg(PoseSourceTitle(workspace_->pose_source()), PoseSourceTitle(shown));
  } else if (!workspace_->sfm_summary().isEmpty()) {
    note = workspace_->sfm_summary();
  } else {
    note = tr("Cloud made with the %1 poses.").arg(PoseSourceTitle(shown));
  }
  pose_note_->setText(note);
}

void ReplayPanel::ShowDamage() {
  const hardware::Recording* opened = workspace_->recording_opened();
  QStringList said, details;
  if (opened != nullptr) {
    const FramesLoadReport& f = opened->decode.frames;
    if (f.damaged()) {
      const auto n = static_cast<qulonglong>(f.corrupt_records_skipped);
      said << (n == 1 ? tr("1 damaged record skipped") : tr("%1 damaged records skipped").arg(n));
      details << QString::fromStdString(f.DamageSummary());
    }
    if (f.truncated_tail) {
      // Short enough beside the name without wrapping (the rest is in the tooltip).
      said << (said.isEmpty() ? tr("ends early: cut off while recording") : tr("ends early"));
      details << tr("It ends early: its last record was cut off as it was written (a crash or "
                    "power loss?), and what was recorded before it is shown. %1 bytes left out "
                    "(%2).")
                     .arg(f.tail_bytes_dropped)
                     .arg(QString::fromStdString(f.tail_reason));
    }
  }
  damage_->setText(said.join(QStringLiteral("; ")));
  damage_->setToolTip(details.join(QLatin1Char('\n')));
  damage_->setVisible(!said.isEmpty());
}

void ReplayPanel::UpdatePause() {
  // Nothing to pause with no replay running (no session, a live cloud, a
  // replay at its end); paused, the button says what it will do.
  const bool running = workspace_->replaying();
  if (!running && pause_->isChecked()) {
    const QSignalBlocker block(pause_);
    pause_->setChecked(false);
  }
  pause_->setEnabled(running);
  pause_->setText(pause_->isChecked() ? tr("Resume") : tr("Pause"));
}

QString ReplayPanel::pose_source_text() const { return pose_note_->text(); }

double ReplayPanel::speed() const { return speed_->currentData().toDouble(); }

void ReplayPanel::SetSpeed(double s) {
  if (!(s >= 0.0)) return;
  int i = speed_->findData(s);
  if (i < 0) {
    // A speed the list does not offer (--speed 3): added in its place, so
    // that the panel shows it and a restarted replay (a seek back, another
    // pose source) keeps it. "max" (0) stays last.
    i = 0;
    while (i < speed_->count() - 1 && speed_->itemData(i).toDouble() < s) ++i;
    speed_->insertItem(i, QStringLiteral("%1x").arg(s), s);
  }
  speed_->setCurrentIndex(i);
}

}  // namespace sweepscan::ui
