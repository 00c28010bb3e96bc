// Where an axis-aligned box lies against a set of planes (a view frustum,
// a clip): the level-of-detail plans of the view and of a project's
// sessions cull with it. Boxes are (x min, x max, y min, y max, z min,
// z max), as VTK orders bounds; a plane is (a, b, c, d), a x + b y + c z +
// d >= 0 inside, as vtkCamera::GetFrustumPlanes gives them.
#ifndef SWEEPSCAN_CORE_GEOMETRY_BOX_PLANES_H_
#define SWEEPSCAN_CORE_GEOMETRY_BOX_PLANES_H_

#include <algorithm>
#include <cstddef>

namespace sweepscan {

enum class InView { kOut, kPartly, kWhole };

// The box's corners farthest and nearest along each plane's inward normal:
// out if some plane has even the farthest behind it, whole if every plane
// has even the nearest in front of it.
template <typename T>
InView BoxAgainstPlanes(const T* b, const double* planes, size_t count) {
  bool whole = true;
  for (size_t p = 0; p < count; ++p) {
    const double* n = planes + 4 * p;
    const double far = n[0] * (n[0] >= 0 ? b[1] : b[0]) + n[1] * (n[1] >= 0 ? b[3] : b[2]) +
                       n[2] * (n[2] >= 0 ? b[5] : b[4]) + n[3];
    if (far < 0) return InView::kOut;
    const double near = n[0] * (n[0] >= 0 ? b[0] : b[1]) + n[1] * (n[1] >= 0 ? b[2] : b[3]) +
                        n[2] * (n[2] >= 0 ? b[4] : b[5]) + n[3];
    whole = whole && near >= 0;
  }
  return whole ? InView::kWhole : InView::kPartly;
}

// The squared distance from `eye` to the box's nearest point (0 inside).
template <typename T>
double SquaredDistanceToBox(const double eye[3], const T* b) {
  double d2 = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double q = std::clamp<double>(eye[k], b[2 * k], b[2 * k + 1]);
    d2 += (eye[k] - q) * (eye[k] - q);
  }
  return d2;
}

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_GEOMETRY_BOX_PLANES_H_
