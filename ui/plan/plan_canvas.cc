#include "ui/plan/plan_canvas.h"

#include <QFontInfo>
#include <QFontMetricsF>
#include <QKeyEvent>
#include <QMouseEvent>
#include <QPainter>
#include <QPainterPath>
#include <QPolygonF>
#include <QTransform>
#include <algorithm>
#include <cmath>

#include "core/plan/plan_writers.h"

namespace sweepscan::ui {
namespace {

const QColor kPoints(150, 156, 163);
const QColor kWallFill(60, 60, 64);
const QColor kFurniture(120, 120, 120);
const QColor kOpening(21, 101, 192);
const QColor kDimension(198, 40, 40);
const QColor kRoomText(40, 56, 72);
const QColor kSection(106, 27, 154);  // the section line: violet, apart from the plan's colours
// Its end marks (pixels): a stroke along the viewing direction, an arrow
// at its tip, a half-width, and the letters' distance before and after
// the line's ends. PaintSectionLine draws them; SectionMarks keeps the
// room names off them.
constexpr double kSectionStroke = 22.0, kSectionArrow = 6.0, kSectionArrowHalf = 5.0,
                 kSectionLetterGap = 14.0;

// A pale, translucent tint for room `i`: hues 137.5 deg apart (the golden
// angle) so that neighbours, numbered south to north, differ.
QColor RoomTint(size_t i) {
  return QColor::fromHsv(static_cast<int>(std::fmod(200.0 + 137.5 * static_cast<double>(i), 360.0)), 70, 245, 110);
}

}  // namespace

PlanCanvas::PlanCanvas(QWidget* parent) : Canvas2d(parent) {
  setObjectName(QStringLiteral("planCanvas"));
  empty_text_ = tr("No plan yet");
}

void PlanCanvas::SetPlan(const plan::FloorPlan& plan, bool fit) {
  plan_ = plan;
  empty_text_.clear();
  Follow(fit);
  emit contentChanged();
}

void PlanCanvas::ClearPlan(const QString& why) {
  plan_.reset();
  drag_.reset();
  empty_text_ = why;
  Unfollow();
  update();
  emit contentChanged();
}

bool PlanCanvas::Extent(Eigen::Vector2d* min, Eigen::Vector2d* max) const {
  if (!plan_) return false;
  *min = plan_->min;
  *max = plan_->max;
  return true;
}

QString PlanCanvas::CursorText(const Eigen::Vector2d& at) const {
  return tr("x %1  y %2 m").arg(at.x(), 0, 'f', 2).arg(at.y(), 0, 'f', 2);
}

void PlanCanvas::SetSectionLine(const std::optional<SectionLine>& line) {
  section_line_ = line;
  update();
}

void PlanCanvas::SetSectionMode(bool on) {
  if (on == section_mode_) return;
  section_mode_ = on;
  if (!on) drag_.reset();
  setCursor(on ? Qt::CrossCursor : Qt::OpenHandCursor);
  update();
  emit sectionModeChanged(on);
}

void PlanCanvas::paintEvent(QPaintEvent*) {
  QPainter p(this);
  if (!PaintBackground(&p, plan_.has_value(), empty_text_)) return;
  const plan::FloorPlan& plan = *plan_;
  labels_.clear();
  figures_.clear();
  room_labels_.clear();
  PaintRooms(&p, false);  // Under everything: the fills.
  // The section's points (decimated to one a 2 cm cell by the plan).
  QPolygonF points;
  points.reserve(static_cast<int>(plan.points.size()));
  const QRectF inside = QRectF(rect()).adjusted(-2, -2, 2, 2);
  for (const Eigen::Vector2d& q : plan.points) {
    const QPointF w = ToWidget(q);
    if (inside.contains(w)) points << w;
  }
  p.setPen(QPen(kPoints, std::clamp(0.02 * scale(), 1.5, 3.0), Qt::SolidLine, Qt::RoundCap));
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
    const double r = o.width_m * scale();
    const double start = ScreenAngle(leaf - a), end = ScreenAngle(b - a);
    double span = end - start;
    while (span > 180.0) span -= 360.0;
    while (span <= -180.0) span += 360.0;
    p.setPen(QPen(kOpening, 1.0));
    p.drawArc(QRectF(a.x() - r, a.y() - r, 2 * r, 2 * r), static_cast<int>(start * 16), static_cast<int>(span * 16));
    const QPointF mid = ToWidget(0.5 * (o.a + o.b) - 0.3 * o.width_m * n);
    QPolygonF plate;
    PaintLabel(&p, mid, ScreenAngle(b - a), QString::fromStdString(plan::FormatMetres(o.width_m)),
               kOpening, 1.5 * r, &plate);
    if (!plate.isEmpty()) labels_.push_back(plate);
  }
  // Dimensions: the lines and their end slashes first, then each length
  // over its line's middle, slid along the line off the figures placed
  // before it, or left out when nowhere on its line is clear (a room's two
  // dimensions cross near their middles, and their figures covered each
  // other); a later line never runs over an earlier figure.
  std::vector<QPolygonF> bands;
  for (const plan::Dimension& d : plan.dimensions) {
    const QPointF a = ToWidget(d.a), b = ToWidget(d.b);
    const QPointF u = (b - a) / std::max(1e-9, std::hypot(b.x() - a.x(), b.y() - a.y()));
    const QPointF slash = 5.0 * (u + QPointF(-u.y(), u.x()));
    p.setPen(QPen(kDimension, 1.0));
    p.drawLine(a, b);
    p.setPen(QPen(kDimension, 1.6));
    p.drawLine(a - slash, a + slash);
    p.drawLine(b - slash, b + slash);
    // The line itself (and its end slashes) is kept clear of the names.
    const QPointF side = 3.0 * QPointF(-u.y(), u.x());
    bands.push_back(QPolygonF(
        {a - 5.0 * u + side, b + 5.0 * u + side, b + 5.0 * u - side, a - 5.0 * u - side}));
  }
  for (const plan::Dimension& d : plan.dimensions) {
    const QPointF a = ToWidget(d.a), b = ToWidget(d.b);
    const double length = std::hypot(b.x() - a.x(), b.y() - a.y());
    const QPointF u = (b - a) / std::max(1e-9, length);
    const QString text = QString::fromStdString(plan::FormatMetres(d.distance_m)) + tr(" m");
    const double room = length - 16.0, width = p.fontMetrics().horizontalAdvance(text) + 6.0;
    if (width > room) continue;  // PaintLabel leaves it out too
    const double slack = 0.5 * (room - width), step = 0.25 * width;
    std::optional<QPointF> at;
    for (int k = 0; !at && k * step <= slack; ++k) {
      bool clear = false;
      for (const double sign : {1.0, -1.0}) {
        const QPointF there = 0.5 * (a + b) + sign * k * step * u;
        const QPolygonF plate = LabelPlate(p.fontMetrics(), there, ScreenAngle(b - a), text);
        clear = std::none_of(labels_.begin(), labels_.end(),
                             [&](const QPolygonF& other) { return ConvexOverlap(plate, other); });
        if (clear) {
          at = there;
          break;
        }
        if (k == 0) break;
      }
    }
    // Nowhere clear on its line (zoomed out): left out, as a line too
    // short for its figure is; zooming in brings it back.
    if (!at) continue;
    QPolygonF plate;
    PaintLabel(&p, *at, ScreenAngle(b - a), text, kDimension, room, &plate);
    if (!plate.isEmpty()) labels_.push_back(plate);
  }
  figures_ = labels_;
  figures_.insert(figures_.end(), bands.begin(), bands.end());
  // The section line drawn over the names, so the names keep clear of it
  // (its "A" covered "31.2 m²" of the office floor's Room 4). Not the
  // line being dragged: the names would jump at every move.
  if (section_line_) {
    const std::vector<QPolygonF> marks = SectionMarks(*section_line_, p.font());
    figures_.insert(figures_.end(), marks.begin(), marks.end());
  }
  PaintRooms(&p, true);  // The names where they clear the figures.
  if (section_line_ && !drag_) PaintSectionLine(&p, *section_line_, false);
  if (drag_) PaintSectionLine(&p, *drag_, true);
  PaintScaleBar(&p);
  PaintCursor(&p);
}

void PlanCanvas::PaintRooms(QPainter* p, bool names) const {
  const std::vector<plan::Room>& rooms = plan_->rooms;
  for (size_t i = 0; i < rooms.size(); ++i) {
    const plan::Room& room = rooms[i];
    if (room.outline.size() < 3) continue;
    if (!names) {
      QPolygonF outline;
      for (const Eigen::Vector2d& v : room.outline) outline << ToWidget(v);
      const QColor tint = RoomTint(i);
      p->setPen(QPen(tint.darker(130), 1.0));
      p->setBrush(tint);
      p->drawPolygon(outline);
      p->setBrush(Qt::NoBrush);
      continue;
    }
    PaintRoomName(p, i, room);
  }
}

void PlanCanvas::PaintRoomName(QPainter* p, size_t index, const plan::Room& room) const {
  // The name over the area in the largest font, from the view's down to
  // kMinRoomFontPx, across the plan or else along it (a corridor), whose
  // block lies inside the room's outline and clear of every figure and
  // dimension line drawn (figures_): at core/plan's label
  // point if it is clear there, else at the clear point nearest to it (the
  // rooms' dimensions cross at their middles, where the label point is).
  // None fits: no name (the area is in the summary; zooming in brings it
  // back). The names once covered the dimensions' figures at any zoom and
  // spilled across walls when zoomed out.
  QPolygonF outline;
  for (const Eigen::Vector2d& v : room.outline) outline << ToWidget(v);
  const QString name = tr("Room %1").arg(index + 1);
  const QString area = tr("%1 m²").arg(room.area_m2, 0, 'f', 2);
  const QPointF label = ToWidget(room.label);
  // Candidate centres: the label point, then a grid over the room (at most
  // 40 x 40 points) by distance from it.
  const QRectF bounds = outline.boundingRect().intersected(QRectF(rect()));
  if (bounds.isEmpty()) return;
  // Each way its own step: across a corridor of 40 px a square grid's
  // 9 px steps missed the strip of 5 px where its name fits.
  const double step_x = std::max(2.0, bounds.width() / 40.0),
               step_y = std::max(2.0, bounds.height() / 40.0);
  std::vector<QPointF> candidates{label};
  for (double y = bounds.top() + 0.5 * step_y; y < bounds.bottom(); y += step_y) {
    for (double x = bounds.left() + 0.5 * step_x; x < bounds.right(); x += step_x) {
      if (outline.containsPoint({x, y}, Qt::OddEvenFill)) candidates.emplace_back(x, y);
    }
  }
  const auto distance = [&](const QPointF& q) { return QPointF::dotProduct(q - label, q - label); };
  std::sort(candidates.begin() + 1, candidates.end(),
            [&](const QPointF& l, const QPointF& r) { return distance(l) < distance(r); });
  QFont font = p->font();
  // The view's own size (the dimensions' figures), not its line height.
  const int base = QFontInfo(font).pixelSize();
  // Across the plan first, at every size; then along it, turned as a
  // vertical dimension's figure is: a corridor (2 m) is narrower than its
  // name across it until zoomed far in, but long. Last the name and area
  // on one line, along then across: half the height, which a corridor
  // between its dimension lines has at the default zoom (it had no name).
  const QString one_line = name + QStringLiteral(" · ") + area;
  for (const auto& [degrees, lines] : {std::pair{0.0, 2}, {90.0, 2}, {90.0, 1}, {0.0, 1}}) {
    for (double px = base; px >= kMinRoomFontPx; px -= 1.0) {
      font.setPixelSize(static_cast<int>(px));
      const QFontMetricsF m(font);
      const double line = m.height() + 2.0;
      const double width =
          (lines == 1 ? m.horizontalAdvance(one_line)
                      : std::max(m.horizontalAdvance(name), m.horizontalAdvance(area))) +
          6.0;
      const double height = lines * line + 2.0;
      const QSizeF size = degrees == 0.0 ? QSizeF(width, height) : QSizeF(height, width);
      for (const QPointF& at : candidates) {
        const QRectF block(at - QPointF(0.5 * size.width(), 0.5 * size.height()), size);
        const QPolygonF box(block.adjusted(-1, -1, 1, 1));  // clear by a pixel, not touching
        bool fits = true;
        for (const QPointF& c :
             {block.topLeft(), block.topRight(), block.bottomLeft(), block.bottomRight()}) {
          fits = fits && outline.containsPoint(c, Qt::OddEvenFill);
        }
        for (size_t k = 0; fits && k < figures_.size(); ++k) {
          fits = !ConvexOverlap(box, figures_[k]);
        }
        if (!fits) continue;
        // The name's line, then the area's below it in the text's frame.
        const QPointF down = QTransform().rotate(-degrees).map(QPointF(0.0, 0.5 * line));
        p->save();
        p->setFont(font);
        if (lines == 1) {
          PaintLabel(p, at, degrees, one_line, kRoomText);
        } else {
          PaintLabel(p, at - down, degrees, name, kRoomText);
          PaintLabel(p, at + down, degrees, area, kRoomText);
        }
        p->restore();
        room_labels_.push_back({name, block});
        return;
      }
    }
  }
}

std::vector<QPolygonF> PlanCanvas::SectionMarks(const SectionLine& line, QFont font) const {
  const QPointF a = ToWidget(line.a), b = ToWidget(line.b);
  const double length = std::hypot(b.x() - a.x(), b.y() - a.y());
  if (length < 1.0) return {};
  const QPointF u = (b - a) / length;
  const QPointF n(u.y(), -u.x());
  const QPointF side = 3.0 * QPointF(-u.y(), u.x());
  std::vector<QPolygonF> marks{QPolygonF({a + side, b + side, b - side, a - side})};
  for (const QPointF& end : {a, b}) {  // the stroke and its arrow
    const QPointF tip = end + (kSectionStroke + kSectionArrow) * n;
    const QPointF half = kSectionArrowHalf * u;
    marks.push_back(QPolygonF({end - half, tip - half, tip + half, end + half}));
  }
  font.setBold(true);
  const QFontMetrics bold(font);
  marks.push_back(LabelPlate(bold, a - kSectionLetterGap * u, 0.0, QStringLiteral("A")));
  marks.push_back(LabelPlate(bold, b + kSectionLetterGap * u, 0.0, QStringLiteral("A'")));
  return marks;
}

void PlanCanvas::PaintSectionLine(QPainter* p, const SectionLine& line, bool rubber_band) const {
  const QPointF a = ToWidget(line.a), b = ToWidget(line.b);
  const double length = std::hypot(b.x() - a.x(), b.y() - a.y());
  if (length < 1.0) return;
  // On screen, y down: the plan's u = (b - a) / |b - a| and its +90 deg
  // turn n (the way the section's viewer looks) have their y negated.
  const QPointF u = (b - a) / length;
  const QPointF n(u.y(), -u.x());
  p->setPen(QPen(kSection, rubber_band ? 1.5 : 2.0, Qt::DashDotLine, Qt::FlatCap));
  p->drawLine(a, b);
  // At each end a short solid stroke and an arrow along n, as drawings mark a cut.
  p->setPen(QPen(kSection, 2.5, Qt::SolidLine, Qt::FlatCap));
  p->setBrush(kSection);
  for (const QPointF& end : {a, b}) {
    const QPointF tip = end + kSectionStroke * n;
    p->drawLine(end, tip);
    p->drawPolygon(QPolygonF(
        {tip + kSectionArrow * n, tip - kSectionArrowHalf * u, tip + kSectionArrowHalf * u}));
  }
  p->setBrush(Qt::NoBrush);
  QFont bold = p->font();
  bold.setBold(true);
  p->save();
  p->setFont(bold);
  PaintLabel(p, a - kSectionLetterGap * u, 0.0, QStringLiteral("A"), kSection);
  PaintLabel(p, b + kSectionLetterGap * u, 0.0, QStringLiteral("A'"), kSection);
  p->restore();
  if (rubber_band) {
    PaintLabel(p, 0.5 * (a + b) - 12.0 * n, ScreenAngle(b - a),
               tr("%1 m").arg((line.b - line.a).norm(), 0, 'f', 2), kSection, length - 40.0);
  }
}

bool PlanCanvas::event(QEvent* event) {
  // Esc while a line is drawn is the canvas's, not a window shortcut's.
  if (event->type() == QEvent::ShortcutOverride && (drag_ || section_mode_) &&
      static_cast<QKeyEvent*>(event)->key() == Qt::Key_Escape) {
    event->accept();
    return true;
  }
  return Canvas2d::event(event);
}

void PlanCanvas::mousePressEvent(QMouseEvent* event) {
  if (plan_ && event->button() == Qt::LeftButton && (section_mode_ || (event->modifiers() & Qt::ShiftModifier))) {
    const Eigen::Vector2d at = ToPlan(event->localPos());
    drag_ = SectionLine{at, at};
    setFocus(Qt::MouseFocusReason);  // Esc
    event->accept();
    update();
    return;
  }
  Canvas2d::mousePressEvent(event);
}

void PlanCanvas::mouseMoveEvent(QMouseEvent* event) {
  if (drag_) drag_->b = ToPlan(event->localPos());
  Canvas2d::mouseMoveEvent(event);
}

void PlanCanvas::mouseReleaseEvent(QMouseEvent* event) {
  if (drag_ && event->button() == Qt::LeftButton) {
    drag_->b = ToPlan(event->localPos());
    const SectionLine line = *drag_;
    drag_.reset();
    update();
    if ((line.b - line.a).norm() * scale() >= kMinSectionPx) {
      section_line_ = line;
      SetSectionMode(false);  // One line a time, then the hand again.
      emit sectionLineDrawn();
    }
    event->accept();
    return;
  }
  Canvas2d::mouseReleaseEvent(event);
}

void PlanCanvas::keyPressEvent(QKeyEvent* event) {
  if (event->key() == Qt::Key_Escape && (drag_ || section_mode_)) {
    // The drag first, the mode with a second Esc.
    if (drag_) {
      drag_.reset();
      update();
    } else {
      SetSectionMode(false);
    }
    event->accept();
    return;
  }
  Canvas2d::keyPressEvent(event);
}

}  // namespace sweepscan::ui
