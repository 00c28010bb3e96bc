#include "ui/plan/section_canvas.h"

#include <QPainter>
#include <QPolygonF>
#include <algorithm>
#include <cmath>

namespace sweepscan::ui {
namespace {

const QColor kPoints(90, 96, 104);
const QColor kGround(121, 85, 72);
const QColor kTicks(90, 90, 90);
const QColor kEnds(106, 27, 154);  // as the line on the plan
const QColor kCut(21, 101, 192);

}  // namespace

SectionCanvas::SectionCanvas(QWidget* parent) : Canvas2d(parent) {
  setObjectName(QStringLiteral("sectionCanvas"));
  empty_text_ = tr("No section yet");
}

void SectionCanvas::SetSection(const SectionOf& section, double cut_height_m, bool fit) {
  section_ = section;
  cut_height_m_ = cut_height_m;
  empty_text_.clear();
  // The line's whole length and the ground, even where no point was seen.
  min_ = Eigen::Vector2d::Zero();
  max_ = Eigen::Vector2d(length(), 0.0);
  for (const Eigen::Vector2d& q : section.s_z) {
    min_ = min_.cwiseMin(q);
    max_ = max_.cwiseMax(q);
  }
  Follow(fit);
  emit contentChanged();
}

void SectionCanvas::ClearSection(const QString& why) {
  section_.reset();
  empty_text_ = why;
  Unfollow();
  update();
  emit contentChanged();
}

double SectionCanvas::length() const {
  return section_ ? (section_->options.b - section_->options.a).norm() : 0.0;
}

bool SectionCanvas::Extent(Eigen::Vector2d* min, Eigen::Vector2d* max) const {
  if (!section_) return false;
  *min = min_;
  *max = max_;
  return true;
}

QString SectionCanvas::CursorText(const Eigen::Vector2d& at) const {
  return tr("s %1  z %2 m").arg(at.x(), 0, 'f', 2).arg(at.y(), 0, 'f', 2);
}

void SectionCanvas::paintEvent(QPaintEvent*) {
  QPainter p(this);
  labels_.clear();
  if (!PaintBackground(&p, section_.has_value(), empty_text_)) return;
  const auto label = [&](const QPointF& at, const QString& text, const QColor& color) {
    Label l{text, {}};
    PaintLabel(&p, at, 0.0, text, color, 1e9, &l.plate);
    labels_.push_back(l);
  };
  const double s_end = length();
  // The plan's cut: where the plan above is the section of, named above
  // the line inside its far end (away from the z ticks at A).
  p.setPen(QPen(kCut, 1.0, Qt::DashLine));
  p.drawLine(ToWidget({0.0, cut_height_m_}), ToWidget({s_end, cut_height_m_}));
  const QString cut = tr("plan cut %1 m").arg(cut_height_m_, 0, 'f', 2);
  const double half = 0.5 * p.fontMetrics().horizontalAdvance(cut) + 6.0;
  label(ToWidget({s_end, cut_height_m_}) + QPointF(-half - 8.0, -12.0), cut, kCut);
  // The points (decimated to one a 1 cm cell).
  QPolygonF points;
  points.reserve(static_cast<int>(section_->s_z.size()));
  const QRectF inside = QRectF(rect()).adjusted(-2, -2, 2, 2);
  for (const Eigen::Vector2d& q : section_->s_z) {
    const QPointF w = ToWidget(q);
    if (inside.contains(w)) points << w;
  }
  p.setPen(QPen(kPoints, std::clamp(0.01 * scale(), 1.5, 3.0), Qt::SolidLine, Qt::RoundCap));
  p.drawPoints(points);
  // The ground line over the section's length and a little beyond.
  const double over = 0.3;
  p.setPen(QPen(kGround, 2.0, Qt::SolidLine, Qt::FlatCap));
  p.drawLine(ToWidget({-over, 0.0}), ToWidget({s_end + over, 0.0}));
  // Ticks every grid step: s under the ground line, z left of A; the last
  // of each axis carries the unit.
  const double step = GridStep();
  const auto tick_text = [](double v, bool last) {
    return last ? QStringLiteral("%1 m").arg(v) : QString::number(v);
  };
  for (double s = 0.0; s <= s_end + 1e-9; s += step) {
    const QPointF at = ToWidget({s, 0.0});
    p.setPen(QPen(kTicks, 1.0));
    p.drawLine(at, at + QPointF(0, 6));
    label(at + QPointF(0, 15), tick_text(s, s + step > s_end + 1e-9), kTicks);
  }
  for (double z = std::ceil(min_.y() / step) * step; z <= max_.y() + 1e-9; z += step) {
    const QPointF at = ToWidget({0.0, z});
    p.setPen(QPen(kTicks, 1.0));
    p.drawLine(at - QPointF(6, 0), at);
    const QString text = tick_text(z, z + step > max_.y() + 1e-9);
    // Right-aligned against the tick, whatever its width.
    label(at - QPointF(12.0 + 0.5 * p.fontMetrics().horizontalAdvance(text), 0), text, kTicks);
  }
  // A and A': the line's ends, thin verticals over the section's height.
  QFont bold = p.font();
  bold.setBold(true);
  for (const auto& [s, name] : {std::pair<double, QString>{0.0, QStringLiteral("A")}, {s_end, QStringLiteral("A'")}}) {
    p.setPen(QPen(kEnds, 1.0, Qt::DashDotLine));
    p.drawLine(ToWidget({s, min_.y()}), ToWidget({s, max_.y()}));
    p.save();
    p.setFont(bold);
    label(ToWidget({s, max_.y()}) - QPointF(0, 12), name, kEnds);
    p.restore();
  }
  PaintCursor(&p);
}

}  // namespace sweepscan::ui
