// CloudView's internals shared by its source files (cloud_view.cc: the
// scene, camera and frames; cloud_view_append.cc: points and sealed chunks
// as they arrive; cloud_view_colors.cc: colour modes and lookup tables;
// cloud_view_lod.cc: the level of detail; ...): the chunk of points with
// what is drawn of it. Not for use outside ui/view/.
//
// A chunk's points live in one place: the shared packed chunk of the cloud
// store (core/cloud/packed_chunk.h, 14 bytes a point, pageable), or, for the
// one growing chunk, the CloudPoints of the batches that brought them. VTK
// holds only what is drawn: the chunk's points in the view's spatially even
// sample (the motion level, core/geometry/voxel_sample.h; a few to a few
// hundred a chunk) and, at rest, every stride-th point of each census cube
// in view, the strides spending the rest budget evenly on screen, with the
// motion level's among them. Each drawn level carries one scalar array, the
// colour mode's, mapped through the shared lookup table on the GPU side.
#ifndef SWEEPSCAN_UI_VIEW_CLOUD_VIEW_CHUNK_H_
#define SWEEPSCAN_UI_VIEW_CLOUD_VIEW_CHUNK_H_

#include <vtkActor.h>
#include <vtkCellArray.h>
#include <vtkFloatArray.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkSmartPointer.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "core/cloud/packed_chunk.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {

namespace cloud_view_internal {
inline const char* const kScalarName = "scalar";
inline constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
inline constexpr uint16_t kNoValue = 0xFFFF;
inline constexpr uint8_t kNoCube = 0xFF;  // A census cube not drawn (Drawn::shifts).
}  // namespace cloud_view_internal

// One drawn level of a chunk: its points index[0], index[1], ... (all of
// them, whatever the pass filter), the vertex cells of those the filter
// shows, and the colour mode's scalar. The rest level's indices are the
// multiples of each census cube's stride among its points (of `stride`
// throughout if `shifts` is empty) and the motion level's (so that
// the progressive passes draw over pass 0's points, never beside them); the
// motion level's are the chunk's representatives. Only the growing chunk
// and the batches have a mapper and an actor; sealed chunks' levels are
// drawn through their batch.
struct CloudView::Drawn {
  int stride = 0;  // 0: nothing built. The motion level: its candidates' stride.
  // The rest level: each census cube's stride as a shift (PackedChunk::
  // cell_keys() order; kNoCube: none of its points), `stride` the finest;
  // empty: the whole chunk at `stride`.
  std::vector<uint8_t> shifts;
  // Sealed chunks: the chunk's index of each drawn point, ascending. Empty
  // for the growing chunk, drawn whole (point k is its k-th).
  std::vector<uint32_t> index;
  vtkSmartPointer<vtkPoints> points;
  vtkSmartPointer<vtkFloatArray> scalar;
  vtkSmartPointer<vtkCellArray> verts;
  vtkSmartPointer<vtkPolyData> poly;
  vtkSmartPointer<vtkPolyDataMapper> mapper;
  vtkSmartPointer<vtkActor> actor;
  // Motion level only: time (s from the cloud's start) and range of its
  // points, so that a new colour mode never reads the (maybe paged) chunk.
  std::vector<float> time_s, range_m;
  size_t size() const { return points ? static_cast<size_t>(points->GetNumberOfPoints()) : 0; }
  size_t At(size_t k) const { return index.empty() ? k : index[k]; }  // The chunk's index.
};

// The growing chunk's points, in order: spans of the batches' own vectors,
// shared, never copied (AppendPoints(std::vector&&): a live batch's points
// arrive in a vector of their own; copying them cost a fifth of live
// insertion with the caches cold, view_insertion_benchmark).
class GrowingPoints {
 public:
  void Append(std::shared_ptr<const std::vector<CloudPoint>> batch, size_t first, size_t n) {
    if (n == 0) return;
    spans_.push_back({std::move(batch), first, n, size_});
    size_ += n;
  }
  size_t size() const { return size_; }
  // Point i: a binary search over the spans (a few hundred at most).
  const CloudPoint& operator[](size_t i) const {
    const auto s = std::upper_bound(spans_.begin(), spans_.end(), i,
                                    [](size_t k, const Span& span) { return k < span.start; }) -
                   1;
    return (*s->batch)[s->first + (i - s->start)];
  }
  // f(i, point) for every point in order.
  template <typename F>
  void ForEach(F&& f) const {
    for (const Span& s : spans_) {
      const CloudPoint* p = s.batch->data() + s.first;
      for (size_t k = 0; k < s.n; ++k) f(s.start + k, p[k]);
    }
  }
  std::vector<CloudPoint> Flatten() const {
    std::vector<CloudPoint> out;
    out.reserve(size_);
    for (const Span& s : spans_)
      out.insert(out.end(), s.batch->begin() + s.first, s.batch->begin() + s.first + s.n);
    return out;
  }

 private:
  struct Span {
    std::shared_ptr<const std::vector<CloudPoint>> batch;
    size_t first, n;  // The batch's points first .. first + n - 1,
    size_t start;     // which are the growing chunk's start .. start + n - 1.
  };
  std::vector<Span> spans_;
  size_t size_ = 0;
};

struct CloudView::Chunk {
  std::shared_ptr<const PackedChunk> packed;  // Sealed chunks.
  uint32_t serial = 0;  // Sealed chunks: its source number in the motion sample, in order.
  GrowingPoints growing;  // The growing chunk's points.
  size_t size = 0;
  std::array<double, 6> bounds{};  // x min, x max, y min, y max, z min, z max
  // Values given after the fact (pass, deviation, intensity), one per point,
  // quantised to 16 bits over their range (CloudView::value_lo_/step_);
  // null or empty when none were given. A sealed chunk's are shared with
  // the picks searching on the pick thread (cloud_pick.h): replaced when
  // new ones are given, never changed in place.
  std::shared_ptr<std::vector<uint16_t>> values[3];
  const std::vector<uint16_t>& Values(int k) const {
    static const std::vector<uint16_t> kNone;
    return values[k] ? *values[k] : kNone;
  }
  Drawn motion;  // Sealed chunks: the level drawn while the camera moves.
  Drawn rest;    // The growing chunk: every point; sealed: the rest level.
  int rest_target = 0;               // The finest rest stride the last plan asked for (0: none).
  std::vector<uint8_t> rest_shifts;  // ... and each cube's (as Drawn::shifts).
  std::vector<uint32_t> cubes;       // Its census cubes' places in the cloud's census.
  bool merged = false;               // ... once counted there.
  bool sealed() const { return packed != nullptr; }
};

// Consecutive sealed chunks' levels drawn as one actor
// (cloud_view_batches.cc): the concatenation of their drawn arrays.
struct CloudView::Batch {
  Drawn drawn;  // poly, mapper and actor only
  std::vector<vtkPolyData*> sources;  // The chunks' levels it was built from.
  vtkMTimeType built = 0;
  size_t points() const { return drawn.poly ? static_cast<size_t>(drawn.poly->GetNumberOfPoints()) : 0; }
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_VIEW_CLOUD_VIEW_CHUNK_H_
