// The plan view's drawing (ui/plan/plan_panel.h): a FloorPlan in 2D with
// QPainter, as a surveyor reads one: rooms as pale fills with their name
// and area, the section's points in grey, walls filled dark with their
// thickness, wall faces black (furniture's thin grey), openings as a blue
// door leaf and swing between their jambs with the width, inner dimensions
// as dimension lines with ticks and the length in metres, a 1 m grid, a
// scale bar, and the cursor's x, y.
//
// Plan x right, y up (the project's frame seen from above, as View > Top);
// pan, zoom and Fit as Canvas2d. A vertical section's line A -> A' is drawn
// over the plan with arrows that point the way its viewer looks (core/plan/
// section.h: along n, a -> b turned +90 deg). The operator draws a new one
// by dragging with Shift held, or with a plain drag while the section mode
// is on (SetSectionMode: the dock's Section button); Esc drops a drag under
// way (and then leaves the mode).
//
// GUI thread only.
#ifndef SWEEPSCAN_UI_PLAN_PLAN_CANVAS_H_
#define SWEEPSCAN_UI_PLAN_PLAN_CANVAS_H_

#include <Eigen/Core>
#include <QFont>
#include <QPointF>
#include <QPolygonF>
#include <QRectF>
#include <QString>
#include <optional>
#include <vector>

#include "core/plan/floor_plan.h"
#include "ui/plan/canvas_2d.h"

namespace sweepscan::ui {

// A vertical section's line in plan metres: A at a, A' at b.
struct SectionLine {
  Eigen::Vector2d a = Eigen::Vector2d::Zero(), b = Eigen::Vector2d::UnitX();
};

class PlanCanvas : public Canvas2d {
  Q_OBJECT
 public:
  // Shorter drags (widget pixels) are clicks, not section lines.
  static constexpr double kMinSectionPx = 8.0;

  explicit PlanCanvas(QWidget* parent = nullptr);

  // A new plan: fitted if `fit` or if the operator has not panned or zoomed
  // since the last fit, else the view stays where the operator left it (a
  // new cut height, the same building).
  void SetPlan(const plan::FloorPlan& plan, bool fit);
  void ClearPlan(const QString& why);  // why: shown in the middle
  const std::optional<plan::FloorPlan>& plan() const { return plan_; }
  // Why there is no plan (ClearPlan's `why`).
  const QString& empty_text() const { return empty_text_; }
  Eigen::Vector2d ToPlan(const QPointF& w) const { return ToModel(w); }

  // The section line drawn over the plan (none: nothing drawn).
  void SetSectionLine(const std::optional<SectionLine>& line);
  const std::optional<SectionLine>& section_line() const { return section_line_; }
  // A plain left drag draws a section line instead of panning.
  void SetSectionMode(bool on);
  bool section_mode() const { return section_mode_; }
  // A section line's drag under way (its rubber band).
  bool drawing_section() const { return drag_.has_value(); }

  // As the last paint left them (for tests): the dimensions' and doors'
  // figures and the dimension lines (widget pixels), and the room names
  // drawn (a name and the block of its two lines).
  struct RoomLabel {
    QString name;
    QRectF block;
  };
  static constexpr double kMinRoomFontPx = 7.0;  // smaller is not read: left out
  const std::vector<QPolygonF>& figures() const { return figures_; }
  // The doors' and dimensions' figures alone (their plates).
  const std::vector<QPolygonF>& label_plates() const { return labels_; }
  const std::vector<RoomLabel>& room_labels() const { return room_labels_; }

 signals:
  // The operator drew `section_line()`.
  void sectionLineDrawn();
  void sectionModeChanged(bool on);

 protected:
  bool Extent(Eigen::Vector2d* min, Eigen::Vector2d* max) const override;
  QString CursorText(const Eigen::Vector2d& at) const override;
  bool event(QEvent* event) override;
  void paintEvent(QPaintEvent* event) override;
  void mousePressEvent(QMouseEvent* event) override;
  void mouseMoveEvent(QMouseEvent* event) override;
  void mouseReleaseEvent(QMouseEvent* event) override;
  void keyPressEvent(QKeyEvent* event) override;

 private:
  void PaintRooms(QPainter* p, bool names) const;
  void PaintRoomName(QPainter* p, size_t index, const plan::Room& room) const;
  void PaintSectionLine(QPainter* p, const SectionLine& line, bool rubber_band) const;
  // Where PaintSectionLine draws `line` (widget pixels): a band along it,
  // its end strokes with their arrows, and the plates of "A" and "A'"
  // (bold `font`).
  std::vector<QPolygonF> SectionMarks(const SectionLine& line, QFont font) const;

  std::optional<plan::FloorPlan> plan_;
  QString empty_text_;
  std::optional<SectionLine> section_line_;
  std::optional<SectionLine> drag_;  // the line being drawn
  bool section_mode_ = false;
  mutable std::vector<QPolygonF> labels_;   // the figures' plates
  mutable std::vector<QPolygonF>
      figures_;  // and the dimension lines' bands and the section line's marks
  mutable std::vector<RoomLabel> room_labels_;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PLAN_PLAN_CANVAS_H_
