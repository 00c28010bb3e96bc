#include "ui/panels/calibration_panel.h"

#include <QCheckBox>
#include <QDoubleSpinBox>
#include <QFileInfo>
#include <QGridLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QPainter>
#include <QPainterPath>
#include <QPushButton>
#include <QScrollArea>
#include <QSettings>
#include <QSignalBlocker>
#include <QTableWidget>
#include <QTimer>
#include <QUndoCommand>
#include <QUndoStack>
#include <QVBoxLayout>
#include <algorithm>
#include <cmath>

#include "ui/panels/calibration_result_text.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {

// The solver's cost per LM iteration on a log scale (the paper's Fig. 8).
class CostPlot : public QWidget {
 public:
  CostPlot() {
    setMinimumHeight(90);
    setToolTip(
        tr("The solver's cost per Levenberg-Marquardt iteration over the whole solve: half "
           "the sum of the squared residuals (pairs and corners: their gaps in metres; "
           "automatic: each point's distance to its plane over its noise, robust). It is "
           "not the RMS in mm above it."));
  }
  void Clear() {
    costs_.clear();
    update();
  }
  // One iteration of the solve under way (StartSolving clears the plot).
  // The automatic mode's rounds and the refined corners' each run an inner
  // solve whose iterations count from 0 again; they are drawn on after the
  // ones before, as CalibrationSummary::trace numbers them, so the live
  // plot grows into the final one instead of starting over each round.
  void Add(double cost) {
    costs_.push_back(std::max(cost, 1e-30));
    update();
  }
  // The whole solve whose result is shown (CalibrationSummary::trace: every
  // inner solve of the automatic mode's rounds and of the refined corners,
  // numbered on). The last round alone starts near the answer and barely
  // moves, which beside the RMS's drop over the whole solve read as a
  // contradiction ("-0.16 %" beside "60 mm -> 5.8 mm").
  void Set(const std::vector<CalibrationIteration>& trace) {
    costs_.clear();
    for (const CalibrationIteration& it : trace) costs_.push_back(std::max(it.cost, 1e-30));
    update();
  }
  // "solver cost 1.44e+06 -> 4.05e+04, 53 iterations, log scale": the solver's
  // own objective (half the sum of the squared residuals, weighted and
  // robust in the automatic mode; not the RMS in mm above it) at the start
  // and the end of the solve. No percentage: the relative change of such a
  // sum is nothing an operator can set beside the RMS.
  QString Caption() const {
    if (costs_.size() < 2) return QString();
    const double first = costs_.front(), last = costs_.back();
    const double change = std::abs(last - first) / first;
    // Enough digits that the two ends differ where the costs do.
    const int digits = change >= 0.01 ? 3 : change >= 1e-4 ? 6 : 9;
    return tr("solver cost %1 -> %2, %3 iterations, log scale")
        .arg(first, 0, 'g', digits)
        .arg(last, 0, 'g', digits)
        .arg(costs_.size() - 1);
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
    const double hi = std::log10(*std::max_element(costs_.begin(), costs_.end()));
    // At least a decade high: a solve that barely moves the cost (it started
    // near the answer) draws a nearly flat line, not a full-height drop.
    lo = std::min(lo, hi - 1.0);
    // Below the caption's line: a flat cost (a solve that starts near the
    // answer) was drawn through the caption's text.
    const QRectF r = QRectF(rect()).adjusted(8, fontMetrics().height() + 8, -8, -8);
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
    p.drawText(rect().adjusted(4, 2, -4, 0), Qt::AlignTop | Qt::AlignLeft, Caption());
  }

 private:
  std::vector<double> costs_;
};

namespace {

QString PassesIntro() {
  return QObject::tr("Open a calibration drive: its two passes are split automatically.");
}

const QColor kColorA(0, 200, 255);
const QColor kColorB(255, 60, 200);
// Fitted corners: pale versions of the pass colours.
const QColor kCornerA(200, 255, 120);
const QColor kCornerB(255, 214, 0);

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
      .arg(p.x(), 0, 'f', 2)
      .arg(p.y(), 0, 'f', 2)
      .arg(p.z(), 0, 'f', 2);
}

}  // namespace

CalibrationPanel::CalibrationPanel(Workspace* workspace, CloudView* view, QUndoStack* undo,
                                   QWidget* parent)
    : QWidget(parent), workspace_(workspace), view_(view), undo_(undo) {
  auto* layout = new QVBoxLayout(this);
  layout->addWidget(BuildTargetStep());
  layout->addWidget(BuildPassesStep());
  layout->addWidget(BuildPickStep());
  layout->addWidget(BuildSolveStep());
  layout->addWidget(BuildKeepStep());
  layout->addStretch(1);

  connect(workspace_, &Workspace::calibrationIteration, this,
          [this](int, double cost) { plot_->Add(cost); });
  connect(workspace_, &Workspace::calibrationFinished, this, &CalibrationPanel::ShowResult);
  connect(workspace_, &Workspace::passesSplit, this, &CalibrationPanel::OnPassesSplit);
  connect(workspace_, &Workspace::sessionChanged, this, [this](const QString& dir) {
    {
      // Not ShowAfter(false): the new session replays under its own
      // calibration already.
      const QSignalBlocker block(after_);
      after_->setChecked(false);
      after_->setText(tr("Show calibrated"));
    }
    // The result was the previous session's (the workspace has let it go).
    solving_ = false;
    result_->clear();
    plot_->Clear();
    pass_shown_ = -1;
    // Picks are points of one session's cloud: another session's pairs (and
    // their undo history) would pair points of a cloud no longer shown. The
    // same session opened again keeps them; New Session ("") always starts
    // a new live cloud.
    if (dir != pairs_session_ || dir.isEmpty()) {
      if (!pairs_.empty()) {
        const QString where =
            pairs_session_.isEmpty() ? tr("the live cloud") : QFileInfo(pairs_session_).fileName();
        dropped_note_ =
            pairs_.size() == 1
                ? tr("Another session opened: the pair picked in %1 was cleared (the pairs' "
                     "Save… keeps pairs in a file).")
                      .arg(where)
                : tr("Another session opened: the %1 pairs picked in %2 were cleared (the "
                     "pairs' Save… keeps pairs in a file).")
                      .arg(pairs_.size())
                      .arg(where);
      }
      pairs_.clear();
      undo_->clear();
      pairs_session_ = dir;
    }
    if (workspace_->recording_opened() == nullptr) {
      passes_->setText(PassesIntro());
    } else {
      passes_->setText(
          workspace_->circle_drive()
              ? tr("Opened %1; splitting the passes when it has replayed.")
                    .arg(workspace_->circle_drive_note())
              : tr("Not a calibration drive: %1").arg(workspace_->circle_drive_note()));
    }
    Refresh();
  });
  // Once every panel has seen the new session (the evaluation panel gives
  // the view back the colouring it had before its deviations, perhaps the
  // passes): a cloud without pass labels is not left grey under the pass
  // legend that this panel chose for the previous one.
  connect(workspace_, &Workspace::sessionChanged, this, &CalibrationPanel::RestoreColorMode,
          Qt::QueuedConnection);
  // The operator's own colouring since the passes were shown is kept.
  connect(view_, &CloudView::colorModeChanged, this, [this](int mode) {
    const auto m = static_cast<CloudView::ColorMode>(mode);
    if (m != CloudView::ColorMode::kPass && m != CloudView::ColorMode::kDeviation) {
      passes_colored_ = false;
    }
  });
  connect(workspace_, &Workspace::recordingChanged, this, [this] { Refresh(); });
  // Show calibrated may need a job (the session read again, SfM's poses):
  // refused while another task runs, cancelled or failed, the cloud stays
  // as it was, and the button must say so (it stayed down, "Showing
  // calibrated", over the uncalibrated cloud).
  connect(workspace_, &Workspace::jobFinished, this, [this] {
    if (!workspace_->job_running()) SyncAfter();
  });
  connect(workspace_, &Workspace::sessionRenamed, this,
          [this](const QString& dir) { pairs_session_ = dir; });
  // The passes are split once the opened circle drive has replayed; after a
  // before / after replay the same labels are given to the new cloud.
  connect(workspace_, &Workspace::replayFinished, this, [this] {
    if (!workspace_->circle_drive()) return;
    if (workspace_->pass_labels().empty()) {
      if (!workspace_->job_running()) workspace_->SplitPasses();
    } else {
      ApplyPassLabels();
    }
  });
  Refresh();
}

QWidget* CalibrationPanel::BuildTargetStep() {
  auto* box = new QGroupBox(tr("1. Target and drive"));
  auto* layout = new QVBoxLayout(box);
  auto* target = new QLabel(
      tr("Mount a thin board (0.6 m, 5 mm) turned 45° like a diamond, 1-2 m beside the "
         "circle, its face towards the circle's centre. Then record three turns of a 1 m circle "
         "at 0.05 m/s (about 6 minutes) and open the recording."));
  target->setWordWrap(true);
  layout->addWidget(target);
  auto* drive = new QPushButton(tr("Record a calibration drive"));
  drive->setToolTip(
      tr("Starts recording and a 1 m circle at 0.05 m/s, three turns (the Drive "
         "panel's scripted circle); Robot > Stop Recording when it ends, then open "
         "the recording"));
  connect(drive, &QPushButton::clicked, this, [this] {
    QString error;
    if (!workspace_->recording() && !workspace_->StartRecording(&error)) {
      result_->setText(error);
      return;
    }
    // Three turns: six sightings of the target and of every wall instead of
    // four average the heading's and the board fit's noise (docs/results.md,
    // "Robustness": the worst angles of 120 automatic and 60 refined drives).
    workspace_->StartScriptedDrive(Workspace::CirclePath(1.0, 0.05, 3.0),
                                   tr("the calibration circle"));
  });
  layout->addWidget(drive);
  return box;
}

QWidget* CalibrationPanel::BuildPassesStep() {
  auto* box = new QGroupBox(tr("2. The two passes"));
  auto* layout = new QVBoxLayout(box);
  passes_ = new QLabel(PassesIntro());
  passes_->setWordWrap(true);
  layout->addWidget(passes_);
  auto* row = new QHBoxLayout;
  const QString names[3] = {tr("Both"), tr("Pass A"), tr("Pass B")};
  const QString tips[3] = {tr("Both passes: the ghost is the two sightings of the target"),
                           tr("Only pass A (near side, cyan): pick here first"),
                           tr("Only pass B (far side, magenta): pick the same corner here")};
  for (int k = 0; k < 3; ++k) {
    pass_buttons_[k] = new QPushButton(names[k]);
    pass_buttons_[k]->setCheckable(true);
    pass_buttons_[k]->setAutoExclusive(true);
    pass_buttons_[k]->setToolTip(tips[k]);
    row->addWidget(pass_buttons_[k]);
    connect(pass_buttons_[k], &QPushButton::clicked, this, [this, k] { ShowPass(k - 1); });
  }
  pass_buttons_[0]->setChecked(true);
  split_ = new QPushButton(tr("Split"));
  split_->setToolTip(tr("Split the cloud shown into the circle drive's two passes again"));
  connect(split_, &QPushButton::clicked, workspace_, &Workspace::SplitPasses);
  row->addWidget(split_);
  layout->addLayout(row);
  return box;
}

QWidget* CalibrationPanel::BuildPickStep() {
  auto* box = new QGroupBox(tr("3. Pick pairs"));
  auto* layout = new QVBoxLayout(box);
  next_pick_ = new QLabel;
  next_pick_->setWordWrap(true);
  layout->addWidget(next_pick_);
  table_ = new QTableWidget(0, 3);
  table_->setHorizontalHeaderLabels({tr("pass A (m)"), tr("pass B (m)"), tr("gap (mm)")});
  table_->horizontalHeader()->setSectionResizeMode(QHeaderView::Stretch);
  table_->horizontalHeader()->setSectionResizeMode(2, QHeaderView::ResizeToContents);
  table_->setSelectionBehavior(QAbstractItemView::SelectRows);
  table_->setSelectionMode(QAbstractItemView::SingleSelection);
  table_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  table_->setMinimumHeight(120);
  layout->addWidget(table_);
  auto* row = new QHBoxLayout;
  auto* remove = delete_pair_ = new QPushButton(tr("Delete"));
  remove->setObjectName(QStringLiteral("deletePair"));
  remove->setShortcut(QKeySequence::Delete);
  auto* load = new QPushButton(tr("Load…"));
  load->setObjectName(QStringLiteral("loadPairs"));
  auto* save = save_pairs_ = new QPushButton(tr("Save…"));
  save->setObjectName(QStringLiteral("savePairs"));
  row->addWidget(remove);
  row->addWidget(load);
  row->addWidget(save);
  layout->addLayout(row);
  connect(table_, &QTableWidget::itemSelectionChanged, this, &CalibrationPanel::Refresh);
  connect(remove, &QPushButton::clicked, this, [this] {
    const int r = table_->currentRow();
    if (r >= 0) DeletePair(r);
  });
  connect(save, &QPushButton::clicked, this, [this] {
    ChooseFileAnd(
        true, tr("Save pairs"), QStringLiteral("pairs"), tr("Pairs (*.json)"),
        [this](const QString& path, QString* error) { return SavePairs(path, error); },
        [this](const QString& path) {
          // A pick waiting for its partner is no pair: said, not silently left out.
          const int saved = static_cast<int>(pairs().size());
          return saved == pair_count()
                     ? tr("Saved %n pair(s) to %1", nullptr, saved).arg(path)
                     : tr("Saved %n pair(s) to %1; the unfinished pair is not saved", nullptr,
                          saved)
                           .arg(path);
        });
  });
  connect(load, &QPushButton::clicked, this, [this] {
    ChooseFileAnd(
        false, tr("Load pairs"), QStringLiteral("pairs"), tr("Pairs (*.json)"),
        [this](const QString& path, QString* error) { return LoadPairs(path, error); },
        [this](const QString& path) {
          return tr("Loaded %n pair(s) from %1", nullptr, static_cast<int>(pairs().size()))
              .arg(path);
        });
  });
  return box;
}

QWidget* CalibrationPanel::BuildSolveStep() {
  auto* box = new QGroupBox(tr("4. Solve"));
  auto* layout = new QVBoxLayout(box);
  refine_ = new QCheckBox(tr("Snap picks to the fitted board corners (refine)"));
  refine_->setChecked(true);
  layout->addWidget(refine_);
  // The board's thickness: beams passing its bottom edges hit their edge
  // faces, which the board fit takes out (docs/calibration.md, "The target").
  auto* thickness_row = new QHBoxLayout;
  auto* thickness_label = new QLabel(tr("Board thickness:"));
  thickness_ = new QDoubleSpinBox;
  thickness_->setObjectName(QStringLiteral("boardThickness"));
  thickness_->setRange(0.0, 50.0);
  thickness_->setDecimals(1);
  thickness_->setSingleStep(0.5);
  thickness_->setSuffix(tr(" mm"));
  thickness_->setToolTip(
      tr("The target board's thickness (0 for a sheet). Beams that pass its bottom edges hit "
         "their edge faces; the refined fit takes that out."));
  thickness_->setValue(
      QSettings().value(QStringLiteral("calibration/board_thickness_mm"), 5.0).toDouble());
  thickness_label->setBuddy(thickness_);
  thickness_row->addWidget(thickness_label);
  thickness_row->addWidget(thickness_);
  thickness_row->addStretch(1);
  layout->addLayout(thickness_row);
  connect(refine_, &QCheckBox::toggled, thickness_, &QWidget::setEnabled);
  connect(thickness_, QOverload<double>::of(&QDoubleSpinBox::valueChanged), this, [](double mm) {
    QSettings().setValue(QStringLiteral("calibration/board_thickness_mm"), mm);
  });
  // The board reads alpha + beta loosely; the room's planes, from the same
  // drive, pin it (docs/calibration.md, "The board and the room's planes
  // together"). Each part alone is shown beside the result.
  combine_ = new QCheckBox(tr("Combine with the room's planes"));
  combine_->setObjectName(QStringLiteral("combineWithPlanes"));
  combine_->setToolTip(
      tr("Weigh the board's angles with the automatic mode's on the same drive by their "
         "uncertainties, unless the two disagree beyond chance. Off: the board's angles alone."));
  combine_->setChecked(
      QSettings().value(QStringLiteral("calibration/combine_with_planes"), true).toBool());
  layout->addWidget(combine_);
  connect(refine_, &QCheckBox::toggled, combine_, &QWidget::setEnabled);
  connect(combine_, &QCheckBox::toggled, this, [](bool on) {
    QSettings().setValue(QStringLiteral("calibration/combine_with_planes"), on);
  });
  auto* row = new QHBoxLayout;
  solve_ = new QPushButton(tr("Solve"));
  solve_->setToolTip(tr("Levenberg-Marquardt on the picked pairs (Miao et al. Eq. 15-17)"));
  auto_ = new QPushButton(tr("Automatic"));
  auto_->setToolTip(
      tr("No picks: the floor, ceiling, walls and board seen in both passes are made to "
         "agree (sweepscan-cli calibrate --auto)"));
  cancel_ = new QPushButton(tr("Cancel"));
  row->addWidget(solve_);
  row->addWidget(auto_);
  row->addWidget(cancel_);
  layout->addLayout(row);
  result_ = new QLabel;
  result_->setObjectName(QStringLiteral("calibrationResult"));
  result_->setWordWrap(true);
  result_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  layout->addWidget(result_);
  plot_ = new CostPlot;
  layout->addWidget(plot_);
  connect(solve_, &QPushButton::clicked, this, &CalibrationPanel::Solve);
  connect(auto_, &QPushButton::clicked, this, &CalibrationPanel::SolveAutomatic);
  connect(cancel_, &QPushButton::clicked, this, &CalibrationPanel::CancelSolve);
  return box;
}

QWidget* CalibrationPanel::BuildKeepStep() {
  auto* box = new QGroupBox(tr("5. Check and keep"));
  auto* layout = new QGridLayout(box);
  after_ = new QPushButton(tr("Show calibrated"));
  after_->setCheckable(true);
  after_->setToolTip(tr("Re-assemble the session from its records under the solved angles"));
  save_calibration_ = new QPushButton(tr("Save…"));
  save_calibration_->setToolTip(tr("Save the calibration file (sweepscan-cli reads it too)"));
  auto* load_calibration = new QPushButton(tr("Load…"));
  load_calibration->setToolTip(tr("Load a calibration file as the result"));
  use_for_robot_ = new QPushButton(tr("Use for this robot"));
  use_for_robot_->setToolTip(
      tr("Live scans and every new recording use these angles (kept in the settings)"));
  layout->addWidget(after_, 0, 0);
  layout->addWidget(use_for_robot_, 0, 1);
  layout->addWidget(save_calibration_, 1, 0);
  layout->addWidget(load_calibration, 1, 1);
  connect(after_, &QPushButton::toggled, this, &CalibrationPanel::ShowAfter);
  connect(save_calibration_, &QPushButton::clicked, this, [this] {
    ChooseFileAnd(
        true, tr("Save calibration"), QStringLiteral("calibration"), tr("Calibration (*.json)"),
        [this](const QString& path, QString* error) { return SaveCalibration(path, error); },
        [this](const QString& path) { return tr("Saved the calibration to %1").arg(path); });
  });
  connect(load_calibration, &QPushButton::clicked, this, [this] {
    ChooseFileAnd(
        false, tr("Load calibration"), QStringLiteral("calibration"), tr("Calibration (*.json)"),
        [this](const QString& path, QString* error) { return LoadCalibration(path, error); },
        [](const QString&) { return QString(); });
  });
  connect(use_for_robot_, &QPushButton::clicked, this, &CalibrationPanel::UseForRobot);
  return box;
}

void CalibrationPanel::ShowPass(int pass) {
  pass_shown_ = pass < 0 || pass > 1 ? -1 : pass;
  pass_buttons_[pass_shown_ + 1]->setChecked(true);
  if (view_->has_point_values(CloudView::ColorMode::kPass)) view_->SetPassFilter(pass_shown_);
  Refresh();
}

void CalibrationPanel::OnPassesSplit(bool ok, const QString& message) {
  if (!ok) {
    passes_->setText(tr("<b style='color:#c62828'>Passes not split:</b> %1")
                         .arg(message.toHtmlEscaped()));
    return;
  }
  passes_->setText(tr("<span style='color:#00b4e6'>■</span> %1 "
                      "<span style='color:#ff3cc8'>■</span>. Show one pass at a time to pick.")
                       .arg(message.toHtmlEscaped()));
  ApplyPassLabels();
}

void CalibrationPanel::ApplyPassLabels(int attempts_left) {
  const std::shared_ptr<const QuantizedValues> labels = workspace_->pass_values();
  if (labels == nullptr || labels->q.empty()) return;
  if (view_->point_count() < labels->q.size() && attempts_left > 0) {
    QTimer::singleShot(50, this, [this, attempts_left] { ApplyPassLabels(attempts_left - 1); });
    return;
  }
  view_->SetPointValues(CloudView::ColorMode::kPass, *labels);
  if (view_->color_mode() != CloudView::ColorMode::kPass) {
    color_before_passes_ = static_cast<int>(view_->color_mode());
  }
  view_->SetColorMode(CloudView::ColorMode::kPass);
  passes_colored_ = true;
  view_->SetPassFilter(pass_shown_);
  Refresh();
}

void CalibrationPanel::RestoreColorMode() {
  if (!passes_colored_ || workspace_->pass_values() != nullptr) return;
  passes_colored_ = false;
  if (view_->color_mode() != CloudView::ColorMode::kPass) return;
  // Height, time and range come with every point; the other colourings'
  // values belonged to the previous cloud.
  auto mode = static_cast<CloudView::ColorMode>(color_before_passes_);
  if (mode != CloudView::ColorMode::kTime && mode != CloudView::ColorMode::kRange) {
    mode = CloudView::ColorMode::kHeight;
  }
  view_->SetColorMode(mode);
}

void CalibrationPanel::AddPick(const Eigen::Vector3d& world) {
  // The pass a pick is in: the one shown (step 2's buttons); with both
  // shown, the side the pair lacks, A first.
  std::vector<PairPoints> next = pairs_;
  const bool open = !next.empty() && !next.back().complete();
  int pass = pass_shown_;
  if (pass < 0) pass = open && next.back().has_a ? 1 : 0;
  if (!open) next.emplace_back().has_a = false;
  // A second pick in the pass the open pair already has replaces its pick
  // there (a corner picked again), undoably.
  PairPoints& p = next.back();
  (pass == 0 ? p.a : p.b) = world;
  (pass == 0 ? p.has_a : p.has_b) = true;
  undo_->push(new PairsCommand(this, next, pass == 0 ? tr("pick A") : tr("pick B")));
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
    if (!p.complete()) continue;
    PickPair pair;
    pair.pass1.world = p.a;
    pair.pass2.world = p.b;
    out.push_back(pair);
  }
  return out;
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
          tr("%1: picks of raw samples (time_ns, or scan and beam) are for the CLI; the panel "
             "takes world picks").arg(path);
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

void CalibrationPanel::SetBoardThickness(double metres) { thickness_->setValue(metres * 1e3); }

double CalibrationPanel::board_thickness() const { return thickness_->value() * 1e-3; }

void CalibrationPanel::SetCombineWithPlanes(bool combine) { combine_->setChecked(combine); }

void CalibrationPanel::Solve() {
  const std::vector<PickPair> p = pairs();
  if (p.size() < 4) {
    ShowResult(false, tr("Pick at least four pairs (%1 so far).").arg(p.size()));
    return;
  }
  StartSolving();
  workspace_->Calibrate(p, refine_->isChecked(), board_thickness(), !combine_->isChecked());
}

void CalibrationPanel::SolveAutomatic() {
  StartSolving();
  workspace_->CalibrateAutomatic();
}

void CalibrationPanel::StartSolving() {
  plot_->Clear();
  solving_ = true;
  result_->setText(tr("Solving…"));
  Refresh();
}

void CalibrationPanel::CancelSolve() {
  if (solving_) workspace_->CancelJob();
}

void CalibrationPanel::ShowResult(bool ok, const QString& message) {
  solving_ = false;
  const PickCalibrationResult* r = workspace_->calibration_result();
  if (!ok || r == nullptr) {
    result_->setText(
        tr("<b style='color:#c62828'>Not solved:</b> %1").arg(message.toHtmlEscaped()));
    emit solved(false);
    Refresh();
    return;
  }
  const CalibrationSummary& s = r->summary;
  const QString text = CalibrationResultText(*r, message);
  result_->setText(text);
  plot_->Set(s.trace);  // the whole solve the figures above are of
  emit solved(s.converged);
  Refresh();
  // The result in sight when the panel scrolls.
  for (QWidget* w = parentWidget(); w != nullptr; w = w->parentWidget()) {
    if (auto* scroll = qobject_cast<QScrollArea*>(w)) {
      scroll->ensureWidgetVisible(plot_);
      break;
    }
  }
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

void CalibrationPanel::SyncAfter() {
  const PickCalibrationResult* r = workspace_->calibration_result();
  const MountingError& shown = workspace_->shown_calibration();
  const bool calibrated = r != nullptr && shown.alpha == r->summary.angles.alpha &&
                          shown.beta == r->summary.angles.beta &&
                          shown.gamma == r->summary.angles.gamma;
  const QSignalBlocker block(after_);
  after_->setChecked(calibrated);
  after_->setText(calibrated ? tr("Showing calibrated") : tr("Show calibrated"));
}

void CalibrationPanel::UseForRobot() {
  const PickCalibrationResult* r = workspace_->calibration_result();
  if (r == nullptr) return;
  workspace_->SetRobotCalibration(r->summary.angles);
  emit robotCalibrationChanged(r->summary.angles);
}

QString CalibrationPanel::result_text() const { return result_->text(); }

QString CalibrationPanel::cost_caption() const { return plot_->Caption(); }

QString CalibrationPanel::pick_prompt() const { return next_pick_->text(); }

void CalibrationPanel::Refresh() {
  const PickCalibrationResult* result = workspace_->calibration_result();
  // Per-pair distances belong to the picks they were solved from.
  const bool checks = result != nullptr && result->pair_checks.size() == pairs().size();
  table_->blockSignals(true);
  const int selected = table_->currentRow();
  table_->setRowCount(static_cast<int>(pairs_.size()));
  for (size_t i = 0; i < pairs_.size(); ++i) {
    const int row = static_cast<int>(i);
    table_->setItem(row, 0,
                    new QTableWidgetItem(pairs_[i].has_a ? Xyz(pairs_[i].a) : tr("(pick A)")));
    table_->setItem(row, 1,
                    new QTableWidgetItem(pairs_[i].has_b ? Xyz(pairs_[i].b) : tr("(pick B)")));
    QString gap = QStringLiteral("-");
    if (checks && pairs_[i].complete()) {
      const auto& c = result->pair_checks[i];
      gap = QStringLiteral("%1 → %2").arg(c.before_m * 1e3, 0, 'f', 1).arg(c.after_m * 1e3, 0,
                                                                            'f', 1);
    }
    auto* item = new QTableWidgetItem(gap);
    item->setTextAlignment(Qt::AlignRight | Qt::AlignVCenter);
    table_->setItem(row, 2, item);
  }
  // A refined solve's gaps are its fitted corners', not the picks' in the
  // row: the column says which (it read as the picks' own).
  const bool corner_gaps = checks && result->has_corners;
  if (QTableWidgetItem* header = table_->horizontalHeaderItem(2)) {
    header->setText(corner_gaps ? tr("corner\ngap (mm)") : tr("gap (mm)"));
    header->setToolTip(
        corner_gaps
            ? tr("The gap between pass A and B of the fitted board corner nearest "
                 "each pick (the green and yellow markers in the view), before -> after the solve")
            : tr("The pair's distance before -> after the solve (each pick snapped to "
                 "its sample)"));
  }
  if (selected >= 0 && selected < table_->rowCount()) table_->selectRow(selected);
  table_->blockSignals(false);
  // What they can act on: a selected pair, a complete pair to save.
  delete_pair_->setEnabled(table_->currentRow() >= 0 && table_->currentRow() < table_->rowCount());
  save_pairs_->setEnabled(!pairs().empty());

  std::vector<CloudView::Marker> markers;
  const int highlight = table_->currentRow();
  for (size_t i = 0; i < pairs_.size(); ++i) {
    const bool h = static_cast<int>(i) == highlight;
    if (pairs_[i].has_a && pass_shown_ != 1) markers.push_back({pairs_[i].a, kColorA, h});
    if (pairs_[i].has_b && pass_shown_ != 0) markers.push_back({pairs_[i].b, kColorB, h});
  }
  // The fitted board corners the refined solve used (the raw picks stay).
  if (result != nullptr && result->has_corners) {
    for (int k = 0; k < 2; ++k) {
      if (pass_shown_ >= 0 && pass_shown_ != k) continue;
      for (const Eigen::Vector3d& c : result->corners[k].corners) {
        markers.push_back({c, k == 0 ? kCornerA : kCornerB, false});
      }
    }
  }
  view_->SetMarkers(markers);

  const bool open = !pairs_.empty() && !pairs_.back().complete();
  if (!pairs_.empty()) dropped_note_.clear();  // Picking again: the note has been read.
  QString prompt;
  if (open && !pairs_.back().has_b) {
    prompt = tr("Shift + click the <b style='color:#ff3cc8'>same corner in pass B</b>.");
  } else if (open) {
    prompt = tr("Shift + click the <b style='color:#00b4e6'>same corner in pass A</b>.");
  } else if (workspace_->recording_opened() == nullptr && workspace_->recording()) {
    // A live cloud's picks are cleared when the recording is opened: the
    // pairs are picked then, on its split passes.
    prompt =
        tr("Recording: when the drive ends (Robot > Stop Recording), open it (step 1) "
           "to pick pairs on its two passes.");
  } else if (workspace_->recording_opened() == nullptr) {
    // Nothing to solve on (a live cloud, a project): where pairs come from.
    prompt = tr("Pairs are picked on a calibration drive: open its session (step 1).");
  } else if (!workspace_->circle_drive()) {
    prompt = tr("This session is no calibration drive (step 2): its pairs cannot be solved.");
  } else {
    prompt = tr("Shift + click a target corner in <b style='color:#00b4e6'>pass A</b> or "
                "<b style='color:#ff3cc8'>pass B</b> (%1 complete pairs; at least 4).")
                 .arg(pairs().size());
  }
  next_pick_->setText(prompt + (dropped_note_.isEmpty()
                                    ? QString()
                                    : QStringLiteral("<br>") + dropped_note_.toHtmlEscaped()));
  const bool opened = workspace_->recording_opened() != nullptr;
  solve_->setEnabled(!solving_ && pairs().size() >= 4 && opened);
  auto_->setEnabled(!solving_ && opened);
  cancel_->setEnabled(solving_);
  split_->setEnabled(opened && workspace_->circle_drive());
  const bool labelled = view_->has_point_values(CloudView::ColorMode::kPass);
  for (QPushButton* b : pass_buttons_) b->setEnabled(labelled);
  const bool have = result != nullptr;
  after_->setEnabled(have && opened);
  save_calibration_->setEnabled(have);
  use_for_robot_->setEnabled(have);
}

}  // namespace sweepscan::ui
