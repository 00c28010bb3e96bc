// The plan view (issue 29, docs/desktop-app.md, "Floor plan"): a dock
// (View > Floor Plan) that draws the floor plan of the project open (its
// placed, visible sessions in the project's frame) or, without a project,
// of the opened session's cloud, cut at the height the operator sets.
//
// * The plan is built on a job thread (plan_build.h: the cut with progress
//   and cancel, then core/plan's fit) while the dock is shown; a new cut
//   height, a placement, a visibility or a new session rebuilds it (edits
//   coalesced over kSettleMs; a build under way is cancelled and started
//   again). Hidden, it is built when next shown.
// * The drawing is a PlanCanvas (pan, zoom, Fit).
// * File > Export Floor Plan… writes the plan shown as SVG or DXF by the
//   file's suffix (core/plan/plan_writers.h); failures are message boxes.
//
// GUI thread only; the job's work touches no widget.
#ifndef SWEEPSCAN_UI_PLAN_PLAN_PANEL_H_
#define SWEEPSCAN_UI_PLAN_PLAN_PANEL_H_

#include <QString>
#include <QWidget>
#include <cstdint>
#include <functional>

#include "ui/project/project_jobs.h"

class QDoubleSpinBox;
class QLabel;
class QProgressBar;
class QPushButton;
class QTimer;
class QToolButton;

namespace sweepscan::ui {

class PlanCanvas;
class ProjectController;
class Workspace;

class PlanPanel : public QWidget {
  Q_OBJECT
 public:
  static constexpr int kSettleMs = 300;

  // `show_error(title, message)`: the window's error report (a message box
  // when interactive).
  PlanPanel(ProjectController* project, Workspace* workspace,
            std::function<void(const QString&, const QString&)> show_error, QWidget* parent = nullptr);
  ~PlanPanel() override;

  // Builds the plan now (cancelling one under way), whether shown or not.
  void Rebuild();
  void Cancel() { jobs_.Cancel(); }
  bool busy() const { return jobs_.running() || settle_pending(); }
  // Plans built so far (tests wait for the next).
  uint64_t plans_built() const { return plans_built_; }
  // Writes the plan shown: SVG (*.svg) or DXF (*.dxf) by the suffix.
  bool ExportPlan(const QString& path, QString* error) const;
  // File > Export Floor Plan…: the file chosen, then ExportPlan; errors shown.
  void ExportWithDialog();

  PlanCanvas* canvas() const { return canvas_; }
  QDoubleSpinBox* height_box() const { return height_; }
  QDoubleSpinBox* band_box() const { return band_; }
  QToolButton* cancel_button() const { return cancel_; }
  QLabel* summary_label() const { return summary_; }

 signals:
  void planBuilt(bool ok, const QString& message);

 protected:
  void showEvent(QShowEvent* event) override;

 private:
  void Stale(bool fit);  // The inputs changed: rebuilt soon if shown.
  bool settle_pending() const;
  void ShowProgress(const QString& what, double fraction);

  ProjectController* project_;
  Workspace* workspace_;
  std::function<void(const QString&, const QString&)> show_error_;
  ProjectJobs jobs_;
  PlanCanvas* canvas_;
  QDoubleSpinBox* height_;
  QDoubleSpinBox* band_;
  QPushButton* fit_;
  QPushButton* export_;
  QProgressBar* progress_;
  QToolButton* cancel_;
  QLabel* summary_;
  QTimer* settle_;
  bool stale_ = true;
  bool fit_next_ = true;  // a new source: the next plan fitted
  bool again_ = false;    // rebuild when the running build ends
  uint64_t plans_built_ = 0;
  QString title_;  // the SVG's title line: what the plan is of
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PLAN_PLAN_PANEL_H_
