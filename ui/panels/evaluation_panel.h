// Evaluation panel: how good is the cloud shown? Miao et al. 2022, section
// 5: statistical outlier removal, RANSAC planes (floor, ceiling, walls) with
// their tilt, RMS and deviation histogram (Fig. 9), density as the mean
// nearest-neighbour distance (Eq. 18-19) and room dimensions between
// parallel planes (Table 3). Each evaluation is shown beside the previous
// one, so evaluating before and after a calibration (Calibration panel,
// Show calibrated) compares them. GUI thread; the work runs on a job thread.
#ifndef SWEEPSCAN_UI_PANELS_EVALUATION_PANEL_H_
#define SWEEPSCAN_UI_PANELS_EVALUATION_PANEL_H_

#include <QWidget>

#include "ui/workspace/workspace.h"

class QLabel;
class QPushButton;
class QTableWidget;

namespace sweepscan::ui {

class HistogramPlot;

class EvaluationPanel : public QWidget {
  Q_OBJECT
 public:
  explicit EvaluationPanel(Workspace* workspace, QWidget* parent = nullptr);
  void Evaluate();
  QString summary_text() const;
  int plane_rows() const;

 signals:
  void evaluated(bool ok);

 private:
  void Show(bool ok, const QString& message);
  void ShowHistogram();

  Workspace* workspace_;
  QPushButton* evaluate_;
  QLabel* summary_;
  QTableWidget* planes_;
  QTableWidget* dimensions_;
  HistogramPlot* histogram_;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PANELS_EVALUATION_PANEL_H_
