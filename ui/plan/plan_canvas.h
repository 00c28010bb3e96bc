// The plan view's drawing (ui/plan/plan_panel.h): a FloorPlan in 2D with
// QPainter, as a surveyor reads one: the section's points in grey, walls
// filled dark with their thickness, wall faces black (furniture's thin
// grey), openings as a blue door leaf and swing between their jambs with
// the width, inner dimensions as dimension lines with ticks and the length
// in metres, a 1 m grid, a scale bar, and the cursor's x, y.
//
// Plan x right, y up (the project's frame seen from above, as View > Top).
// Left drag pans, the wheel zooms about the cursor, a double click or
// Fit() shows the whole plan. Text and line widths stay the same size on
// screen whatever the zoom.
//
// GUI thread only.
#ifndef SWEEPSCAN_UI_PLAN_PLAN_CANVAS_H_
#define SWEEPSCAN_UI_PLAN_PLAN_CANVAS_H_

#include <Eigen/Core>
#include <QPointF>
#include <QString>
#include <QWidget>
#include <optional>

#include "core/plan/floor_plan.h"

namespace sweepscan::ui {

class PlanCanvas : public QWidget {
  Q_OBJECT
 public:
  explicit PlanCanvas(QWidget* parent = nullptr);

  // A new plan: fitted if `fit` or if the operator has not panned or zoomed
  // since the last fit, else the view stays where the operator left it (a
  // new cut height, the same building).
  void SetPlan(const plan::FloorPlan& plan, bool fit);
  void ClearPlan(const QString& why);  // why: shown in the middle
  const std::optional<plan::FloorPlan>& plan() const { return plan_; }
  void Fit();
  // Pixels a metre; the plan point at the widget's centre.
  double scale() const { return scale_; }
  Eigen::Vector2d centre() const { return centre_; }
  // Plan metres <-> widget pixels.
  QPointF ToWidget(const Eigen::Vector2d& p) const;
  Eigen::Vector2d ToPlan(const QPointF& w) const;

  QSize sizeHint() const override { return {640, 480}; }

 protected:
  void paintEvent(QPaintEvent* event) override;
  void mousePressEvent(QMouseEvent* event) override;
  void mouseMoveEvent(QMouseEvent* event) override;
  void mouseReleaseEvent(QMouseEvent* event) override;
  void mouseDoubleClickEvent(QMouseEvent* event) override;
  void wheelEvent(QWheelEvent* event) override;
  void resizeEvent(QResizeEvent* event) override;
  void leaveEvent(QEvent* event) override;

 private:
  std::optional<plan::FloorPlan> plan_;
  QString empty_text_;
  double scale_ = 40.0;
  Eigen::Vector2d centre_ = Eigen::Vector2d::Zero();
  bool fitted_ = true;  // as Fit() leaves it: follows new plans and sizes
  bool dragging_ = false;
  QPointF drag_from_;
  std::optional<QPointF> cursor_;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PLAN_PLAN_CANVAS_H_
