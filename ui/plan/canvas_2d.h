// What the plan view's two drawings share (plan_canvas.h: the plan seen
// from above; section_canvas.h: a vertical section seen from its side): a
// model in metres drawn at one scale on both axes, x (or s) right and y (or
// z) up; left drag pans, the wheel zooms about the cursor, a double click or
// Fit() shows the whole drawing; the view follows new content until the
// operator pans or zooms. The helpers draw what both show the same way: a
// light grid, a scale bar, the cursor's coordinates, text of a constant
// size on screen.
//
// GUI thread only.
#ifndef SWEEPSCAN_UI_PLAN_CANVAS_2D_H_
#define SWEEPSCAN_UI_PLAN_CANVAS_2D_H_

#include <Eigen/Core>
#include <QColor>
#include <QPointF>
#include <QString>
#include <QWidget>
#include <optional>

class QPainter;
class QFontMetrics;
class QPolygonF;

namespace sweepscan::ui {

class Canvas2d : public QWidget {
  Q_OBJECT
 public:
  explicit Canvas2d(QWidget* parent = nullptr);

  // The whole drawing in the view (nothing when there is nothing to draw).
  void Fit();
  // Pixels a metre; the model point at the widget's centre.
  double scale() const { return scale_; }
  Eigen::Vector2d centre() const { return centre_; }
  // Model metres <-> widget pixels.
  QPointF ToWidget(const Eigen::Vector2d& p) const;
  Eigen::Vector2d ToModel(const QPointF& w) const;

  QSize sizeHint() const override { return {640, 480}; }

 signals:
  // New content, or none (what the dock's buttons act on).
  void contentChanged();

 protected:
  // The drawing's extent in model metres; false when there is none.
  virtual bool Extent(Eigen::Vector2d* min, Eigen::Vector2d* max) const = 0;
  // The cursor's model coordinates as the bottom right corner says them.
  virtual QString CursorText(const Eigen::Vector2d& at) const = 0;
  // Pixels Fit() leaves around the extent for what is drawn outside it.
  virtual int FitMargin() const { return 40; }

  // New content: fitted if `fit` or if the operator has not panned or
  // zoomed since the last fit, else the view stays where it was.
  void Follow(bool fit);
  // Nothing to draw: the next content is fitted.
  void Unfollow() { fitted_ = true; }
  const std::optional<QPointF>& cursor() const { return cursor_; }

  // With `content`: white, antialiased, lines every metre (every 10 m when
  // 1 m is too dense to read); true. Else white with `empty_text` in the
  // middle; false (nothing more to draw).
  bool PaintBackground(QPainter* p, bool content, const QString& empty_text) const;
  // Bottom left: a 1, 2 or 5 x 10^k bar of about 100 px with its length.
  void PaintScaleBar(QPainter* p) const;
  // Bottom right: CursorText() of the cursor's point, while over the widget.
  void PaintCursor(QPainter* p) const;
  // The grid's step (m) at this zoom.
  double GridStep() const { return scale_ >= 12.0 ? 1.0 : 10.0; }

  void mousePressEvent(QMouseEvent* event) override;
  void mouseMoveEvent(QMouseEvent* event) override;
  void mouseReleaseEvent(QMouseEvent* event) override;
  void mouseDoubleClickEvent(QMouseEvent* event) override;
  void wheelEvent(QWheelEvent* event) override;
  void resizeEvent(QResizeEvent* event) override;
  void leaveEvent(QEvent* event) override;

 private:
  double scale_ = 40.0;
  Eigen::Vector2d centre_ = Eigen::Vector2d::Zero();
  bool fitted_ = true;  // as Fit() leaves it: follows new content and sizes
  bool panning_ = false;
  QPointF pan_from_;
  std::optional<QPointF> cursor_;
};

// Qt's angle (degrees, counter-clockwise on screen) of a widget vector.
double ScreenAngle(const QPointF& v);

// Text centred at `at`, turned by `degrees` (made to read left to right
// or bottom to top, as the exported drawings read), on a white
// plate; left out when longer than `room` pixels (the line it labels, at
// a zoom too small to read both). The plate drawn (widget pixels) goes to
// `painted` if given; it is left alone when nothing is drawn.
void PaintLabel(QPainter* p, const QPointF& at, double degrees, const QString& text,
                const QColor& color, double room = 1e9, QPolygonF* painted = nullptr);

// The plate PaintLabel would draw (widget pixels) with these metrics,
// without drawing it: where a label goes is chosen before it is drawn.
QPolygonF LabelPlate(const QFontMetrics& metrics, const QPointF& at, double degrees,
                     const QString& text);

// Whether two convex polygons (label plates, a line's band) overlap by
// more than a touch.
bool ConvexOverlap(const QPolygonF& a, const QPolygonF& b);

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PLAN_CANVAS_2D_H_
