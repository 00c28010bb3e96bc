#include "ui/panels/replay_panel.h"

#include <QComboBox>
#include <QFileInfo>
#include <QHBoxLayout>
#include <QLabel>
#include <QPushButton>
#include <QSlider>
#include <QVBoxLayout>

namespace sweepscan::ui {

ReplayPanel::ReplayPanel(Workspace* workspace, QWidget* parent)
    : QWidget(parent), workspace_(workspace) {
  auto* layout = new QVBoxLayout(this);
  session_ = new QLabel(tr("No session"));
  session_->setWordWrap(true);
  session_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  layout->addWidget(session_);
  slider_ = new QSlider(Qt::Horizontal);
  slider_->setRange(0, 1000);
  slider_->setEnabled(false);
  slider_->setToolTip(tr("Replay position: drag to seek"));
  layout->addWidget(slider_);
  auto* row = new QHBoxLayout;
  position_ = new QLabel(QStringLiteral("0.0 / 0.0 s"));
  speed_ = new QComboBox;
  for (double s : {1.0, 2.0, 5.0, 10.0, 20.0}) speed_->addItem(QStringLiteral("%1x").arg(s), s);
  speed_->addItem(tr("max"), 0.0);
  speed_->setCurrentIndex(speed_->count() - 1);
  speed_->setToolTip(tr("Replay speed"));
  pause_ = new QPushButton(tr("Pause"));
  pause_->setCheckable(true);
  row->addWidget(position_, 1);
  row->addWidget(speed_);
  row->addWidget(pause_);
  layout->addLayout(row);
  setSizePolicy(QSizePolicy::Preferred, QSizePolicy::Maximum);

  connect(speed_, QOverload<int>::of(&QComboBox::currentIndexChanged), this,
          [this] { workspace_->SetReplaySpeed(speed()); });
  connect(pause_, &QPushButton::toggled, workspace_, &Workspace::SetReplayPaused);
  connect(slider_, &QSlider::sliderPressed, this, [this] { dragging_ = true; });
  connect(slider_, &QSlider::sliderReleased, this, [this] {
    dragging_ = false;
    workspace_->SeekReplay(length_s_ * slider_->value() / 1000.0);
  });
  connect(workspace_, &Workspace::replayProgress, this, [this](double pos, double len) {
    length_s_ = len;
    slider_->setEnabled(len > 0);
    if (!dragging_ && len > 0) slider_->setValue(static_cast<int>(1000.0 * pos / len));
    position_->setText(QStringLiteral("%1 / %2 s").arg(pos, 0, 'f', 1).arg(len, 0, 'f', 1));
  });
  connect(workspace_, &Workspace::sessionChanged, this, [this](const QString& dir) {
    session_->setText(dir.isEmpty() ? tr("No session") : QFileInfo(dir).fileName());
    session_->setToolTip(dir);
    if (!workspace_->replaying()) slider_->setEnabled(false);
  });
}

double ReplayPanel::speed() const { return speed_->currentData().toDouble(); }

void ReplayPanel::SetSpeed(double s) {
  const int i = speed_->findData(s);
  if (i >= 0) speed_->setCurrentIndex(i);
}

}  // namespace sweepscan::ui
