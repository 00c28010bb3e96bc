#include "ui/plan/canvas_2d.h"

#include <QMouseEvent>
#include <QPainter>
#include <QTransform>
#include <QWheelEvent>
#include <algorithm>
#include <cmath>

#include "core/plan/plan_writers.h"

namespace sweepscan::ui {
namespace {

constexpr double kMinScale = 2.0, kMaxScale = 4000.0;  // pixels a metre

// 1, 2 or 5 times a power of ten, near `m`.
double NiceLength(double m) {
  const double e = std::pow(10.0, std::floor(std::log10(m)));
  for (double k : {1.0, 2.0, 5.0}) {
    if (k * e >= m) return k * e;
  }
  return 10.0 * e;
}

// A label's turn (degrees, counter-clockwise on screen) so that it reads
// left to right or bottom to top, as the exported drawings do (core/plan's
// writers, drawing practice: read from the bottom or the right). A line
// within kUprightBandDeg of vertical counts as vertical: a wall 0.01 deg
// off plumb had its figure read top to bottom on screen, bottom to top on
// paper.
double Readable(double degrees) {
  while (degrees > 90.0 + plan::kUprightBandDeg) degrees -= 180.0;
  while (degrees <= -90.0 + plan::kUprightBandDeg) degrees += 180.0;
  return degrees;
}

}  // namespace

double ScreenAngle(const QPointF& v) { return std::atan2(-v.y(), v.x()) * 180.0 / M_PI; }

QPolygonF LabelPlate(const QFontMetrics& metrics, const QPointF& at, double degrees,
                     const QString& text) {
  degrees = Readable(degrees);
  const QRectF box = metrics.boundingRect(text).adjusted(-3, -1, 3, 1);
  QTransform t;
  t.translate(at.x(), at.y());
  t.rotate(-degrees);
  return t.map(QPolygonF(QRectF(-box.width() / 2, -box.height() / 2, box.width(), box.height())));
}

bool ConvexOverlap(const QPolygonF& a, const QPolygonF& b) {
  // Separating axis theorem: two convex polygons are apart exactly when
  // one of their edges' normals separates their projections.
  if (a.isEmpty() || b.isEmpty() || !a.boundingRect().intersects(b.boundingRect())) return false;
  for (const QPolygonF* edges : {&a, &b}) {
    const int n = edges->size();
    for (int i = 0; i < n; ++i) {
      const QPointF e = edges->at((i + 1) % n) - edges->at(i);
      const QPointF axis(-e.y(), e.x());
      if (axis.manhattanLength() < 1e-9) continue;  // a closing point repeated
      double a_min = 1e300, a_max = -1e300, b_min = 1e300, b_max = -1e300;
      for (const QPointF& q : a) {
        const double d = QPointF::dotProduct(q, axis);
        a_min = std::min(a_min, d);
        a_max = std::max(a_max, d);
      }
      for (const QPointF& q : b) {
        const double d = QPointF::dotProduct(q, axis);
        b_min = std::min(b_min, d);
        b_max = std::max(b_max, d);
      }
      if (a_max <= b_min || b_max <= a_min) return false;
    }
  }
  return true;
}

void PaintLabel(QPainter* p, const QPointF& at, double degrees, const QString& text,
                const QColor& color, double room, QPolygonF* painted) {
  if (p->fontMetrics().horizontalAdvance(text) + 6 > room) return;
  degrees = Readable(degrees);
  p->save();
  p->translate(at);
  p->rotate(-degrees);
  const QRectF box = p->fontMetrics().boundingRect(text).adjusted(-3, -1, 3, 1);
  const QRectF plate(-box.width() / 2, -box.height() / 2, box.width(), box.height());
  if (painted != nullptr) *painted = p->transform().map(QPolygonF(plate));
  p->setPen(Qt::NoPen);
  p->setBrush(QColor(255, 255, 255, 230));
  p->drawRoundedRect(plate, 2, 2);
  p->setPen(color);
  p->drawText(plate, Qt::AlignCenter, text);
  p->restore();
}

Canvas2d::Canvas2d(QWidget* parent) : QWidget(parent) {
  setMouseTracking(true);  // The cursor's coordinates.
  setFocusPolicy(Qt::StrongFocus);
  setMinimumSize(200, 150);
  setCursor(Qt::OpenHandCursor);
  setAutoFillBackground(false);
}

void Canvas2d::Follow(bool fit) {
  if (fit || fitted_) Fit();
  update();
}

void Canvas2d::Fit() {
  Eigen::Vector2d min, max;
  if (!Extent(&min, &max)) return;
  const Eigen::Vector2d size = (max - min).cwiseMax(Eigen::Vector2d(1.0, 1.0));
  centre_ = 0.5 * (min + max);
  const double margin = 2.0 * FitMargin();
  const double sx = std::max(1.0, width() - margin) / size.x();
  const double sy = std::max(1.0, height() - margin) / size.y();
  scale_ = std::clamp(std::min(sx, sy), kMinScale, kMaxScale);
  fitted_ = true;
  update();
}

QPointF Canvas2d::ToWidget(const Eigen::Vector2d& p) const {
  return {width() / 2.0 + (p.x() - centre_.x()) * scale_, height() / 2.0 - (p.y() - centre_.y()) * scale_};
}

Eigen::Vector2d Canvas2d::ToModel(const QPointF& w) const {
  return {centre_.x() + (w.x() - width() / 2.0) / scale_, centre_.y() - (w.y() - height() / 2.0) / scale_};
}

bool Canvas2d::PaintBackground(QPainter* p, bool content, const QString& empty_text) const {
  p->fillRect(rect(), Qt::white);
  if (!content) {
    p->setPen(QColor(110, 110, 110));
    p->drawText(rect().adjusted(20, 20, -20, -20), Qt::AlignCenter | Qt::TextWordWrap, empty_text);
    return false;
  }
  p->setRenderHint(QPainter::Antialiasing, true);
  const double step = GridStep();
  const Eigen::Vector2d lo = ToModel(QPointF(0, height())), hi = ToModel(QPointF(width(), 0));
  p->setPen(QPen(QColor(232, 235, 240), 1));
  for (double x = std::ceil(lo.x() / step) * step; x <= hi.x(); x += step) {
    p->drawLine(ToWidget({x, lo.y()}), ToWidget({x, hi.y()}));
  }
  for (double y = std::ceil(lo.y() / step) * step; y <= hi.y(); y += step) {
    p->drawLine(ToWidget({lo.x(), y}), ToWidget({hi.x(), y}));
  }
  return true;
}

void Canvas2d::PaintScaleBar(QPainter* p) const {
  const double bar_m = NiceLength(100.0 / scale_);
  const double bar_px = bar_m * scale_;
  const QPointF origin(16, height() - 18);
  p->setPen(QPen(Qt::black, 2.0, Qt::SolidLine, Qt::FlatCap));
  p->drawLine(origin, origin + QPointF(bar_px, 0));
  p->drawLine(origin + QPointF(0, -5), origin + QPointF(0, 5));
  p->drawLine(origin + QPointF(bar_px, -5), origin + QPointF(bar_px, 5));
  p->drawText(QPointF(origin.x() + bar_px + 8, origin.y() + 5),
              bar_m >= 1.0 ? tr("%1 m").arg(bar_m) : tr("%1 cm").arg(bar_m * 100.0));
}

void Canvas2d::PaintCursor(QPainter* p) const {
  if (!cursor_) return;
  p->setPen(QColor(60, 60, 60));
  p->drawText(QRectF(0, height() - 28, width() - 12, 24), Qt::AlignRight | Qt::AlignVCenter,
              CursorText(ToModel(*cursor_)));
}

void Canvas2d::mousePressEvent(QMouseEvent* event) {
  if (event->button() == Qt::LeftButton) {
    panning_ = true;
    pan_from_ = event->localPos();
    setCursor(Qt::ClosedHandCursor);
    event->accept();
    return;
  }
  QWidget::mousePressEvent(event);
}

void Canvas2d::mouseMoveEvent(QMouseEvent* event) {
  cursor_ = event->localPos();
  if (panning_) {
    const QPointF d = event->localPos() - pan_from_;
    pan_from_ = event->localPos();
    centre_ -= Eigen::Vector2d(d.x(), -d.y()) / scale_;
    fitted_ = false;
  }
  update();
}

void Canvas2d::mouseReleaseEvent(QMouseEvent* event) {
  if (event->button() == Qt::LeftButton && panning_) {
    panning_ = false;
    setCursor(Qt::OpenHandCursor);
  }
  QWidget::mouseReleaseEvent(event);
}

void Canvas2d::mouseDoubleClickEvent(QMouseEvent*) { Fit(); }

void Canvas2d::wheelEvent(QWheelEvent* event) {
  // About the cursor: the model point under it stays under it.
  const QPointF at = event->position();
  const Eigen::Vector2d before = ToModel(at);
  const double steps = event->angleDelta().y() / 120.0;
  scale_ = std::clamp(scale_ * std::pow(1.2, steps), kMinScale, kMaxScale);
  const Eigen::Vector2d after = ToModel(at);
  centre_ += before - after;
  fitted_ = false;
  event->accept();
  update();
}

void Canvas2d::resizeEvent(QResizeEvent* event) {
  QWidget::resizeEvent(event);
  // Not moved by the operator since the last fit: fitted to the new size.
  if (fitted_) Fit();
}

void Canvas2d::leaveEvent(QEvent* event) {
  cursor_.reset();
  update();
  QWidget::leaveEvent(event);
}

}  // namespace sweepscan::ui
