// CloudView's colours: the colour modes (height, time, range, pass,
// deviation, intensity), their lookup tables and colour bar, the colour
// ranges that grow with a live cloud, values given after the fact
// (SetPointValues), and the pass filter that draws one pass of a circle drive.
#include <vtkDoubleArray.h>
#include <vtkLookupTable.h>
#include <vtkPointData.h>
#include <vtkRenderer.h>
#include <vtkScalarBarActor.h>
#include <vtkVariant.h>

#include <QTimer>
#include <algorithm>
#include <cmath>
#include <string>

#include "ui/view/cloud_view.h"
#include "ui/view/cloud_view_chunk.h"

namespace sweepscan::ui {
using cloud_view_internal::kNoValue;
namespace {

const char* const kBarTitles[CloudView::kColorModes] = {"height (m)", "time (s)", "range (m)",
                                                        "pass", "deviation (mm)", "intensity"};
// The calibration panel's pick colours: pass A cyan, pass B magenta.
constexpr double kPassColors[2][3] = {{0.0, 0.78, 1.0}, {1.0, 0.24, 0.78}};

// The next colour range end that covers `value`: doubling from `current`,
// so that a growing cloud re-maps its colours O(log n) times.
double Grow(double current, double value) {
  double hi = std::max(current, 1e-3);
  while (value > hi) hi *= 2.0;
  return hi;
}

// Height's range ends: the lowest point rounded down to the decimetre (a
// floor's noise a few millimetres below 0 made whole metres start the bar
// at -1 m, a quarter of it empty), the top grown in half metres (doubling
// took a 3.3 m room's bar to 6 m). A vertical scan sees floor to ceiling in
// its first revolution, so height re-maps a handful of times at the start.
double HeightLow(double z) { return std::floor(z * 10.0) / 10.0; }
double HeightHigh(double lo, double span) { return lo + std::ceil(span * 2.0) / 2.0; }

}  // namespace

void CloudView::UpdateRanges(float z, float t, float r) {
  bool changed = false;
  if (!have_points_) {
    z_min_ = z_max_ = z;
    have_points_ = true;
    // Height: start with the floor-to-ceiling span of a room.
    range_lo_[0] = HeightLow(z);
  }
  z_min_ = std::min(z_min_, z);
  z_max_ = std::max(z_max_, z);
  t_max_ = std::max(t_max_, t);
  r_max_ = std::max(r_max_, r);
  if (z_min_ < range_lo_[0]) {
    range_lo_[0] = HeightLow(z_min_);
    changed = true;
  }
  const double spans[3] = {z_max_ - range_lo_[0], t_max_, r_max_};
  for (int i = 0; i < 3; ++i) {
    const double hi_span = range_hi_[i] - range_lo_[i];
    if (spans[i] > hi_span) {
      range_hi_[i] =
          i == 0 ? HeightHigh(range_lo_[0], spans[0]) : range_lo_[i] + Grow(hi_span, spans[i]);
      changed = true;
    }
  }
  if (changed) ApplyLookupTable();
}

std::array<double, 2> CloudView::color_range() const {
  const double* r = lut_->GetTableRange();
  return {r[0], r[1]};
}

void CloudView::ApplyLookupTable() {
  const int m = static_cast<int>(color_mode_);
  color_bar_->SetTitle(kBarTitles[m]);
  lut_->ResetAnnotations();
  lut_->SetNanColor(0.42, 0.43, 0.45, 1.0);
  if (color_mode_ == ColorMode::kPass) {
    // Two categories, as swatches in the colour bar: the pass shown alone
    // when the calibration panel shows one (it listed both beside one
    // pass's points). Indexed lookup colours a value by its annotation's
    // index, so the table follows the annotations (pass B alone is index 0).
    static const char* const kPassNames[2] = {"pass A (near side)", "pass B (far side)"};
    lut_->IndexedLookupOn();
    lut_->SetNumberOfTableValues(pass_filter_ < 0 ? 2 : 1);
    vtkIdType index = 0;
    for (int pass = 0; pass < 2; ++pass) {
      if (pass_filter_ >= 0 && pass_filter_ != pass) continue;
      lut_->SetTableValue(index++, kPassColors[pass][0], kPassColors[pass][1], kPassColors[pass][2],
                          1.0);
      lut_->SetAnnotation(vtkVariant(static_cast<float>(pass)), kPassNames[pass]);
    }
    lut_->SetTableRange(0.0, 1.0);
    color_bar_->SetUseCustomLabels(false);
    color_bar_->SetLabelFormat("%.0f");
    return;
  }
  lut_->IndexedLookupOff();
  lut_->SetNumberOfTableValues(256);
  if (color_mode_ == ColorMode::kDeviation) {
    // Diverging blue - white - red: the sign of a deviation matters (a
    // surface in front of or behind its plane), white is on the plane.
    for (int i = 0; i < 256; ++i) {
      const double x = i / 255.0 * 2.0 - 1.0;  // -1 .. 1
      const double a = std::abs(x);
      if (x < 0) {
        lut_->SetTableValue(i, 1.0 - 0.85 * a, 1.0 - 0.6 * a, 1.0 - 0.1 * a, 1.0);
      } else {
        lut_->SetTableValue(i, 1.0 - 0.1 * a, 1.0 - 0.8 * a, 1.0 - 0.85 * a, 1.0);
      }
    }
    lut_->SetTableRange(-deviation_max_mm_, deviation_max_mm_);
    SetBarTicks(-deviation_max_mm_, deviation_max_mm_);
    return;
  }
  if (color_mode_ == ColorMode::kIntensity) {
    // Grey levels, dark grey (weak) to white (strong): visible on the dark
    // background, and read as intensity the way other viewers show it.
    for (int i = 0; i < 256; ++i) {
      const double v = 0.25 + 0.75 * i / 255.0;
      lut_->SetTableValue(i, v, v, v, 1.0);
    }
    lut_->SetTableRange(intensity_lo_, intensity_hi_);
    SetBarTicks(intensity_lo_, intensity_hi_);
    return;
  }
  lut_->SetHueRange(0.667, 0.0);
  lut_->SetSaturationRange(1.0, 1.0);
  lut_->SetValueRange(1.0, 1.0);
  lut_->SetAlphaRange(1.0, 1.0);
  lut_->ForceBuild();
  lut_->SetTableRange(range_lo_[m], range_hi_[m]);
  SetBarTicks(range_lo_[m], range_hi_[m]);
}

// Labels at steps of 1, 2 or 5 times a power of ten, at least a sixth of
// the range (three to seven labels), with the decimals the step needs: five
// evenly spaced labels over 0..3 m read 0.0, 0.8, 1.5, 2.2, 3.0, and over
// an intensity's fallback 0..1 with "%.0f" they read 0, 0, 0, 1, 1.
std::vector<double> CloudView::BarTicks(double lo, double hi, int* decimals) {
  *decimals = 0;
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) return {};
  const double raw = (hi - lo) / 6.0;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  double step = 10.0 * power;
  for (const double m : {1.0, 2.0, 5.0}) {
    if (m * power >= raw * (1.0 - 1e-9)) {
      step = m * power;
      break;
    }
  }
  std::vector<double> ticks;
  for (double k = std::ceil(lo / step - 1e-9); k * step <= hi + 1e-9 * step; k += 1.0) {
    ticks.push_back(k == 0.0 ? 0.0 : k * step);  // no "-0"
  }
  *decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  return ticks;
}

void CloudView::SetBarTicks(double lo, double hi) {
  int decimals = 0;
  const std::vector<double> ticks = BarTicks(lo, hi, &decimals);
  if (ticks.empty()) {
    color_bar_->SetUseCustomLabels(false);
    return;
  }
  auto labels = vtkSmartPointer<vtkDoubleArray>::New();
  for (const double t : ticks) labels->InsertNextValue(t);
  color_bar_->SetLabelFormat(("%." + std::to_string(decimals) + "f").c_str());
  color_bar_->SetCustomLabels(labels);
  color_bar_->SetUseCustomLabels(true);
}

void CloudView::SetPointValues(ColorMode mode, const QuantizedValues& values) {
  const int m = static_cast<int>(mode);
  if (m < 3) return;  // Height, time and range come with the points.
  static_assert(QuantizedValues::kNone == kNoValue);
  value_lo_[m - 3] = values.lo;
  value_step_[m - 3] = values.step;
  size_t offset = 0;
  for (auto& c : chunks_) {
    // A new vector: a pick in flight may hold the old one.
    auto shared = std::make_shared<std::vector<uint16_t>>(c->size, kNoValue);
    c->values[m - 3] = shared;
    std::vector<uint16_t>& q = *shared;
    if (offset < values.q.size()) {
      const size_t n = std::min(c->size, values.q.size() - offset);
      std::copy_n(values.q.begin() + offset, n, q.begin());
    }
    offset += c->size;
    if (mode == color_mode_) {
      Recolor(c.get(), &c->motion);
      Recolor(c.get(), &c->rest);
    }
  }
  has_values_[m] = true;
  emit pointValuesChanged();
  if (mode == ColorMode::kPass && pass_filter_ >= 0) ApplyPassFilter();
  if (mode == ColorMode::kIntensity) {
    intensity_lo_ = values.lo;
    intensity_hi_ = values.hi > values.lo ? values.hi : intensity_lo_ + 1.0;
    if (color_mode_ == ColorMode::kIntensity) ApplyLookupTable();
  }
  RequestRender();
}

void CloudView::SetDeviationRange(double max_mm) {
  deviation_max_mm_ = std::max(0.1, max_mm);
  if (color_mode_ == ColorMode::kDeviation) ApplyLookupTable();
  RequestRender();
}

QStringList CloudView::color_bar_categories() const {
  QStringList names;
  for (vtkIdType i = 0; i < lut_->GetNumberOfAnnotatedValues(); ++i) {
    names << QString::fromStdString(lut_->GetAnnotation(i));
  }
  return names;
}

QColor CloudView::ColorOfValue(double value) const {
  double rgb[3];
  lut_->GetColor(value, rgb);
  return QColor::fromRgbF(rgb[0], rgb[1], rgb[2]);
}

void CloudView::SetPassFilter(int pass) {
  pass = pass < 0 || pass > 1 ? -1 : pass;
  if (pass == pass_filter_) return;
  pass_filter_ = pass;
  ApplyPassFilter();
  if (color_mode_ == ColorMode::kPass) ApplyLookupTable();
  RequestRender();
}

void CloudView::ApplyPassFilter() {
  // Rebuilds each drawn level's vertex list with the points of the pass
  // shown; the point arrays stay as they are.
  for (auto& c : chunks_) {
    for (Drawn* d : {&c->motion, &c->rest}) {
      if (d->poly) RefilterVerts(*c, d);
    }
  }
}

size_t CloudView::drawn_point_count() const {
  size_t n = 0;
  for (const auto& c : chunks_) {
    if (pass_filter_ < 0) {
      n += c->size;
      continue;
    }
    for (size_t i = 0; i < c->size; ++i) n += Passes(*c, i) ? 1 : 0;
  }
  return n;
}

void CloudView::SetColorMode(ColorMode mode) {
  color_mode_ = mode;
  // Height and the values given after the fact are recoloured in place. Time
  // and range of a sealed chunk's rest level must read the chunk again (and
  // unpack it if compressed, ~2 ms a chunk: seconds at 100 M points), so
  // those levels are dropped and built again as after a camera move: the
  // motion level (recoloured at once) drawn meanwhile, then the rest level
  // nearest first, kRefineSliceMs of the GUI thread at a time.
  const bool reread = mode == ColorMode::kTime || mode == ColorMode::kRange;
  bool dropped = false;
  for (auto& c : chunks_) {
    Recolor(c.get(), &c->motion);
    if (reread && c->sealed() && c->rest.stride > 0) {
      if (c->rest.actor) renderer_->RemoveActor(c->rest.actor);
      c->rest = Drawn();
      DrawnChanged();
      dropped = true;
    } else {
      Recolor(c.get(), &c->rest);
    }
  }
  if (dropped) {
    progress_.active = false;
    lod_active_ = true;
    ShowLevels();
    if (!interacting_) {  // otherwise the settle after the interaction plans them
      PlanRest();
      refine_timer_->start();
    }
  }
  ApplyLookupTable();
  RequestRender();
  emit colorModeChanged(static_cast<int>(mode));
}

}  // namespace sweepscan::ui
