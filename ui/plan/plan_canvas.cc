#include "ui/plan/plan_canvas.h"

#include <QMouseEvent>
#include <QPainter>
#include <QPainterPath>
#include <QPolygonF>
#include <QWheelEvent>
#include <algorithm>
#include <cmath>

#include "core/plan/plan_writers.h"

namespace sweepscan::ui {
namespace {

constexpr double kMinScale = 2.0, kMaxScale = 4000.0;  // pixels a metre
const QColor kPoints(150, 156, 163);
const QColor kWallFill(60, 60, 64);
const QColor kFurniture(120, 120, 120);
const QColor kOpening(21, 101, 192);
const QColor kDimension(198, 40, 40);

// Qt's angle (degrees, counter-clockwise on screen) of a widget vector.
double ScreenAngle(const QPointF& v) { return std::atan2(-v.y(), v.x()) * 180.0 / M_PI; }

// Text centred at `at`, turned by `degrees` (kept upright), on a white
// plate; left out when longer than `room` pixels (the line it labels, at
// a zoom too small to read both).
void Label(QPainter* p, const QPointF& at, double degrees, const QString& text, const QColor& color,
           double room) {
  if (p->fontMetrics().horizontalAdvance(text) + 6 > room) return;
  while (degrees > 90.0) degrees -= 180.0;
  while (degrees <= -90.0) degrees += 180.0;
  p->save();
  p->translate(at);
  p->rotate(-degrees);
  const QRectF box = p->fontMetrics().boundingRect(text).adjusted(-3, -1, 3, 1);
  const QRectF plate(-box.width() / 2, -box.height() / 2, box.width(), box.height());
  p->setPen(Qt::NoPen);
  p->setBrush(QColor(255, 255, 255, 230));
  p->drawRoundedRect(plate, 2, 2);
  p->setPen(color);
  p->drawText(plate, Qt::AlignCenter, text);
  p->restore();
}

// 1, 2 or 5 times a power of ten, near `m`.
double NiceLength(double m) {
  const double e = std::pow(10.0, std::floor(std::log10(m)));
  for (double k : {1.0, 2.0, 5.0}) {
    if (k * e >= m) return k * e;
  }
  return 10.0 * e;
}

}  // namespace

PlanCanvas::PlanCanvas(QWidget* parent) : QWidget(parent) {
  setObjectName(QStringLiteral("planCanvas"));
  setMouseTracking(true);  // The cursor's coordinates.
  setFocusPolicy(Qt::StrongFocus);
  setMinimumSize(200, 150);
  setCursor(Qt::OpenHandCursor);
  setAutoFillBackground(false);
  empty_text_ = tr("No plan yet");
}

void PlanCanvas::SetPlan(const plan::FloorPlan& plan, bool fit) {
  plan_ = plan;
  empty_text_.clear();
  if (fit || fitted_) Fit();
  update();
}

void PlanCanvas::ClearPlan(const QString& why) {
  plan_.reset();
  empty_text_ = why;
  fitted_ = true;
  update();
}

void PlanCanvas::Fit() {
  if (!plan_) return;
  const Eigen::Vector2d size = (plan_->max - plan_->min).cwiseMax(Eigen::Vector2d(1.0, 1.0));
  centre_ = 0.5 * (plan_->min + plan_->max);
  // A margin of 40 px around: the dimension labels and the scale bar.
  const double sx = std::max(1.0, width() - 80.0) / size.x();
  const double sy = std::max(1.0, height() - 80.0) / size.y();
  scale_ = std::clamp(std::min(sx, sy), kMinScale, kMaxScale);
  fitted_ = true;
  update();
}

QPointF PlanCanvas::ToWidget(const Eigen::Vector2d& p) const {
  return {width() / 2.0 + (p.x() - centre_.x()) * scale_, height() / 2.0 - (p.y() - centre_.y()) * scale_};
}

Eigen::Vector2d PlanCanvas::ToPlan(const QPointF& w) const {
  return {centre_.x() + (w.x() - width() / 2.0) / scale_, centre_.y() - (w.y() - height() / 2.0) / scale_};
}

void PlanCanvas::paintEvent(QPaintEvent*) {
  QPainter p(this);
  p.fillRect(rect(), Qt::white);
  p.setRenderHint(QPainter::Antialiasing, true);
  if (!plan_) {
    p.setPen(QColor(110, 110, 110));
    p.drawText(rect().adjusted(20, 20, -20, -20), Qt::AlignCenter | Qt::TextWordWrap, empty_text_);
    return;
  }
  const plan::FloorPlan& plan = *plan_;
  // The grid: 1 m, or 10 m when 1 m is too dense to read.
  const double step = scale_ >= 12.0 ? 1.0 : 10.0;
  const Eigen::Vector2d lo = ToPlan(QPointF(0, height())), hi = ToPlan(QPointF(width(), 0));
  p.setPen(QPen(QColor(232, 235, 240), 1));
  for (double x = std::ceil(lo.x() / step) * step; x <= hi.x(); x += step) {
    p.drawLine(ToWidget({x, lo.y()}), ToWidget({x, hi.y()}));
  }
  for (double y = std::ceil(lo.y() / step) * step; y <= hi.y(); y += step) {
    p.drawLine(ToWidget({lo.x(), y}), ToWidget({hi.x(), y}));
  }
  // The section's points (decimated to one a 2 cm cell by the plan).
  QPolygonF points;
  points.reserve(static_cast<int>(plan.points.size()));
  const QRectF inside = QRectF(rect()).adjusted(-2, -2, 2, 2);
  for (const Eigen::Vector2d& q : plan.points) {
    const QPointF w = ToWidget(q);
    if (inside.contains(w)) points << w;
  }
  p.setPen(QPen(kPoints, std::clamp(0.02 * scale_, 1.5, 3.0), Qt::SolidLine, Qt::RoundCap));
  p.drawPoints(points);
  // Walls: their thickness filled.
  p.setPen(Qt::NoPen);
  p.setBrush(kWallFill);
  for (const plan::Wall& w : plan.walls) {
    const Eigen::Vector2d along = (w.b - w.a).normalized();
    const Eigen::Vector2d n(-along.y(), along.x());
    const Eigen::Vector2d h = 0.5 * w.thickness_m * n;
    p.drawPolygon(QPolygonF({ToWidget(w.a + h), ToWidget(w.b + h), ToWidget(w.b - h), ToWidget(w.a - h)}));
  }
  p.setBrush(Qt::NoBrush);
  // Faces: walls' black, furniture's thin grey.
  for (const plan::WallFace& f : plan.faces) {
    p.setPen(f.structural ? QPen(Qt::black, 2.0, Qt::SolidLine, Qt::FlatCap)
                          : QPen(kFurniture, 1.0, Qt::SolidLine, Qt::FlatCap));
    p.drawLine(ToWidget(f.a), ToWidget(f.b));
  }
  // Openings: a door leaf at a (the jamb), its swing to b into the free side, the width.
  for (const plan::Opening& o : plan.openings) {
    const Eigen::Vector2d along = o.b - o.a;
    Eigen::Vector2d n(-along.y(), along.x());
    n.normalize();
    if (o.face >= 0 && o.face < static_cast<int>(plan.faces.size()) && plan.faces[o.face].normal_known &&
        plan.faces[o.face].normal.dot(n) < 0) {
      n = -n;
    }
    const QPointF a = ToWidget(o.a), b = ToWidget(o.b), leaf = ToWidget(o.a + o.width_m * n);
    p.setPen(QPen(Qt::white, 4.0));  // The gap in the wall's line, as drawings leave it.
    p.drawLine(a, b);
    p.setPen(QPen(kOpening, 1.0, Qt::DashLine));
    p.drawLine(a, b);
    p.setPen(QPen(kOpening, 1.6));
    p.drawLine(a, leaf);
    const double r = o.width_m * scale_;
    const double start = ScreenAngle(leaf - a), end = ScreenAngle(b - a);
    double span = end - start;
    while (span > 180.0) span -= 360.0;
    while (span <= -180.0) span += 360.0;
    p.setPen(QPen(kOpening, 1.0));
    p.drawArc(QRectF(a.x() - r, a.y() - r, 2 * r, 2 * r), static_cast<int>(start * 16), static_cast<int>(span * 16));
    const QPointF mid = ToWidget(0.5 * (o.a + o.b) - 0.3 * o.width_m * n);
    Label(&p, mid, ScreenAngle(b - a), QString::fromStdString(plan::FormatMetres(o.width_m)), kOpening,
          1.5 * r);
  }
  // Dimensions: the line, slashes at its ends, the length above its middle.
  for (const plan::Dimension& d : plan.dimensions) {
    const QPointF a = ToWidget(d.a), b = ToWidget(d.b);
    const QPointF u = (b - a) / std::max(1e-9, std::hypot(b.x() - a.x(), b.y() - a.y()));
    const QPointF slash = 5.0 * (u + QPointF(-u.y(), u.x()));
    p.setPen(QPen(kDimension, 1.0));
    p.drawLine(a, b);
    p.setPen(QPen(kDimension, 1.6));
    p.drawLine(a - slash, a + slash);
    p.drawLine(b - slash, b + slash);
    Label(&p, 0.5 * (a + b), ScreenAngle(b - a), QString::fromStdString(plan::FormatMetres(d.distance_m)) + tr(" m"),
          kDimension, std::hypot(b.x() - a.x(), b.y() - a.y()) - 16.0);
  }
  // The scale bar, bottom left.
  const double bar_m = NiceLength(100.0 / scale_);
  const double bar_px = bar_m * scale_;
  const QPointF origin(16, height() - 18);
  p.setPen(QPen(Qt::black, 2.0, Qt::SolidLine, Qt::FlatCap));
  p.drawLine(origin, origin + QPointF(bar_px, 0));
  p.drawLine(origin + QPointF(0, -5), origin + QPointF(0, 5));
  p.drawLine(origin + QPointF(bar_px, -5), origin + QPointF(bar_px, 5));
  p.drawText(QPointF(origin.x() + bar_px + 8, origin.y() + 5),
             bar_m >= 1.0 ? tr("%1 m").arg(bar_m) : tr("%1 cm").arg(bar_m * 100.0));
  // Where the cursor is, bottom right.
  if (cursor_) {
    const Eigen::Vector2d c = ToPlan(*cursor_);
    const QString text = tr("x %1  y %2 m").arg(c.x(), 0, 'f', 2).arg(c.y(), 0, 'f', 2);
    p.setPen(QColor(60, 60, 60));
    p.drawText(QRectF(0, height() - 28, width() - 12, 24), Qt::AlignRight | Qt::AlignVCenter, text);
  }
}

void PlanCanvas::mousePressEvent(QMouseEvent* event) {
  if (event->button() == Qt::LeftButton) {
    dragging_ = true;
    drag_from_ = event->localPos();
    setCursor(Qt::ClosedHandCursor);
    event->accept();
    return;
  }
  QWidget::mousePressEvent(event);
}

void PlanCanvas::mouseMoveEvent(QMouseEvent* event) {
  cursor_ = event->localPos();
  if (dragging_) {
    const QPointF d = event->localPos() - drag_from_;
    drag_from_ = event->localPos();
    centre_ -= Eigen::Vector2d(d.x(), -d.y()) / scale_;
    fitted_ = false;
  }
  update();
}

void PlanCanvas::mouseReleaseEvent(QMouseEvent* event) {
  if (event->button() == Qt::LeftButton && dragging_) {
    dragging_ = false;
    setCursor(Qt::OpenHandCursor);
  }
  QWidget::mouseReleaseEvent(event);
}

void PlanCanvas::mouseDoubleClickEvent(QMouseEvent*) { Fit(); }

void PlanCanvas::wheelEvent(QWheelEvent* event) {
  // About the cursor: the plan point under it stays under it.
  const QPointF at = event->position();
  const Eigen::Vector2d before = ToPlan(at);
  const double steps = event->angleDelta().y() / 120.0;
  scale_ = std::clamp(scale_ * std::pow(1.2, steps), kMinScale, kMaxScale);
  const Eigen::Vector2d after = ToPlan(at);
  centre_ += before - after;
  fitted_ = false;
  event->accept();
  update();
}

void PlanCanvas::resizeEvent(QResizeEvent* event) {
  QWidget::resizeEvent(event);
  // Not moved by the operator since the last fit: fitted to the new size.
  if (plan_ && fitted_) Fit();
}

void PlanCanvas::leaveEvent(QEvent* event) {
  cursor_.reset();
  update();
  QWidget::leaveEvent(event);
}

}  // namespace sweepscan::ui
