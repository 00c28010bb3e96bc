// CloudView's internals shared by its source files (cloud_view.cc: content,
// camera, picking; cloud_view_colors.cc: colour modes and lookup tables):
// the chunk of points with its actors, and the per-point arrays' names.
// Not for use outside ui/view/.
#ifndef SWEEPSCAN_UI_VIEW_CLOUD_VIEW_CHUNK_H_
#define SWEEPSCAN_UI_VIEW_CLOUD_VIEW_CHUNK_H_

#include <vtkActor.h>
#include <vtkCellArray.h>
#include <vtkFloatArray.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkSmartPointer.h>

#include <limits>

#include "ui/view/cloud_view.h"

namespace sweepscan::ui {

namespace cloud_view_internal {
// One float array per ColorMode, by these names (the mappers select them).
inline const char* const kArrayNames[CloudView::kColorModes] = {"height", "time", "range", "pass",
                                                                "deviation", "intensity"};
inline constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
}  // namespace cloud_view_internal

struct CloudView::Chunk {
  vtkSmartPointer<vtkPoints> points;
  vtkSmartPointer<vtkCellArray> verts;
  vtkSmartPointer<vtkFloatArray> arrays[kColorModes];
  vtkSmartPointer<vtkPolyData> poly;
  vtkSmartPointer<vtkPolyDataMapper> mapper;
  vtkSmartPointer<vtkActor> actor;
  // Thinned copies (every kLodStrides[k]-th point); sealed chunks only.
  vtkSmartPointer<vtkPolyData> lod_poly[kLodLevels];
  vtkSmartPointer<vtkActor> lod_actor[kLodLevels];
  vtkSmartPointer<vtkPolyDataMapper> lod_mapper[kLodLevels];
  size_t size = 0;
  bool sealed = false;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_VIEW_CLOUD_VIEW_CHUNK_H_
