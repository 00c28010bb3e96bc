// Plain SVG 1.1 drawings (docs/plan-formats.md, "SVG"). User units are paper
// millimetres: width="W mm" with viewBox="0 0 W H". A model point (x, y) in
// metres is drawn at
//   X = margin + (x - x_min) * k,   Y = margin + (y_max - y) * k,   k = 1000 / scale
// so +y (north) is up on the paper.
#include <cmath>
#include <cstdio>

#include "core/common/checked_file.h"
#include "core/common/format_number.h"
#include "core/plan/axis_ticks.h"
#include "core/plan/plan_writers.h"

namespace sweepscan::plan {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string Num(double v) { return FormatFixed(std::abs(v) < 5e-3 ? 0.0 : v, 2); }

std::string Escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '&') {
      out += "&amp;";
    } else if (c == '<') {
      out += "&lt;";
    } else if (c == '>') {
      out += "&gt;";
    } else if (c == '"') {
      out += "&quot;";
    } else if (static_cast<unsigned char>(c) < 0x20 && c != '\t' && c != '\n' && c != '\r') {
      out += '?';  // XML 1.0 has no way to write these (a folder name may hold one).
    } else {
      out += c;
    }
  }
  return out;
}

// Model metres -> paper millimetres.
struct Paper {
  Eigen::Vector2d min, max;
  double k = 20.0, margin = 15.0, extra_bottom = 0.0;
  double X(double x) const { return margin + (x - min.x()) * k; }
  double Y(double y) const { return margin + (max.y() - y) * k; }
  double Width() const { return 2 * margin + (max.x() - min.x()) * k; }
  double Height() const { return 2 * margin + (max.y() - min.y()) * k + extra_bottom; }
  std::string Line(const Eigen::Vector2d& a, const Eigen::Vector2d& b) const {
    return "<line x1=\"" + Num(X(a.x())) + "\" y1=\"" + Num(Y(a.y())) + "\" x2=\"" + Num(X(b.x())) + "\" y2=\"" +
           Num(Y(b.y())) + "\"/>\n";
  }
};

std::string Header(const Paper& p, const std::string& description) {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"" +
         Num(p.Width()) + "mm\" height=\"" + Num(p.Height()) + "mm\" viewBox=\"0 0 " + Num(p.Width()) + " " +
         Num(p.Height()) + "\">\n<desc>" + Escape(description) + "</desc>\n" +
         "<rect x=\"0\" y=\"0\" width=\"" + Num(p.Width()) + "\" height=\"" + Num(p.Height()) +
         "\" fill=\"#ffffff\"/>\n";
}

// A label centred on the segment a -> b (paper), turned along it so that it
// reads left to right or bottom to top, `offset` mm above it.
std::string Label(const Paper& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b, const std::string& text,
                  double height, double offset) {
  const Eigen::Vector2d pa(p.X(a.x()), p.Y(a.y())), pb(p.X(b.x()), p.Y(b.y()));
  double angle = std::atan2(pb.y() - pa.y(), pb.x() - pa.x()) * 180.0 / kPi;
  // Paper y points down: -90 deg reads bottom to top, +90 would read top to
  // bottom. A line within kUprightBandDeg of vertical counts as vertical: a
  // wall 0.02 deg off plumb had its value turned by 89.98 deg, top to bottom.
  if (angle > 90.0 - kUprightBandDeg) angle -= 180.0;
  if (angle <= -90.0 - kUprightBandDeg) angle += 180.0;
  const double r = angle * kPi / 180.0;
  const Eigen::Vector2d m = 0.5 * (pa + pb) + offset * Eigen::Vector2d(std::sin(r), -std::cos(r));
  // No stroke: the group's dashed line stroke would outline the glyphs.
  return "<text x=\"" + Num(m.x()) + "\" y=\"" + Num(m.y()) + "\" font-size=\"" + Num(height) +
         "\" text-anchor=\"middle\" stroke=\"none\" transform=\"rotate(" + Num(angle) + " " +
         Num(m.x()) + " " + Num(m.y()) + ")\">" + Escape(text) + "</text>\n";
}

std::string Title(const Paper& p, const std::string& title, double height) {
  if (title.empty()) return "";
  return "<text x=\"" + Num(p.margin) + "\" y=\"" + Num(p.Height() - 0.5 * p.margin) + "\" font-size=\"" +
         Num(height) + "\" font-family=\"sans-serif\">" + Escape(title) + "</text>\n";
}

bool Finite(const Eigen::Vector2d& v) { return v.allFinite(); }

}  // namespace

bool SvgOptions::IsValid(std::string* error) const {
  if (!std::isfinite(scale) || scale <= 0.0) {
    *error = "drawing scale must be a finite number > 0 (50 for 1:50)";
    return false;
  }
  if (!std::isfinite(margin_mm) || margin_mm < 0.0 || !std::isfinite(text_height_mm) || text_height_mm <= 0.0) {
    *error = "drawing margin must be >= 0 mm and text height > 0 mm";
    return false;
  }
  return true;
}

std::string FormatMetres(double m) { return FormatFixed(m, 3); }

std::string RoomName(size_t index) { return "Room " + std::to_string(index + 1); }

std::string FormatArea(double m2) { return FormatFixed(m2, 2) + " m2"; }

Status PlanSvg(const FloorPlan& plan, const SvgOptions& o, std::string* svg) {
  std::string error;
  if (!o.IsValid(&error)) return Status::Error(error);
  Paper p;
  p.min = plan.min;
  p.max = plan.max;
  for (const WallFace& f : plan.faces) {
    if (!Finite(f.a) || !Finite(f.b)) return Status::Error("the plan has a face that is not finite");
    p.min = p.min.cwiseMin(f.a).cwiseMin(f.b);
    p.max = p.max.cwiseMax(f.a).cwiseMax(f.b);
  }
  if (!Finite(p.min) || !Finite(p.max)) return Status::Error("the plan's extent is not finite");
  p.k = 1000.0 / o.scale;
  p.margin = o.margin_mm;
  p.extra_bottom = o.title.empty() ? 0.0 : 2.0 * o.text_height_mm;
  const std::string desc = "sweepscan floor plan: section at z = " + FormatFixed(plan.height_m, 3) +
                           " m +- " + FormatFixed(plan.band_m, 3) +
                           " m, scale 1:" + FormatGeneral(o.scale) + ", paper mm";
  std::string s = Header(p, desc);
  const double t = o.text_height_mm;
  // Rooms: each outline filled pale under everything else, its name and
  // area at its label point.
  s += "<g id=\"rooms\" fill=\"#eef4e8\" stroke=\"none\" font-family=\"sans-serif\">\n";
  for (size_t r = 0; r < plan.rooms.size(); ++r) {
    const Room& room = plan.rooms[r];
    s += "<polygon points=\"";
    for (size_t k = 0; k < room.outline.size(); ++k) {
      if (!Finite(room.outline[k])) return Status::Error("the plan has a room corner that is not finite");
      s += Num(p.X(room.outline[k].x())) + "," + Num(p.Y(room.outline[k].y())) + (k + 1 < room.outline.size() ? " " : "");
    }
    s += "\"/>\n";
    const double x = p.X(room.label.x()), y = p.Y(room.label.y());
    s += "<text x=\"" + Num(x) + "\" y=\"" + Num(y - 0.2 * t) + "\" font-size=\"" + Num(1.2 * t) +
         "\" text-anchor=\"middle\" fill=\"#406030\">" + Escape(RoomName(r)) + "</text>\n";
    s += "<text x=\"" + Num(x) + "\" y=\"" + Num(y + 1.2 * t) + "\" font-size=\"" + Num(t) +
         "\" text-anchor=\"middle\" fill=\"#406030\">" + Escape(FormatArea(room.area_m2)) + "</text>\n";
  }
  s += "</g>\n";
  // Section points and furniture (faces that are not walls'): the survey's raw evidence.
  s += "<g id=\"points\" fill=\"#a0a0a0\" stroke=\"#808080\" stroke-width=\"0.18\">\n";
  if (o.points) {
    for (const Eigen::Vector2d& q : plan.points) {
      s += "<circle cx=\"" + Num(p.X(q.x())) + "\" cy=\"" + Num(p.Y(q.y())) + "\" r=\"0.15\" stroke=\"none\"/>\n";
    }
  }
  for (const WallFace& f : plan.faces) {
    if (!f.structural) s += p.Line(f.a, f.b);
  }
  s += "</g>\n";
  // Walls: each pair's body filled, every wall face as a line.
  s += "<g id=\"walls\" stroke=\"#000000\" stroke-width=\"0.35\" stroke-linecap=\"square\">\n";
  for (const Wall& w : plan.walls) {
    const Eigen::Vector2d u = (w.b - w.a).normalized(), n(-u.y(), u.x());
    const Eigen::Vector2d h = 0.5 * w.thickness_m * n;
    const Eigen::Vector2d c[4] = {w.a + h, w.b + h, w.b - h, w.a - h};
    s += "<polygon fill=\"#c8c8c8\" stroke=\"none\" points=\"";
    for (int i = 0; i < 4; ++i) s += Num(p.X(c[i].x())) + "," + Num(p.Y(c[i].y())) + (i < 3 ? " " : "");
    s += "\"/>\n";
  }
  for (const WallFace& f : plan.faces) {
    if (f.structural) s += p.Line(f.a, f.b);
  }
  s += "</g>\n";
  // Openings: jamb to jamb, dashed, with the clear width.
  s += "<g id=\"openings\" stroke=\"#1060c0\" stroke-width=\"0.35\" stroke-dasharray=\"1.5,1\" fill=\"#1060c0\" "
       "font-family=\"sans-serif\">\n";
  for (const Opening& op : plan.openings) {
    s += p.Line(op.a, op.b);
    s += Label(p, op.a, op.b, FormatMetres(op.width_m), t, 0.6 * t + 1.0);
  }
  s += "</g>\n";
  // Dimensions: the line, a 45 degree tick at each end, the value above.
  s += "<g id=\"dimensions\" stroke=\"#c02020\" stroke-width=\"0.18\" fill=\"#c02020\" font-family=\"sans-serif\">\n";
  for (const Dimension& d : plan.dimensions) {
    s += p.Line(d.a, d.b);
    const Eigen::Vector2d u = (d.b - d.a).normalized(), n(-u.y(), u.x());
    const Eigen::Vector2d tick = (u + n).normalized() * (1.0 / p.k);  // 1 mm on paper
    for (const Eigen::Vector2d& e : {d.a, d.b}) s += p.Line(e - tick, e + tick);
    s += Label(p, d.a, d.b, FormatMetres(d.distance_m), t, 1.0);
  }
  s += "</g>\n";
  s += Title(p, o.title, t);
  s += "</svg>\n";
  *svg = std::move(s);
  return Status::Ok();
}

Status WritePlanSvg(const std::string& path, const FloorPlan& plan, const SvgOptions& options) {
  std::string svg;
  const Status s = PlanSvg(plan, options, &svg);
  if (!s.ok()) return s;
  return WriteFileChecked(path, svg);
}

Status SectionSvg(const std::vector<Eigen::Vector2d>& s_z, const SvgOptions& o, std::string* svg) {
  std::string error;
  if (!o.IsValid(&error)) return Status::Error(error);
  if (s_z.empty()) return Status::Error("the vertical section holds no point: nothing to draw");
  Paper p;
  p.min = p.max = s_z.front();
  for (const Eigen::Vector2d& q : s_z) {
    if (!Finite(q)) return Status::Error("the vertical section has a point that is not finite");
    p.min = p.min.cwiseMin(q);
    p.max = p.max.cwiseMax(q);
  }
  p.min.y() = std::min(p.min.y(), 0.0);
  p.k = 1000.0 / o.scale;
  p.margin = o.margin_mm;
  p.extra_bottom = o.title.empty() ? 0.0 : 2.0 * o.text_height_mm;
  const std::string desc =
      "sweepscan vertical section: s along the line, z up, scale 1:" + FormatGeneral(o.scale) +
      ", paper mm";
  std::string s = Header(p, desc);
  s += "<g id=\"points\" fill=\"#404040\">\n";
  for (const Eigen::Vector2d& q : s_z) {
    s += "<circle cx=\"" + Num(p.X(q.x())) + "\" cy=\"" + Num(p.Y(q.y())) + "\" r=\"0.15\"/>\n";
  }
  s += "</g>\n<g id=\"axes\" stroke=\"#c02020\" stroke-width=\"0.18\" fill=\"#c02020\" font-family=\"sans-serif\">\n";
  s += p.Line({p.min.x(), 0.0}, {p.max.x(), 0.0});
  const Eigen::Vector2d tick(0.0, 1.5 / p.k);
  for (const double m : AxisTicks(p.min.x(), p.max.x())) {
    s += p.Line(Eigen::Vector2d(m, 0.0) - tick, Eigen::Vector2d(m, 0.0) + tick);
    s += Label(p, {m - 0.5, 0.0}, {m + 0.5, 0.0}, AxisLabel(m), o.text_height_mm,
               -2.0 - o.text_height_mm);
  }
  for (const double z : AxisTicks(p.min.y(), p.max.y())) {
    const Eigen::Vector2d at(p.min.x(), z), side(1.5 / p.k, 0.0);
    s += p.Line(at - side, at + side);
    s += "<text x=\"" + Num(p.X(p.min.x()) - 2.5) + "\" y=\"" +
         Num(p.Y(z) + 0.35 * o.text_height_mm) + "\" font-size=\"" + Num(o.text_height_mm) +
         "\" text-anchor=\"end\" stroke=\"none\">" + AxisLabel(z) + "</text>\n";
  }
  s += "</g>\n";
  s += Title(p, o.title, o.text_height_mm);
  s += "</svg>\n";
  *svg = std::move(s);
  return Status::Ok();
}

Status WriteSectionSvg(const std::string& path, const std::vector<Eigen::Vector2d>& s_z, const SvgOptions& options) {
  std::string svg;
  const Status s = SectionSvg(s_z, options, &svg);
  if (!s.ok()) return s;
  return WriteFileChecked(path, svg);
}

}  // namespace sweepscan::plan
