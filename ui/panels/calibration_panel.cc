#include "ui/panels/calibration_panel.h"

#include <QCheckBox>
#include <QFileDialog>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QPainter>
#include <QPainterPath>
#include <QPushButton>
#include <QTableWidget>
#include <QUndoCommand>
#include <QUndoStack>
#include <QVBoxLayout>
#include <algorithm>
#include <cmath>
#include <fstream>

#include "core/calibration/calibration_file.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {

// The solver's cost per LM iteration on a log scale (the paper's Fig. 8).
class CostPlot : public QWidget {
 public:
  CostPlot() { setMinimumHeight(90); }
  void Clear() {
    costs_.clear();
    update();
  }
  void Add(int iteration, double cost) {
    if (iteration == 0) costs_.clear();
    costs_.push_back(std::max(cost, 1e-30));
    update();
  }

 protected:
  void paintEvent(QPaintEvent*) override {
    QPainter p(this);
    p.setRenderHint(QPainter::Antialiasing);
    p.fillRect(rect(), palette().base());
    p.setPen(palette().mid().color());
    p.drawRect(rect().adjusted(0, 0, -1, -1));
    p.setPen(palette().text().color());
    if (costs_.size() < 2) {
      p.drawText(rect(), Qt::AlignCenter, tr("cost per iteration"));
      return;
    }
    double lo = std::log10(*std::min_element(costs_.begin(), costs_.end()));
    double hi = std::log10(*std::max_element(costs_.begin(), costs_.end()));
    if (hi - lo < 1e-9) hi = lo + 1.0;
    const QRectF r = QRectF(rect()).adjusted(8, 16, -8, -8);
    QPainterPath path;
    for (size_t i = 0; i < costs_.size(); ++i) {
      const double x = r.left() + r.width() * i / (costs_.size() - 1);
      const double y = r.bottom() - r.height() * (std::log10(costs_[i]) - lo) / (hi - lo);
      if (i == 0)
        path.moveTo(x, y);
      else
        path.lineTo(x, y);
    }
    p.setPen(QPen(QColor(30, 136, 229), 2));
    p.drawPath(path);
    p.setPen(palette().text().color());
    p.drawText(rect().adjusted(4, 2, -4, 0), Qt::AlignTop | Qt::AlignLeft,
               tr("cost %1 -> %2 (%3 iterations, log scale)")
                   .arg(costs_.front(), 0, 'g', 3)
                   .arg(costs_.back(), 0, 'g', 3)
                   .arg(costs_.size() - 1));
  }

 private:
  std::vector<double> costs_;
};

namespace {

const QColor kColorA(0, 200, 255);
const QColor kColorB(255, 60, 200);

// Every edit of the pair list is one snapshot swap: simple and exact.
class PairsCommand : public QUndoCommand {
 public:
  PairsCommand(CalibrationPanel* panel, std::vector<CalibrationPanel::PairPoints> after,
               const QString& text)
      : panel_(panel), before_(panel->pair_points()), after_(std::move(after)) {
    setText(text);
  }
  void redo() override { panel_->SetPairs(after_); }
  void undo() override { panel_->SetPairs(before_); }

 private:
  CalibrationPanel* panel_;
  std::vector<CalibrationPanel::PairPoints> before_, after_;
};

QString Xyz(const Eigen::Vector3d& p) {
  return QStringLiteral("%1, %2, %3")
      .arg(p.x(), 0, 'f', 3)
      .arg(p.y(), 0, 'f', 3)
      .arg(p.z(), 0, 'f', 3);
}

}  // namespace

CalibrationPanel::CalibrationPanel(Workspace* workspace, CloudView* view, QUndoStack* undo,
                                   QWidget* parent)
    : QWidget(parent), workspace_(workspace), view_(view), undo_(undo) {
  auto* layout = new QVBoxLayout(this);

  auto* target = new QLabel(
      tr("<b>1. Target and drive.</b> Mount a thin board (0.6 m, 5 mm) turned 45° like a "
         "diamond, 1-2 m beside the circle, and drive two turns at 0.05 m/s (Drive panel, "
         "Calibration circle) while recording. Open the recording."));
  target->setWordWrap(true);
  layout->addWidget(target);
  auto* drive = new QPushButton(tr("Record a calibration drive"));
  drive->setToolTip(
      tr("Starts recording and a 1 m circle at 0.05 m/s, two turns (the Drive "
         "panel's scripted circle); Robot > Stop Recording when it ends, then open "
         "the recording"));
  connect(drive, &QPushButton::clicked, this, [this] {
    QString error;
    if (!workspace_->recording() && !workspace_->StartRecording(&error)) {
      result_->setText(error);
      return;
    }
    workspace_->StartScriptedDrive(Workspace::CirclePath(1.0, 0.05, 2.0));
  });
  layout->addWidget(drive);

  auto* picking = new QGroupBox(tr("2. Pick pairs"));
  auto* pick_layout = new QVBoxLayout(picking);
  next_pick_ = new QLabel;
  next_pick_->setWordWrap(true);
  pick_layout->addWidget(next_pick_);
  table_ = new QTableWidget(0, 2);
  table_->setHorizontalHeaderLabels({tr("pass A (m)"), tr("pass B (m)")});
  table_->horizontalHeader()->setSectionResizeMode(QHeaderView::Stretch);
  table_->setSelectionBehavior(QAbstractItemView::SelectRows);
  table_->setSelectionMode(QAbstractItemView::SingleSelection);
  table_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  table_->setMinimumHeight(120);
  pick_layout->addWidget(table_);
  auto* row = new QHBoxLayout;
  auto* remove = new QPushButton(tr("Delete"));
  auto* load = new QPushButton(tr("Load…"));
  auto* save = new QPushButton(tr("Save…"));
  row->addWidget(remove);
  row->addWidget(load);
  row->addWidget(save);
  pick_layout->addLayout(row);
  layout->addWidget(picking);

  auto* solving = new QGroupBox(tr("3. Solve"));
  auto* solve_layout = new QVBoxLayout(solving);
  refine_ = new QCheckBox(tr("Snap picks to the fitted board corners (refine)"));
  refine_->setChecked(true);
  solve_layout->addWidget(refine_);
  solve_ = new QPushButton(tr("Solve"));
  solve_layout->addWidget(solve_);
  result_ = new QLabel;
  result_->setObjectName(QStringLiteral("calibrationResult"));
  result_->setWordWrap(true);
  result_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  solve_layout->addWidget(result_);
  plot_ = new CostPlot;
  solve_layout->addWidget(plot_);
  layout->addWidget(solving);

  auto* applying = new QGroupBox(tr("4. Check and keep"));
  auto* apply_layout = new QHBoxLayout(applying);
  after_ = new QPushButton(tr("Show calibrated"));
  after_->setCheckable(true);
  save_calibration_ = new QPushButton(tr("Save calibration…"));
  apply_layout->addWidget(after_);
  apply_layout->addWidget(save_calibration_);
  use_for_robot_ = new QPushButton(tr("Use for this robot"));
  use_for_robot_->setToolTip(
      tr("Live scans and every new recording use these angles (kept in the settings)"));
  apply_layout->addWidget(use_for_robot_);
  layout->addWidget(applying);
  layout->addStretch(1);

  connect(view_, &CloudView::pointPicked, this, &CalibrationPanel::AddPick);
  connect(table_, &QTableWidget::itemSelectionChanged, this, &CalibrationPanel::Refresh);
  connect(remove, &QPushButton::clicked, this, [this] {
    const int r = table_->currentRow();
    if (r >= 0) DeletePair(r);
  });
  connect(save, &QPushButton::clicked, this, [this] {
    const QString path =
        QFileDialog::getSaveFileName(this, tr("Save pairs"), QString(), tr("Pairs (*.json)"));
    QString error;
    if (!path.isEmpty() && !SavePairs(path, &error)) result_->setText(error);
  });
  connect(load, &QPushButton::clicked, this, [this] {
    const QString path =
        QFileDialog::getOpenFileName(this, tr("Load pairs"), QString(), tr("Pairs (*.json)"));
    QString error;
    if (!path.isEmpty() && !LoadPairs(path, &error)) result_->setText(error);
  });
  connect(solve_, &QPushButton::clicked, this, &CalibrationPanel::Solve);
  connect(after_, &QPushButton::toggled, this, &CalibrationPanel::ShowAfter);
  connect(save_calibration_, &QPushButton::clicked, this, [this] {
    const QString path = QFileDialog::getSaveFileName(this, tr("Save calibration"), QString(),
                                                      tr("Calibration (*.json)"));
    QString error;
    if (!path.isEmpty() && !SaveCalibration(path, &error)) result_->setText(error);
  });
  connect(use_for_robot_, &QPushButton::clicked, this, &CalibrationPanel::UseForRobot);
  connect(workspace_, &Workspace::calibrationIteration, this,
          [this](int i, double cost) { plot_->Add(i, cost); });
  connect(workspace_, &Workspace::calibrationFinished, this, &CalibrationPanel::ShowResult);
  connect(workspace_, &Workspace::sessionChanged, this, [this] {
    after_->setChecked(false);
    Refresh();
  });
  Refresh();
}

void CalibrationPanel::AddPick(const Eigen::Vector3d& world) {
  std::vector<PairPoints> next = pairs_;
  if (!next.empty() && !next.back().has_b) {
    next.back().b = world;
    next.back().has_b = true;
    undo_->push(new PairsCommand(this, next, tr("pick B")));
  } else {
    PairPoints p;
    p.a = world;
    next.push_back(p);
    undo_->push(new PairsCommand(this, next, tr("pick A")));
  }
}

void CalibrationPanel::DeletePair(int index) {
  if (index < 0 || index >= pair_count()) return;
  std::vector<PairPoints> next = pairs_;
  next.erase(next.begin() + index);
  undo_->push(new PairsCommand(this, next, tr("delete pair")));
}

void CalibrationPanel::SetPairs(const std::vector<PairPoints>& pairs) {
  pairs_ = pairs;
  Refresh();
}

std::vector<PickPair> CalibrationPanel::pairs() const {
  std::vector<PickPair> out;
  for (const PairPoints& p : pairs_) {
    if (!p.has_b) continue;
    PickPair pair;
    pair.pass1.world = p.a;
    pair.pass2.world = p.b;
    out.push_back(pair);
  }
  return out;
}

bool CalibrationPanel::SavePairs(const QString& path, QString* error) const {
  std::ofstream out(path.toStdString());
  out << PairsToJson(pairs());
  out.close();
  if (!out) {
    *error = tr("%1: cannot write the pairs file").arg(path);
    return false;
  }
  return true;
}

bool CalibrationPanel::LoadPairs(const QString& path, QString* error) {
  std::vector<PickPair> loaded;
  const Status s = LoadPairsFile(path.toStdString(), &loaded);
  if (!s.ok()) {
    *error = QString::fromStdString(s.message());
    return false;
  }
  std::vector<PairPoints> next;
  for (const PickPair& p : loaded) {
    if (p.pass1.has_sample || p.pass2.has_sample) {
      *error =
          tr("%1: picks by (scan, beam) are for the CLI; the panel takes world picks").arg(path);
      return false;
    }
    PairPoints q;
    q.a = p.pass1.world;
    q.b = p.pass2.world;
    q.has_b = true;
    next.push_back(q);
  }
  undo_->push(new PairsCommand(this, next, tr("load pairs")));
  return true;
}

void CalibrationPanel::SetRefine(bool refine) { refine_->setChecked(refine); }

void CalibrationPanel::Solve() {
  const std::vector<PickPair> p = pairs();
  if (p.size() < 4) {
    ShowResult(false, tr("Pick at least four pairs (%1 so far).").arg(p.size()));
    return;
  }
  plot_->Clear();
  solve_->setEnabled(false);
  result_->setText(tr("Solving…"));
  workspace_->Calibrate(p, refine_->isChecked());
}

void CalibrationPanel::ShowResult(bool ok, const QString& message) {
  solve_->setEnabled(true);
  const PickCalibrationResult* r = workspace_->calibration_result();
  if (!ok || r == nullptr) {
    result_->setText(
        tr("<b style='color:#c62828'>Not solved:</b> %1").arg(message.toHtmlEscaped()));
    emit solved(false);
    Refresh();
    return;
  }
  const CalibrationSummary& s = r->summary;
  auto angle = [](double v, double sigma) {
    return sigma >= 0
               ? QStringLiteral("%1 ± %2").arg(v * 1e3, 0, 'f', 2).arg(sigma * 1e3, 0, 'f', 2)
               : QStringLiteral("%1").arg(v * 1e3, 0, 'f', 2);
  };
  QString text = tr("<b>%1</b> (%2)<br>alpha %3 mrad<br>beta %4 mrad<br>gamma %5 mrad<br>"
                    "pair distance (the ghost): %6 mm -> %7 mm, %8 pairs, %9 sightings")
                     .arg(s.converged ? tr("Converged") : tr("Not converged"))
                     .arg(QString::fromStdString(s.method))
                     .arg(angle(s.angles.alpha, s.sigma_rad[0]))
                     .arg(angle(s.angles.beta, s.sigma_rad[1]))
                     .arg(angle(s.angles.gamma, s.sigma_rad[2]))
                     .arg(s.initial_rms_m * 1e3, 0, 'f', 1)
                     .arg(s.final_rms_m * 1e3, 0, 'f', 2)
                     .arg(s.residual_blocks)
                     .arg(static_cast<int>(r->sightings.windows.size()));
  if (r->has_baseline) {
    text += tr("<br>raw picks alone (the paper's method): %1 mm -> %2 mm")
                .arg(r->baseline.initial_rms_m * 1e3, 0, 'f', 1)
                .arg(r->baseline.final_rms_m * 1e3, 0, 'f', 1);
  }
  for (const std::string& w : s.warnings)
    text += tr("<br>warning: %1").arg(QString::fromStdString(w));
  result_->setText(text);
  emit solved(s.converged);
  Refresh();
}

void CalibrationPanel::ShowAfter(bool after) {
  const PickCalibrationResult* r = workspace_->calibration_result();
  if (after && r == nullptr) {
    after_->setChecked(false);
    return;
  }
  if (after_->isChecked() != after) after_->setChecked(after);  // Re-enters with the same value.
  workspace_->ShowCalibrated(after ? r->summary.angles : MountingError());
  after_->setText(after ? tr("Showing calibrated") : tr("Show calibrated"));
}

bool CalibrationPanel::SaveCalibration(const QString& path, QString* error) const {
  const PickCalibrationResult* r = workspace_->calibration_result();
  if (r == nullptr) {
    *error = tr("Solve first.");
    return false;
  }
  const Status s = SaveCalibrationFile(path.toStdString(), r->summary.angles, &r->summary);
  if (!s.ok()) {
    *error = QString::fromStdString(s.message());
    return false;
  }
  return true;
}

void CalibrationPanel::UseForRobot() {
  const PickCalibrationResult* r = workspace_->calibration_result();
  if (r == nullptr) return;
  workspace_->SetRobotCalibration(r->summary.angles);
  emit robotCalibrationChanged(r->summary.angles);
}

QString CalibrationPanel::result_text() const { return result_->text(); }

void CalibrationPanel::Refresh() {
  table_->blockSignals(true);
  const int selected = table_->currentRow();
  table_->setRowCount(static_cast<int>(pairs_.size()));
  for (size_t i = 0; i < pairs_.size(); ++i) {
    table_->setItem(static_cast<int>(i), 0, new QTableWidgetItem(Xyz(pairs_[i].a)));
    table_->setItem(static_cast<int>(i), 1,
                    new QTableWidgetItem(pairs_[i].has_b ? Xyz(pairs_[i].b) : tr("(pick B)")));
  }
  if (selected >= 0 && selected < table_->rowCount()) table_->selectRow(selected);
  table_->blockSignals(false);

  std::vector<CloudView::Marker> markers;
  const int highlight = table_->currentRow();
  for (size_t i = 0; i < pairs_.size(); ++i) {
    const bool h = static_cast<int>(i) == highlight;
    markers.push_back({pairs_[i].a, kColorA, h});
    if (pairs_[i].has_b) markers.push_back({pairs_[i].b, kColorB, h});
  }
  view_->SetMarkers(markers);

  const bool open_b = !pairs_.empty() && !pairs_.back().has_b;
  next_pick_->setText(
      open_b ? tr("Shift + click the <b style='color:#ff3cc8'>same corner in pass B</b>.")
             : tr("Shift + click a target corner in <b style='color:#00b4e6'>pass A</b> "
                  "(%1 complete pairs; at least 4).")
                   .arg(pairs().size()));
  solve_->setEnabled(pairs().size() >= 4 && workspace_->recording_opened() != nullptr);
  const bool have = workspace_->calibration_result() != nullptr;
  after_->setEnabled(have);
  save_calibration_->setEnabled(have);
  use_for_robot_->setEnabled(have);
}

}  // namespace sweepscan::ui
