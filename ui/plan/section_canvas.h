// The plan view's vertical section (ui/plan/plan_panel.h): the points of a
// thin slab along the line A -> A' drawn on the plan, as its viewer sees
// them (core/plan/section.h: standing on the line's right, looking across
// it), s along the line to the right from A (s = 0) to A' and z up, at one
// scale on both axes: the section's points in grey, the ground line z = 0,
// A and A' at the line's ends, the plan's cut height dashed and named at
// the line's far end (at A it sat on the z ticks), ticks and labels every
// grid step (they are its scale; the last of each axis says "m") and the
// cursor's s, z. Pan, zoom and Fit as Canvas2d.
//
// GUI thread only.
#ifndef SWEEPSCAN_UI_PLAN_SECTION_CANVAS_H_
#define SWEEPSCAN_UI_PLAN_SECTION_CANVAS_H_

#include <QPolygonF>
#include <QString>
#include <optional>
#include <vector>

#include "ui/plan/canvas_2d.h"
#include "ui/plan/plan_build.h"

namespace sweepscan::ui {

class SectionCanvas : public Canvas2d {
  Q_OBJECT
 public:
  explicit SectionCanvas(QWidget* parent = nullptr);

  // A new section; `cut_height_m` is the plan's (drawn dashed). Fitted as
  // PlanCanvas::SetPlan.
  void SetSection(const SectionOf& section, double cut_height_m, bool fit);
  void ClearSection(const QString& why);
  const std::optional<SectionOf>& section() const { return section_; }
  // |A A'| (m), 0 without a section.
  double length() const;
  // The labels drawn at the last paint and their plates (widget pixels):
  // the ticks', A and A', the plan's cut.
  struct Label {
    QString text;
    QPolygonF plate;
  };
  const std::vector<Label>& labels() const { return labels_; }

 protected:
  bool Extent(Eigen::Vector2d* min, Eigen::Vector2d* max) const override;
  QString CursorText(const Eigen::Vector2d& at) const override;
  // Room under the ground line for the s labels above the cursor's text.
  int FitMargin() const override { return 56; }
  void paintEvent(QPaintEvent* event) override;

 private:
  std::optional<SectionOf> section_;
  Eigen::Vector2d min_ = Eigen::Vector2d::Zero(), max_ = Eigen::Vector2d::Zero();  // of the points, A, A', z 0
  double cut_height_m_ = 0.0;
  QString empty_text_;
  std::vector<Label> labels_;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PLAN_SECTION_CANVAS_H_
