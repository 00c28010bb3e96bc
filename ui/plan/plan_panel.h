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
// * The drawing is a PlanCanvas (pan, zoom, Fit), rooms' outlines with
//   their names and areas under the walls.
// * A vertical section: the Section button (or Shift + drag on the plan)
//   draws its line A -> A'; the section of the same inputs along it (the
//   dock's band either side) is built on the job thread and drawn in a
//   SectionCanvas under the plan. The line stays while the plan is rebuilt
//   (each rebuild builds its section too) and is kept in the settings;
//   Export Section… writes it as SVG (core/plan WriteSectionSvg).
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
#include <optional>

#include "ui/plan/plan_build.h"
#include "ui/plan/plan_canvas.h"
#include "ui/project/project_jobs.h"

class QAction;
class QDoubleSpinBox;
class QLabel;
class QProgressBar;
class QPushButton;
class QSplitter;
class QTimer;
class QToolButton;

namespace sweepscan::ui {

class ProjectController;
class SectionCanvas;
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
  // Plans and sections built so far (tests wait for the next).
  uint64_t plans_built() const { return plans_built_; }
  uint64_t sections_built() const { return sections_built_; }
  // Writes the plan shown: SVG (*.svg) or DXF (*.dxf) by the suffix.
  bool ExportPlan(const QString& path, QString* error) const;
  // File > Export Floor Plan…: the file chosen, then ExportPlan; errors shown.
  void ExportWithDialog();
  // The File menu's Export Floor Plan action, enabled with the dock's
  // Export… (or, the dock hidden, when there is something to plan).
  void SetFileExportAction(QAction* action);

  // The section line (none: no section); its section is built now or
  // after the build under way, and the line kept in the settings.
  void SetSectionLine(const std::optional<SectionLine>& line);
  // Writes the section shown: SVG (*.svg, 1:50, paper millimetres) or DXF
  // (*.dxf, R12 in metres) by the suffix.
  bool ExportSection(const QString& path, QString* error) const;
  // Export Section…: the file chosen, then ExportSection; errors shown.
  void ExportSectionWithDialog();

  PlanCanvas* canvas() const { return canvas_; }
  QDoubleSpinBox* height_box() const { return height_; }
  QDoubleSpinBox* band_box() const { return band_; }
  QToolButton* cancel_button() const { return cancel_; }
  QLabel* summary_label() const { return summary_; }
  QToolButton* section_tool() const { return section_tool_; }
  SectionCanvas* section_canvas() const { return section_canvas_; }
  QWidget* section_pane() const { return section_pane_; }
  QPushButton* section_export_button() const { return section_export_; }
  QLabel* section_summary_label() const { return section_summary_; }

 signals:
  void planBuilt(bool ok, const QString& message);

 protected:
  void showEvent(QShowEvent* event) override;
  void hideEvent(QHideEvent* event) override;

 private:
  void Stale(bool fit);  // The inputs changed: rebuilt soon if shown.
  // The export, Fit and Remove buttons (and the File action) enabled when
  // they can act, with why not in their tooltips.
  void UpdateActions();
  // Why Export cannot act, said so that the operator can mend it.
  QString NoPlanReason() const;
  bool settle_pending() const;
  void ShowProgress(const QString& what, double fraction);
  // The section of the line alone (the plan kept), on the job thread.
  void RebuildSection();
  // The build ended: progress hidden; true if the caller is to go on (no
  // rebuild of everything was waiting).
  bool JobEnded();
  void ShowSection(const SectionOf& section, bool fit);
  QWidget* MakeSectionPane();

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
  QToolButton* section_tool_;
  QSplitter* splitter_;
  QWidget* section_pane_ = nullptr;
  SectionCanvas* section_canvas_ = nullptr;
  QLabel* section_summary_ = nullptr;
  QPushButton* section_export_ = nullptr;
  QPushButton* section_fit_ = nullptr;
  QToolButton* section_remove_ = nullptr;
  QAction* file_export_ = nullptr;
  QTimer* settle_;
  bool stale_ = true;
  bool fit_next_ = true;  // a new source: the next plan fitted
  bool again_ = false;    // rebuild when the running build ends
  uint64_t plans_built_ = 0;
  uint64_t sections_built_ = 0;
  // Each new line counts up: a build that ends with an older one is
  // followed by the section of the new.
  uint64_t line_serial_ = 0;
  uint64_t section_shown_serial_ = 0;  // of the section shown (0: none)
  QString title_;  // the SVG's title line: what the plan is of
  QString what_;   // what the last build was of
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PLAN_PLAN_PANEL_H_
