#include "ui/panels/evaluation_panel.h"

#include <QHeaderView>
#include <QLabel>
#include <QPainter>
#include <QPushButton>
#include <QTableWidget>
#include <QVBoxLayout>
#include <algorithm>

namespace sweepscan::ui {

// A plane's signed deviations n . p + d as bars (the paper's Fig. 9).
class HistogramPlot : public QWidget {
 public:
  HistogramPlot() { setMinimumHeight(110); }
  void Set(const DeviationHistogram& h, const QString& title) {
    h_ = h;
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
    const uint64_t peak = *std::max_element(h_.counts.begin(), h_.counts.end());
    const QRectF r = QRectF(rect()).adjusted(6, 18, -6, -16);
    const double w = r.width() / h_.counts.size();
    for (size_t i = 0; i < h_.counts.size(); ++i) {
      const double bar = peak > 0 ? r.height() * h_.counts[i] / peak : 0.0;
      p.fillRect(QRectF(r.left() + i * w, r.bottom() - bar, std::max(1.0, w - 1), bar),
                 QColor(67, 160, 71));
    }
    p.drawText(rect().adjusted(4, 2, -4, 0), Qt::AlignTop | Qt::AlignLeft, title_);
    const double lo = h_.min_m * 1e3, hi = (h_.min_m + h_.bin_m * h_.counts.size()) * 1e3;
    p.drawText(rect().adjusted(4, 0, -4, -2), Qt::AlignBottom | Qt::AlignLeft,
               QStringLiteral("%1 mm").arg(lo, 0, 'f', 0));
    p.drawText(rect().adjusted(4, 0, -4, -2), Qt::AlignBottom | Qt::AlignHCenter,
               QStringLiteral("0"));
    p.drawText(rect().adjusted(4, 0, -4, -2), Qt::AlignBottom | Qt::AlignRight,
               QStringLiteral("%1 mm").arg(hi, 0, 'f', 0));
  }

 private:
  DeviationHistogram h_;
  QString title_;
};

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

EvaluationPanel::EvaluationPanel(Workspace* workspace, QWidget* parent)
    : QWidget(parent), workspace_(workspace) {
  auto* layout = new QVBoxLayout(this);
  evaluate_ = new QPushButton(tr("Evaluate the cloud shown"));
  layout->addWidget(evaluate_);
  summary_ =
      new QLabel(tr("Planes, deviations, density and room size of the cloud shown. "
                    "Evaluate before and after a calibration to compare."));
  summary_->setWordWrap(true);
  summary_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  layout->addWidget(summary_);
  planes_ = new QTableWidget(0, 5);
  planes_->setHorizontalHeaderLabels(
      {tr("plane"), tr("points"), tr("RMS (mm)"), tr("tilt (°)"), tr("before: RMS, tilt")});
  planes_->horizontalHeader()->setSectionResizeMode(QHeaderView::ResizeToContents);
  planes_->setSelectionBehavior(QAbstractItemView::SelectRows);
  planes_->setSelectionMode(QAbstractItemView::SingleSelection);
  planes_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  planes_->setMinimumHeight(140);
  layout->addWidget(planes_);
  histogram_ = new HistogramPlot;
  layout->addWidget(histogram_);
  dimensions_ = new QTableWidget(0, 3);
  dimensions_->setHorizontalHeaderLabels({tr("dimension"), tr("now (m)"), tr("before (m)")});
  dimensions_->horizontalHeader()->setSectionResizeMode(QHeaderView::Stretch);
  dimensions_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  dimensions_->setMinimumHeight(100);
  layout->addWidget(dimensions_);

  connect(evaluate_, &QPushButton::clicked, this, &EvaluationPanel::Evaluate);
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

void EvaluationPanel::Show(bool ok, const QString& message) {
  evaluate_->setEnabled(true);
  const CloudEvaluation* e = workspace_->evaluation();
  if (!ok || e == nullptr) {
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
  planes_->setRowCount(static_cast<int>(e->planes.size()));
  for (size_t i = 0; i < e->planes.size(); ++i) {
    const EvaluatedPlane& p = e->planes[i];
    const int r = static_cast<int>(i);
    planes_->setItem(r, 0, new QTableWidgetItem(QString::fromStdString(p.kind)));
    planes_->setItem(r, 1, Item(QString::number(p.plane.count)));
    planes_->setItem(r, 2, Item(QString::number(p.plane.rms * 1e3, 'f', 2)));
    planes_->setItem(r, 3, Item(QString::number(p.tilt_deg, 'f', 3)));
    QString b = QStringLiteral("-");
    if (before != nullptr && i < before->planes.size() && before->planes[i].kind == p.kind) {
      b = QStringLiteral("%1 mm, %2°")
              .arg(before->planes[i].plane.rms * 1e3, 0, 'f', 2)
              .arg(before->planes[i].tilt_deg, 0, 'f', 3);
    }
    planes_->setItem(r, 4, Item(b));
  }
  dimensions_->setRowCount(static_cast<int>(e->dimensions.size()));
  for (size_t i = 0; i < e->dimensions.size(); ++i) {
    const RoomDimension& d = e->dimensions[i];
    const int r = static_cast<int>(i);
    dimensions_->setItem(r, 0,
                         new QTableWidgetItem(QStringLiteral("%1 (%2-%3)")
                                                  .arg(QString::fromStdString(d.axis))
                                                  .arg(d.plane_a)
                                                  .arg(d.plane_b)));
    dimensions_->setItem(r, 1, Item(QString::number(d.distance_m, 'f', 4)));
    QString b = QStringLiteral("-");
    if (before != nullptr && i < before->dimensions.size() &&
        before->dimensions[i].axis == d.axis) {
      b = QString::number(before->dimensions[i].distance_m, 'f', 4);
    }
    dimensions_->setItem(r, 2, Item(b));
  }
  if (!e->planes.empty()) planes_->selectRow(0);
  ShowHistogram();
  emit evaluated(true);
}

void EvaluationPanel::ShowHistogram() {
  const CloudEvaluation* e = workspace_->evaluation();
  const int r = planes_->currentRow();
  if (e == nullptr || r < 0 || r >= static_cast<int>(e->planes.size())) return;
  const EvaluatedPlane& p = e->planes[r];
  histogram_->Set(p.deviations, tr("%1 %2: deviations from its plane (RMS %3 mm)")
                                    .arg(QString::fromStdString(p.kind))
                                    .arg(r)
                                    .arg(p.plane.rms * 1e3, 0, 'f', 2));
}

}  // namespace sweepscan::ui
