#include "ui/panels/evaluation_panel.h"

#include <QCheckBox>
#include <QDir>
#include <QDoubleSpinBox>
#include <QFileDialog>
#include <QFileInfo>
#include <QGridLayout>
#include <QHeaderView>
#include <QLabel>
#include <QPainter>
#include <QPainterPath>
#include <QPushButton>
#include <QTableWidget>
#include <QVBoxLayout>
#include <algorithm>
#include <cmath>

#include "core/evaluation/plane_match.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {

// A dimension by the planes it spans, numbered as the planes table's rows
// (from 1), as an operator reads them: "wall 3 - wall 4". Its axis alone
// ("horizontal (3-4)", cut to "horizontal ...") did not say which walls.
QString DimensionName(const CloudEvaluation& e, const RoomDimension& d) {
  const auto plane = [&](int i) {
    const bool known = i >= 0 && static_cast<size_t>(i) < e.planes.size();
    return QStringLiteral("%1 %2")
        .arg(known ? QString::fromStdString(e.planes[static_cast<size_t>(i)].kind)
                   : QStringLiteral("plane"))
        .arg(i + 1);
  };
  return QStringLiteral("%1 \u2013 %2").arg(plane(d.plane_a), plane(d.plane_b));
}

// A plane's signed deviations n . p + d as bars (the paper's Fig. 9).
class HistogramPlot : public QWidget {
 public:
  HistogramPlot() { setMinimumHeight(130); }
  // `before`: the same plane in the previous evaluation, drawn as an
  // outline over the bars (empty counts: none).
  void Set(const DeviationHistogram& h, const DeviationHistogram& before, const QString& title) {
    h_ = h;
    before_ = before;
    title_ = title;
    update();
  }

 protected:
  void paintEvent(QPaintEvent*) override {
    QPainter p(this);
    p.fillRect(rect(), palette().base());
    p.setPen(palette().mid().color());
    p.drawRect(rect().adjusted(0, 0, -1, -1));
    p.setPen(palette().text().color());
    if (h_.counts.empty()) {
      p.drawText(rect(), Qt::AlignCenter, tr("deviation histogram of the selected plane"));
      return;
    }
    // Shares of each histogram's points, so that clouds of different size
    // compare; bins on the same axis (the same options give the same bins).
    auto shares = [](const DeviationHistogram& h) {
      std::vector<double> s(h.counts.size(), 0.0);
      uint64_t total = 0;
      for (uint64_t c : h.counts) total += c;
      for (size_t i = 0; i < s.size() && total > 0; ++i) s[i] = double(h.counts[i]) / total;
      return s;
    };
    const std::vector<double> now = shares(h_);
    const bool with_before =
        before_.counts.size() == h_.counts.size() && before_.bin_m == h_.bin_m;
    const std::vector<double> then = with_before ? shares(before_) : std::vector<double>();
    double peak = *std::max_element(now.begin(), now.end());
    if (with_before) peak = std::max(peak, *std::max_element(then.begin(), then.end()));
    const QRectF r = QRectF(rect()).adjusted(6, 32, -6, -16);
    const double w = r.width() / now.size();
    // The end bars also hold the deviations beyond the range: that part of
    // them is drawn in brown, and said, so a plane with points far off it
    // does not look clean.
    const QColor kInside(67, 160, 71), kBeyond(141, 110, 99);
    for (size_t i = 0; i < now.size(); ++i) {
      const double bar = peak > 0 ? r.height() * now[i] / peak : 0.0;
      const QRectF whole(r.left() + i * w, r.bottom() - bar, std::max(1.0, w - 1), bar);
      p.fillRect(whole, kInside);
      uint64_t beyond = 0;
      if (i == 0) beyond += h_.below;
      if (i + 1 == now.size()) beyond += h_.above;
      if (beyond > 0 && h_.counts[i] > 0) {
        const double part = bar * std::min(1.0, double(beyond) / double(h_.counts[i]));
        p.fillRect(QRectF(whole.left(), whole.top(), whole.width(), part), kBeyond);
      }
    }
    if (with_before) {
      QPainterPath path;
      path.moveTo(r.left(), r.bottom());
      for (size_t i = 0; i < then.size(); ++i) {
        const double y = r.bottom() - (peak > 0 ? r.height() * then[i] / peak : 0.0);
        path.lineTo(r.left() + i * w, y);
        path.lineTo(r.left() + (i + 1) * w, y);
      }
      path.lineTo(r.right(), r.bottom());
      p.setPen(QPen(QColor(239, 108, 0), 1.5));
      p.drawPath(path);
      p.drawText(rect().adjusted(4, 16, -4, 0), Qt::AlignTop | Qt::AlignRight,
                 tr("orange: previous"));
      p.setPen(palette().text().color());
    }
    p.drawText(rect().adjusted(4, 2, -4, 0), Qt::AlignTop | Qt::AlignLeft, title_);
    const double lo = h_.min_m * 1e3, hi = (h_.min_m + h_.bin_m * h_.counts.size()) * 1e3;
    if (h_.below + h_.above > 0) {
      p.setPen(kBeyond.darker(130));
      p.drawText(rect().adjusted(4, 16, -4, 0), Qt::AlignTop | Qt::AlignLeft,
                 tr("brown: %L1 below %2 mm, %L3 above %4 mm")
                     .arg(h_.below)
                     .arg(lo, 0, 'f', 0)
                     .arg(h_.above)
                     .arg(hi, 0, 'f', 0));
      p.setPen(palette().text().color());
    }
    p.drawText(rect().adjusted(4, 0, -4, -2), Qt::AlignBottom | Qt::AlignLeft,
               QStringLiteral("%1 mm").arg(lo, 0, 'f', 0));
    p.drawText(rect().adjusted(4, 0, -4, -2), Qt::AlignBottom | Qt::AlignHCenter,
               QStringLiteral("0"));
    p.drawText(rect().adjusted(4, 0, -4, -2), Qt::AlignBottom | Qt::AlignRight,
               QStringLiteral("%1 mm").arg(hi, 0, 'f', 0));
  }

 private:
  DeviationHistogram h_, before_;
  QString title_;
};

QColor PlaneColor(const std::string& kind, int wall) {
  if (kind == "floor") return QColor(141, 110, 99);
  if (kind == "ceiling") return QColor(144, 202, 249);
  if (kind == "wall") {
    // Eight of Material's 300 tones, then hues a golden angle apart: a room
    // of an alcove or two has more than four walls, and its fifth wall was
    // drawn in its first one's orange.
    static const QColor walls[] = {
        QColor(255, 183, 77), QColor(129, 199, 132), QColor(186, 104, 200), QColor(77, 208, 225),
        QColor(240, 98, 146), QColor(220, 231, 117), QColor(121, 134, 203), QColor(77, 182, 172)};
    constexpr int kNamed = static_cast<int>(sizeof(walls) / sizeof(walls[0]));
    if (wall < 0) wall = 0;
    if (wall < kNamed) return walls[wall];
    return QColor::fromHsv((15 + 137 * (wall - kNamed)) % 360, 150, 235);
  }
  return QColor(224, 224, 224);
}

namespace {

QTableWidgetItem* Item(const QString& text) {
  auto* item = new QTableWidgetItem(text);
  item->setTextAlignment(Qt::AlignRight | Qt::AlignVCenter);
  return item;
}

QString Angles(const MountingError& c) {
  if (c.alpha == 0 && c.beta == 0 && c.gamma == 0) return QObject::tr("uncalibrated");
  return QObject::tr("calibrated (%1, %2, %3 mrad)")
      .arg(c.alpha * 1e3, 0, 'f', 2)
      .arg(c.beta * 1e3, 0, 'f', 2)
      .arg(c.gamma * 1e3, 0, 'f', 2);
}

}  // namespace

EvaluationPanel::EvaluationPanel(Workspace* workspace, CloudView* view, QWidget* parent)
    : QWidget(parent), workspace_(workspace), view_(view) {
  auto* layout = new QVBoxLayout(this);
  evaluate_ = new QPushButton(tr("Evaluate the cloud shown"));
  evaluate_->setObjectName(QStringLiteral("evaluate"));
  layout->addWidget(evaluate_);
  intro_ =
      tr("Planes, deviations, density and room size of the cloud shown. "
         "Evaluate before and after a calibration to compare.");
  summary_ = new QLabel(intro_);
  summary_->setObjectName(QStringLiteral("evaluationSummary"));
  summary_->setWordWrap(true);
  summary_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  layout->addWidget(summary_);
  // Named as in the view ("wall 3"), so no row numbers; the previous
  // evaluation's figures in columns of their own, as numbers like the
  // others (the units in the headers and tooltips).
  planes_ = new QTableWidget(0, 6);
  planes_->setObjectName(QStringLiteral("evaluationPlanes"));
  // Headers on two lines: the figures are narrower than their names, and
  // the six columns then fit the dock without scrolling.
  planes_->setHorizontalHeaderLabels({tr("plane"), tr("points"), tr("RMS\n(mm)"), tr("tilt\n(°)"),
                                      tr("RMS\nbefore"), tr("tilt\nbefore")});
  planes_->horizontalHeaderItem(4)->setToolTip(
      tr("RMS (mm) of the same surface in the previous evaluation"));
  planes_->horizontalHeaderItem(5)->setToolTip(
      tr("Tilt (°) of the same surface in the previous evaluation"));
  planes_->verticalHeader()->setVisible(false);
  planes_->horizontalHeader()->setSectionResizeMode(QHeaderView::ResizeToContents);
  planes_->horizontalHeader()->setStretchLastSection(true);
  planes_->setColumnHidden(4, true);  // shown when there is a previous evaluation
  planes_->setColumnHidden(5, true);
  planes_->setSelectionBehavior(QAbstractItemView::SelectRows);
  planes_->setSelectionMode(QAbstractItemView::SingleSelection);
  planes_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  planes_->setMinimumHeight(140);
  layout->addWidget(planes_);
  histogram_ = new HistogramPlot;
  layout->addWidget(histogram_);
  dimensions_ = new QTableWidget(0, 3);
  dimensions_->setObjectName(QStringLiteral("evaluationDimensions"));
  dimensions_->setHorizontalHeaderLabels({tr("dimension"), tr("now (m)"), tr("before (m)")});
  // The name takes the room; the figures are as wide as they need.
  dimensions_->horizontalHeader()->setSectionResizeMode(QHeaderView::ResizeToContents);
  dimensions_->horizontalHeader()->setSectionResizeMode(0, QHeaderView::Stretch);
  dimensions_->setColumnHidden(2, true);
  dimensions_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  dimensions_->setMinimumHeight(100);
  layout->addWidget(dimensions_);

  auto* shown = new QGridLayout;
  planes_shown_ = new QCheckBox(tr("Show planes"));
  planes_shown_->setChecked(true);
  planes_shown_->setToolTip(tr("The fitted planes as coloured rectangles in the view"));
  deviations_shown_ = new QCheckBox(tr("Colour by deviation, ±"));
  deviations_shown_->setToolTip(
      tr("Each point coloured by its distance to its fitted plane: blue behind, white on, red "
         "in front; grey on no plane"));
  deviation_range_ = new QDoubleSpinBox;
  deviation_range_->setRange(1.0, 200.0);
  deviation_range_->setValue(20.0);
  deviation_range_->setSuffix(tr(" mm"));
  deviation_range_->setDecimals(0);
  shown->addWidget(planes_shown_, 0, 0);
  shown->addWidget(deviations_shown_, 1, 0);
  shown->addWidget(deviation_range_, 1, 1);
  layout->addLayout(shown);
  export_ = new QPushButton(tr("Export report…"));
  export_->setObjectName(QStringLiteral("exportReport"));
  export_->setToolTip(tr("The evaluation as JSON, with a PNG of the view beside it"));
  export_->setEnabled(false);
  layout->addWidget(export_);

  connect(evaluate_, &QPushButton::clicked, this, &EvaluationPanel::Evaluate);
  connect(planes_shown_, &QCheckBox::toggled, this, &EvaluationPanel::ShowPlanes);
  connect(deviations_shown_, &QCheckBox::toggled, this, &EvaluationPanel::ShowDeviations);
  connect(deviation_range_, qOverload<double>(&QDoubleSpinBox::valueChanged), view_,
          &CloudView::SetDeviationRange);
  connect(export_, &QPushButton::clicked, this, [this] {
    QString path = QFileDialog::getSaveFileName(this, tr("Export evaluation report"), QString(),
                                                tr("Report (*.json)"));
    if (path.isEmpty()) return;
    // Qt's own dialog leaves a name typed without its suffix bare.
    if (QFileInfo(path).suffix().isEmpty()) path += QStringLiteral(".json");
    ExportReportInBackground(path);
  });
  // A new cloud (another session, a before / after replay, another pose
  // source) has neither the old planes nor the old deviations.
  auto forget = [this] {
    patches_.clear();
    view_->SetPlanes({});
    deviations_shown_->setChecked(false);
  };
  connect(workspace_, &Workspace::sessionChanged, this, forget);
  connect(workspace_, &Workspace::shownPoseSourceChanged, this, forget);
  // ... nor the old figures: the workspace has forgotten them.
  connect(workspace_, &Workspace::evaluationCleared, this, [this] {
    ShowCleared(workspace_->previous_evaluation() != nullptr
                    ? tr("The cloud shown has changed (another pose source or calibration): "
                         "evaluate it again. The last evaluation is kept as \"before\".")
                    : tr("The cloud shown has changed: evaluate it again."));
  });
  connect(workspace_, &Workspace::sessionChanged, this, [this] {
    if (workspace_->evaluation() == nullptr) ShowCleared(intro_);
  });
  connect(planes_, &QTableWidget::itemSelectionChanged, this, &EvaluationPanel::ShowHistogram);
  connect(workspace_, &Workspace::evaluationFinished, this, &EvaluationPanel::Show);
}

void EvaluationPanel::Evaluate() {
  evaluate_->setEnabled(false);
  summary_->setText(tr("Evaluating…"));
  workspace_->Evaluate();
}

QString EvaluationPanel::summary_text() const { return summary_->text(); }

int EvaluationPanel::plane_rows() const { return planes_->rowCount(); }

void EvaluationPanel::ShowCleared(const QString& text) {
  summary_->setText(text);
  planes_->setRowCount(0);
  dimensions_->setRowCount(0);
  histogram_->Set(DeviationHistogram(), DeviationHistogram(), QString());
  export_->setEnabled(false);
}

void EvaluationPanel::Show(bool ok, const QString& message) {
  evaluate_->setEnabled(true);
  const CloudEvaluation* e = workspace_->evaluation();
  if (!ok || e == nullptr) {
    // The tables show the evaluation the workspace holds (it may be one
    // from before a refused re-evaluation), or none.
    if (e == nullptr) ShowCleared(QString());
    summary_->setText(
        tr("<b style='color:#c62828'>Not evaluated:</b> %1").arg(message.toHtmlEscaped()));
    emit evaluated(false);
    return;
  }
  const CloudEvaluation* before = workspace_->previous_evaluation();
  QString text = tr("<b>%1</b>: %L2 points, %L3 after outlier removal; density (mean nearest "
                    "neighbour, Eq. 18-19) %4 mm")
                     .arg(Angles(workspace_->evaluated_calibration()))
                     .arg(e->points_in)
                     .arg(e->points_after_outliers)
                     .arg(e->mean_nn_distance_m * 1e3, 0, 'f', 2);
  if (before != nullptr) {
    text += tr("<br>previous evaluation: density %1 mm, %2 planes")
                .arg(before->mean_nn_distance_m * 1e3, 0, 'f', 2)
                .arg(before->planes.size());
  }
  summary_->setText(text);
  // "before" only when there is one: an empty column's header was cut to
  // "before: RM" and pushed the table into scrolling.
  planes_->setColumnHidden(4, before == nullptr);
  planes_->setColumnHidden(5, before == nullptr);
  dimensions_->setColumnHidden(2, before == nullptr);
  // The same surfaces, matched by place: the rows are by size, and a
  // calibration changes the planes' inlier counts.
  const std::vector<int> same =
      before != nullptr ? MatchPlanes(*e, *before) : std::vector<int>(e->planes.size(), -1);
  const std::vector<int> same_dimension = before != nullptr
                                              ? MatchDimensions(*e, *before, same)
                                              : std::vector<int>(e->dimensions.size(), -1);
  planes_->setRowCount(static_cast<int>(e->planes.size()));
  for (size_t i = 0; i < e->planes.size(); ++i) {
    const EvaluatedPlane& p = e->planes[i];
    const int r = static_cast<int>(i);
    planes_->setItem(r, 0,
                     new QTableWidgetItem(
                         QStringLiteral("%1 %2").arg(QString::fromStdString(p.kind)).arg(i + 1)));
    planes_->setItem(r, 1, Item(QString::number(p.plane.count)));
    planes_->setItem(r, 2, Item(QString::number(p.plane.rms * 1e3, 'f', 2)));
    planes_->setItem(r, 3, Item(QString::number(p.tilt_deg, 'f', 3)));
    QString rms_before = QStringLiteral("-"), tilt_before = QStringLiteral("-");
    if (same[i] >= 0) {
      const EvaluatedPlane& b = before->planes[static_cast<size_t>(same[i])];
      rms_before = QString::number(b.plane.rms * 1e3, 'f', 2);
      tilt_before = QString::number(b.tilt_deg, 'f', 3);
    }
    planes_->setItem(r, 4, Item(rms_before));
    planes_->setItem(r, 5, Item(tilt_before));
  }
  dimensions_->setRowCount(static_cast<int>(e->dimensions.size()));
  for (size_t i = 0; i < e->dimensions.size(); ++i) {
    const RoomDimension& d = e->dimensions[i];
    const int r = static_cast<int>(i);
    dimensions_->setItem(r, 0, new QTableWidgetItem(DimensionName(*e, d)));
    // To the millimetre: the cloud's grid step, below its planes' RMS of
    // several (a tenth of a millimetre claimed what it does not know).
    dimensions_->setItem(r, 1, Item(QString::number(d.distance_m, 'f', 3)));
    QString b = QStringLiteral("-");
    if (same_dimension[i] >= 0) {
      b = QString::number(before->dimensions[static_cast<size_t>(same_dimension[i])].distance_m,
                          'f', 3);
    }
    dimensions_->setItem(r, 2, Item(b));
  }
  patches_.clear();
  if (!e->planes.empty()) planes_->selectRow(0);
  // The planes in the view, coloured by kind, named with their RMS.
  std::vector<CloudView::PlanePatch> patches;
  int walls = 0;
  for (size_t i = 0; i < e->planes.size(); ++i) {
    const EvaluatedPlane& p = e->planes[i];
    CloudView::PlanePatch patch;
    patch.corners = p.outline;
    patch.color = PlaneColor(p.kind, p.kind == "wall" ? walls++ : 0);
    patch.label = QStringLiteral("%1 %2: %3 mm")
                      .arg(QString::fromStdString(p.kind))
                      .arg(i + 1)
                      .arg(p.plane.rms * 1e3, 0, 'f', 1);
    patches.push_back(patch);
  }
  patches_ = patches;
  ShowHistogram();  // With the selected row's plane singled out.
  view_->SetPlanesVisible(planes_shown_->isChecked());
  if (workspace_->deviation_values() != nullptr) {
    view_->SetPointValues(CloudView::ColorMode::kDeviation, *workspace_->deviation_values());
  }
  view_->SetDeviationRange(deviation_range_->value());
  if (deviations_shown_->isChecked()) view_->SetColorMode(CloudView::ColorMode::kDeviation);
  export_->setEnabled(true);
  emit evaluated(true);
}

void EvaluationPanel::ShowPlanes(bool on) {
  if (planes_shown_->isChecked() != on) planes_shown_->setChecked(on);
  view_->SetPlanesVisible(on);
}

void EvaluationPanel::ShowDeviations(bool on) {
  if (deviations_shown_->isChecked() != on) {
    deviations_shown_->setChecked(on);  // Re-enters through toggled.
    return;
  }
  if (on) {
    if (view_->color_mode() != CloudView::ColorMode::kDeviation) {
      color_before_ = static_cast<int>(view_->color_mode());
    }
    view_->SetColorMode(CloudView::ColorMode::kDeviation);
  } else if (view_->color_mode() == CloudView::ColorMode::kDeviation) {
    // The colouring from before, unless the cloud now shown has no values
    // for it (the pass labels of a calibration drive no longer shown): grey
    // under its legend says nothing.
    auto mode = static_cast<CloudView::ColorMode>(color_before_);
    const bool given = mode == CloudView::ColorMode::kPass ||
                       mode == CloudView::ColorMode::kDeviation ||
                       mode == CloudView::ColorMode::kIntensity;
    if (given && !view_->has_point_values(mode)) mode = CloudView::ColorMode::kHeight;
    view_->SetColorMode(mode);
  }
}

void EvaluationPanel::ExportReportInBackground(const QString& path) {
  // The view grabbed now (GUI thread), the files written on the job thread;
  // a failure comes back as a failed job, shown as an error by the main
  // window as Export Cloud's is. The summary stays.
  workspace_->ExportEvaluationReport(path, view_->GrabImage());
}

bool EvaluationPanel::ExportReport(const QString& path, QString* error) {
  const QFileInfo info(path);
  const QString image = info.completeBaseName() + QStringLiteral(".png");
  if (!view_->SaveScreenshot(info.dir().filePath(image), error)) return false;
  return workspace_->SaveEvaluationReport(path, image, error);
}

void EvaluationPanel::ShowHistogram() {
  const CloudEvaluation* e = workspace_->evaluation();
  // The selected row (none once the selection is cleared, which leaves a
  // current row behind).
  const QList<QTableWidgetItem*> selected = planes_->selectedItems();
  const int r = selected.isEmpty() ? -1 : selected.front()->row();
  if (!patches_.empty()) {
    for (size_t i = 0; i < patches_.size(); ++i) patches_[i].selected = static_cast<int>(i) == r;
    view_->SetPlanes(patches_);
  }
  if (e == nullptr || r < 0 || r >= static_cast<int>(e->planes.size())) return;
  const EvaluatedPlane& p = e->planes[r];
  // The same plane in the previous evaluation: the same kind, the nearest
  // normal (planes come in size order, which a calibration can change).
  DeviationHistogram before;
  if (const CloudEvaluation* b = workspace_->previous_evaluation()) {
    double best = 0.9;  // |cos| of at most ~25 degrees
    for (const EvaluatedPlane& q : b->planes) {
      const double c = std::abs(q.plane.normal.dot(p.plane.normal));
      if (q.kind == p.kind && c > best &&
          std::abs(std::abs(q.plane.d) - std::abs(p.plane.d)) < 0.3) {
        best = c;
        before = q.deviations;
      }
    }
  }
  histogram_->Set(p.deviations, before,
                  tr("%1 %2: deviations from its plane (RMS %3 mm)")
                      .arg(QString::fromStdString(p.kind))
                      .arg(r + 1)
                      .arg(p.plane.rms * 1e3, 0, 'f', 2));
}

}  // namespace sweepscan::ui
