// CloudView's room view: a room scan opened looking into the room, its
// ceiling hidden, instead of looking down on the ceiling (an orange box with
// the interior hidden).
#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkMatrix4x4.h>
#include <vtkMapper.h>
#include <vtkPolyData.h>
#include <vtkRenderer.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "ui/view/cloud_view.h"
#include "ui/view/cloud_view_chunk.h"

namespace sweepscan::ui {

double CloudView::FindCeiling() const {
  // Heights of a representative sample: the motion level of sealed chunks
  // (one point a cell, spread per volume) and the growing chunk.
  std::vector<float> z;
  for (const auto& c : chunks_) {
    const Drawn& d = c->sealed() ? c->motion : c->rest;
    if (!d.points) continue;
    const float* p = static_cast<const float*>(d.points->GetVoidPointer(0));
    for (size_t k = 0; k < d.size(); ++k) z.push_back(p[3 * k + 2]);
  }
  // Layers (a project's sessions): about 200 000 heights in all, through
  // each actor's matrix (its third row gives z).
  for (const auto& layer : layers_) {
    auto* poly = layer.rest ? vtkPolyData::SafeDownCast(layer.rest->GetInput()) : nullptr;
    if (!layer.actor->GetVisibility() || poly == nullptr || poly->GetNumberOfPoints() == 0) continue;
    vtkMatrix4x4* m = layer.actor->GetMatrix();
    const vtkIdType n = poly->GetNumberOfPoints();
    const vtkIdType step = std::max<vtkIdType>(1, n * static_cast<vtkIdType>(layers_.size()) / 200'000);
    for (vtkIdType k = 0; k < n; k += step) {
      double p[3];
      poly->GetPoint(k, p);
      z.push_back(static_cast<float>(m->GetElement(2, 0) * p[0] + m->GetElement(2, 1) * p[1] +
                                     m->GetElement(2, 2) * p[2] + m->GetElement(2, 3)));
    }
  }
  constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  if (z.size() < 1000) return kNone;
  const auto [lo_it, hi_it] = std::minmax_element(z.begin(), z.end());
  const double lo = *lo_it, hi = *hi_it;
  // A room is at least 1.8 m high; a scan of a ceiling-less yard or a lone
  // object has no ceiling to hide.
  if (hi - lo < 1.8) return kNone;
  // Bins on whole multiples of kBin, not from the sample's lowest point, so
  // that the height found does not move with the sample (the LOD budget).
  constexpr double kBin = 0.05;
  const double base = std::floor(lo / kBin);
  const int bins = static_cast<int>(std::floor(hi / kBin) - base) + 1;
  std::vector<size_t> count(bins, 0);
  for (float v : z) {
    ++count[std::clamp(static_cast<int>(std::floor(v / kBin) - base), 0, bins - 1)];
  }
  // Walls give each bin of height about the same count; a ceiling is a
  // horizontal layer that puts many times that into a few bins near the top.
  std::vector<size_t> middle(count.begin() + bins / 4, count.begin() + 3 * bins / 4);
  std::nth_element(middle.begin(), middle.begin() + middle.size() / 2, middle.end());
  const double wall = std::max<double>(1.0, static_cast<double>(middle[middle.size() / 2]));
  for (int b = bins - 1; b >= bins * 2 / 3; --b) {
    const size_t layer = count[b] + (b > 0 ? count[b - 1] : 0);
    if (layer >= 6.0 * wall && layer >= z.size() / 50) {
      // The layer's lower edge: the lowest bin below it that still holds
      // half the walls' count again. An uncalibrated circle drive smears
      // its ceiling over 40 cm in two layers (one a pass) with a thinner
      // bin between them (1.8 times the walls' on the diamond drive): the
      // edge taken at 3 times stopped there and left the lower layer as a
      // lid over the board the operator has to pick.
      int first = b;
      while (first > 0 && count[first - 1] >= 1.5 * wall) --first;
      return (base + first) * kBin;
    }
  }
  return kNone;
}

double CloudView::ShowRoom() {
  const double ceiling = FindCeiling();
  // Just under the ceiling: the walls to their top, the ceiling hidden.
  if (!std::isnan(ceiling)) SetClipHeight(ceiling - 0.05);
  // From the south-west, 50 degrees above the floor: over the walls into
  // the room, the floor and the robot's path in view.
  const double d[3] = {0.47, 0.43, -0.77}, up[3] = {0, 0, 1};
  SetCamera(d, up);
  return ceiling;
}

}  // namespace sweepscan::ui
