// Evaluation panel: how good is the cloud shown? Miao et al. 2022, section
// 5: statistical outlier removal, RANSAC planes (floor, ceiling, walls) with
// their tilt, RMS and deviation histogram (Fig. 9), density as the mean
// nearest-neighbour distance (Eq. 18-19) and room dimensions between
// parallel planes (Table 3). Each evaluation is shown beside the previous
// one, so evaluating before and after a calibration (Calibration panel,
// Show calibrated) compares them: the planes' histograms are drawn over the
// previous ones. In the view: the planes as coloured rectangles and the
// cloud coloured by its deviation from them (mm, colour bar). The report
// (JSON and a PNG of the view) is exported. GUI thread; the work runs on a
// job thread.
#ifndef SWEEPSCAN_UI_PANELS_EVALUATION_PANEL_H_
#define SWEEPSCAN_UI_PANELS_EVALUATION_PANEL_H_

#include <QColor>
#include <QWidget>
#include <string>
#include <vector>

#include "ui/view/cloud_view.h"
#include "ui/workspace/workspace.h"

class QCheckBox;
class QDoubleSpinBox;
class QLabel;
class QPushButton;
class QTableWidget;

namespace sweepscan::ui {

class HistogramPlot;

// A room dimension's name in the panel: the planes it spans, as
// "wall 3 – wall 4" (planes numbered from 1, as the planes table's rows).
QString DimensionName(const CloudEvaluation& e, const RoomDimension& d);
// A plane's colour in the view: by kind ("floor", "ceiling", "wall", other),
// walls each their own, counted from 0 in the planes' order.
QColor PlaneColor(const std::string& kind, int wall);

class EvaluationPanel : public QWidget {
  Q_OBJECT
 public:
  EvaluationPanel(Workspace* workspace, CloudView* view, QWidget* parent = nullptr);
  void Evaluate();
  // Colours the cloud by the deviation map (true) or gives the view back its
  // previous colouring (false).
  void ShowDeviations(bool on);
  void ShowPlanes(bool on);
  // Writes `path` (JSON, docs/evaluation-report.md) and beside it the view
  // as PNG (same name, .png), here and now.
  bool ExportReport(const QString& path, QString* error);
  // The same as Export report… does it: on the job thread (progress in the
  // status bar); a failure is shown as an error, the summary stays.
  void ExportReportInBackground(const QString& path);
  QString summary_text() const;
  int plane_rows() const;

 signals:
  void evaluated(bool ok);

 private:
  void Show(bool ok, const QString& message);
  // No evaluation of the cloud shown: empty tables, no export; `text` says why.
  void ShowCleared(const QString& text);
  // The selected row's histogram, and its plane singled out in the view.
  void ShowHistogram();

  Workspace* workspace_;
  CloudView* view_;
  QPushButton* evaluate_;
  QPushButton* export_;
  QCheckBox* planes_shown_;
  QCheckBox* deviations_shown_;
  QDoubleSpinBox* deviation_range_;
  int color_before_ = 0;
  QLabel* summary_;
  QString intro_;  // What the panel does, shown until an evaluation.
  QTableWidget* planes_;
  QTableWidget* dimensions_;
  HistogramPlot* histogram_;
  std::vector<CloudView::PlanePatch> patches_;  // The planes drawn, in the table's order.
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PANELS_EVALUATION_PANEL_H_
