// ASCII DXF, AutoCAD Release 12 (AC1009), written from Autodesk's DXF
// reference: pairs of lines "group code" / "value". The subset (HEADER,
// TABLES with LTYPE, STYLE and LAYER, ENTITIES with LINE, POINT, TEXT and
// POLYLINE / VERTEX / SEQEND, EOF) is specified field by field in docs/plan-formats.md, "DXF".
// No handles (no $HANDLING variable: R12 then has none), no BLOCKS, no
// subclass markers (those are R13's).
#include <cmath>
#include <cstdio>
#include <vector>

#include "core/common/checked_file.h"
#include "core/common/format_number.h"
#include "core/plan/axis_ticks.h"
#include "core/plan/plan_writers.h"

namespace sweepscan::plan {
namespace {

constexpr double kPi = 3.14159265358979323846;

class Dxf {
 public:
  // Group codes right-aligned in three columns, as AutoCAD writes them.
  void Code(int code, const std::string& value) {
    char buf[8];
    std::snprintf(buf, sizeof(buf), "%3d\n", code);
    s_ += buf;
    s_ += value;
    s_ += '\n';
  }
  void Int(int code, int v) { Code(code, std::to_string(v)); }
  void Real(int code, double v) { Code(code, FormatFixed(std::abs(v) < 5e-7 ? 0.0 : v, 6)); }
  // A 2D point in the plane z = 0: codes base, base + 10, base + 20.
  void Point(int base, const Eigen::Vector2d& p) {
    Real(base, p.x());
    Real(base + 10, p.y());
    Real(base + 20, 0.0);
  }
  void Line(const char* layer, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    Code(0, "LINE");
    Code(8, layer);
    Point(10, a);
    Point(11, b);
  }
  // Centred on `at` (72 = 1: the alignment point 11 is the baseline's
  // middle), turned by `degrees` counter-clockwise.
  void Text(const char* layer, const Eigen::Vector2d& at, double height, double degrees, const std::string& text) {
    Code(0, "TEXT");
    Code(8, layer);
    Point(10, at);
    Real(40, height);
    Code(1, text);
    Real(50, degrees);
    Int(72, 1);
    Point(11, at);
  }
  // A closed 2D polyline (70 = 1), its vertices as VERTEX entities after it
  // (66 = 1) and a SEQEND: R12's only polyline (LWPOLYLINE is R14's).
  void ClosedPolyline(const char* layer, const std::vector<Eigen::Vector2d>& corners) {
    Code(0, "POLYLINE");
    Code(8, layer);
    Int(66, 1);
    Point(10, Eigen::Vector2d::Zero());
    Int(70, 1);
    for (const Eigen::Vector2d& c : corners) {
      Code(0, "VERTEX");
      Code(8, layer);
      Point(10, c);
    }
    Code(0, "SEQEND");
    Code(8, layer);
  }
  const std::string& str() const { return s_; }

 private:
  std::string s_;
};

// A label for the segment a -> b: centred, `offset` metres to its left as
// read, turned along it so that it reads left to right or bottom to top.
void Label(Dxf* d, const char* layer, const Eigen::Vector2d& a, const Eigen::Vector2d& b, double height,
           const std::string& text) {
  double angle = std::atan2(b.y() - a.y(), b.x() - a.x()) * 180.0 / kPi;
  // y up: +90 deg reads bottom to top. A line within kUprightBandDeg of
  // vertical counts as vertical (one 0.02 deg off plumb read top to bottom).
  if (angle >= 90.0 + kUprightBandDeg) angle -= 180.0;
  if (angle < -90.0 + kUprightBandDeg) angle += 180.0;
  const double r = angle * kPi / 180.0;
  const Eigen::Vector2d at = 0.5 * (a + b) + 0.4 * height * Eigen::Vector2d(-std::sin(r), std::cos(r));
  d->Text(layer, at, height, angle + 0.0, text);
}

struct Layer {
  const char* name;
  int colour;  // AutoCAD colour index: 7 black/white, 5 blue, 1 red, 8 grey, 3 green
};

// HEADER (version, units: 6 = metres, the drawing's extent lo..hi) and
// TABLES (the linetype and text style the layers and TEXT refer to, the
// layers), then the ENTITIES section opened: what every drawing of ours
// starts with.
void Begin(Dxf* dxf, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, const std::vector<Layer>& layers,
           double text_height_m) {
  Dxf& d = *dxf;
  d.Code(0, "SECTION");
  d.Code(2, "HEADER");
  d.Code(9, "$ACADVER");
  d.Code(1, "AC1009");
  d.Code(9, "$INSUNITS");
  d.Int(70, 6);
  d.Code(9, "$EXTMIN");
  d.Point(10, lo);
  d.Code(9, "$EXTMAX");
  d.Point(10, hi);
  d.Code(0, "ENDSEC");
  d.Code(0, "SECTION");
  d.Code(2, "TABLES");
  d.Code(0, "TABLE");
  d.Code(2, "LTYPE");
  d.Int(70, 1);
  d.Code(0, "LTYPE");
  d.Code(2, "CONTINUOUS");
  d.Int(70, 0);
  d.Code(3, "Solid line");
  d.Int(72, 65);
  d.Int(73, 0);
  d.Real(40, 0.0);
  d.Code(0, "ENDTAB");
  d.Code(0, "TABLE");
  d.Code(2, "STYLE");
  d.Int(70, 1);
  d.Code(0, "STYLE");
  d.Code(2, "STANDARD");
  d.Int(70, 0);
  d.Real(40, 0.0);
  d.Real(41, 1.0);
  d.Real(50, 0.0);
  d.Int(71, 0);
  d.Real(42, text_height_m);
  d.Code(3, "txt");
  d.Code(4, "");
  d.Code(0, "ENDTAB");
  d.Code(0, "TABLE");
  d.Code(2, "LAYER");
  d.Int(70, static_cast<int>(layers.size()));
  for (const Layer& l : layers) {
    d.Code(0, "LAYER");
    d.Code(2, l.name);
    d.Int(70, 0);
    d.Int(62, l.colour);
    d.Code(6, "CONTINUOUS");
  }
  d.Code(0, "ENDTAB");
  d.Code(0, "ENDSEC");
  d.Code(0, "SECTION");
  d.Code(2, "ENTITIES");
}

// The ENTITIES section closed and the file ended.
std::string End(Dxf* d) {
  d->Code(0, "ENDSEC");
  d->Code(0, "EOF");
  return d->str();
}

}  // namespace

bool DxfOptions::IsValid(std::string* error) const {
  if (!std::isfinite(text_height_m) || text_height_m <= 0.0) {
    *error = "DXF text height must be a finite number > 0 m";
    return false;
  }
  return true;
}

Status PlanDxf(const FloorPlan& plan, const DxfOptions& o, std::string* out) {
  std::string error;
  if (!o.IsValid(&error)) return Status::Error(error);
  Eigen::Vector2d lo = plan.min, hi = plan.max;
  for (const WallFace& f : plan.faces) {
    if (!f.a.allFinite() || !f.b.allFinite()) return Status::Error("the plan has a face that is not finite");
    lo = lo.cwiseMin(f.a).cwiseMin(f.b);
    hi = hi.cwiseMax(f.a).cwiseMax(f.b);
  }
  if (!lo.allFinite() || !hi.allFinite()) return Status::Error("the plan's extent is not finite");
  for (const Room& room : plan.rooms) {
    for (const Eigen::Vector2d& c : room.outline) {
      if (!c.allFinite()) return Status::Error("the plan has a room corner that is not finite");
    }
  }
  Dxf d;
  Begin(&d, lo, hi,
        {{"0", 7},
         {kDxfLayerWalls, 7},
         {kDxfLayerOpenings, 5},
         {kDxfLayerDimensions, 1},
         {kDxfLayerSection, 8},
         {kDxfLayerRooms, 3}},
        o.text_height_m);
  for (const WallFace& f : plan.faces) d.Line(f.structural ? kDxfLayerWalls : kDxfLayerSection, f.a, f.b);
  for (const Opening& op : plan.openings) {
    d.Line(kDxfLayerOpenings, op.a, op.b);
    Label(&d, kDxfLayerOpenings, op.a, op.b, o.text_height_m, FormatMetres(op.width_m));
  }
  for (const Dimension& dim : plan.dimensions) {
    d.Line(kDxfLayerDimensions, dim.a, dim.b);
    Label(&d, kDxfLayerDimensions, dim.a, dim.b, o.text_height_m, FormatMetres(dim.distance_m));
  }
  // Rooms: the outline, the name above the label point, the area below.
  for (size_t r = 0; r < plan.rooms.size(); ++r) {
    const Room& room = plan.rooms[r];
    d.ClosedPolyline(kDxfLayerRooms, room.outline);
    const Eigen::Vector2d up(0.0, 0.7 * o.text_height_m);
    d.Text(kDxfLayerRooms, room.label + up, 1.2 * o.text_height_m, 0.0, RoomName(r));
    d.Text(kDxfLayerRooms, room.label - up, o.text_height_m, 0.0, FormatArea(room.area_m2));
  }
  if (o.section_points) {
    for (const Eigen::Vector2d& p : plan.points) {
      d.Code(0, "POINT");
      d.Code(8, kDxfLayerSection);
      d.Point(10, p);
    }
  }
  *out = End(&d);
  return Status::Ok();
}

Status WritePlanDxf(const std::string& path, const FloorPlan& plan, const DxfOptions& options) {
  std::string dxf;
  const Status s = PlanDxf(plan, options, &dxf);
  if (!s.ok()) return s;
  return WriteFileChecked(path, dxf);
}

Status SectionDxf(const std::vector<Eigen::Vector2d>& s_z, const DxfOptions& o, std::string* out) {
  std::string error;
  if (!o.IsValid(&error)) return Status::Error(error);
  if (s_z.empty()) return Status::Error("the vertical section holds no point: nothing to draw");
  Eigen::Vector2d lo = s_z.front(), hi = s_z.front();
  for (const Eigen::Vector2d& q : s_z) {
    if (!q.allFinite()) return Status::Error("the vertical section has a point that is not finite");
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  lo.y() = std::min(lo.y(), 0.0);
  Dxf d;
  Begin(&d, lo, hi, {{"0", 7}, {kDxfLayerSection, 8}, {kDxfLayerAxes, 1}}, o.text_height_m);
  // The axes: the ground line z = 0, a tick and a label every metre (or
  // AxisTicks' coarser step) along s and up z (at s = lo.x), as the SVG
  // draws them.
  d.Line(kDxfLayerAxes, {lo.x(), 0.0}, {hi.x(), 0.0});
  const double tick = 0.075;
  for (const double m : AxisTicks(lo.x(), hi.x())) {
    d.Line(kDxfLayerAxes, {m, -tick}, {m, tick});
    d.Text(kDxfLayerAxes, {m, -tick - 1.2 * o.text_height_m}, o.text_height_m, 0.0, AxisLabel(m));
  }
  for (const double z : AxisTicks(lo.y(), hi.y())) {
    d.Line(kDxfLayerAxes, {lo.x() - tick, z}, {lo.x() + tick, z});
    d.Text(kDxfLayerAxes, {lo.x() - tick - 1.5 * o.text_height_m, z - 0.4 * o.text_height_m},
           o.text_height_m, 0.0, AxisLabel(z));
  }
  for (const Eigen::Vector2d& q : s_z) {
    d.Code(0, "POINT");
    d.Code(8, kDxfLayerSection);
    d.Point(10, q);
  }
  *out = End(&d);
  return Status::Ok();
}

Status WriteSectionDxf(const std::string& path, const std::vector<Eigen::Vector2d>& s_z, const DxfOptions& options) {
  std::string dxf;
  const Status s = SectionDxf(s_z, options, &dxf);
  if (!s.ok()) return s;
  return WriteFileChecked(path, dxf);
}

}  // namespace sweepscan::plan
