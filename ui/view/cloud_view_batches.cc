// CloudView's draw batches: sealed chunks are drawn through one actor per
// batch of consecutive chunks, not one per chunk.
//
// Why: under Mesa llvmpipe a visible actor costs about 60 us a frame
// (mapper state, buffer binding, shader uniforms) whatever its size. A
// 100 M-point cloud is 1 519 chunks: one actor each made the motion level
// (97 000 points) run at 7.8 frames/s, of which ~90 ms a frame was actors.
// * The motion level (at most the LOD budget, ~40 points a chunk at 100 M)
//   is batched by kMotionBatches * kBatchChunks = 128 chunks: 12 actors.
// * The rest level is batched by at most kBatchChunks chunks and at most
//   kRestBatchPoints (32 768) drawn points, or one chunk: ~110 actors at
//   100 M. The bound on points lets the rest level be drawn in progressive
//   passes of about the LOD budget each (cloud_view_progressive.cc): a
//   batch of 16 chunks drawn whole would be a million points, a ~0.35 s
//   frame in software. Half a chunk rather than a whole one: the passes'
//   turns came to a median of 28 ms instead of 42 (the budget overshot
//   by less).
//
// A batch's arrays are the concatenation of its chunks' drawn arrays (the
// motion level, or for the rest level each chunk's rest level where it has
// one and its motion level where not), rebuilt before a frame when a member
// changed (VTK's modification times) or the members changed. The copies
// are at most the budgets (the LOD and the rest budget) in total.
#include <vtkCallbackCommand.h>
#include <vtkCellArray.h>
#include <vtkFloatArray.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkPointData.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>
#include <vtkTimeStamp.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "ui/view/cloud_view.h"
#include "ui/view/cloud_view_chunk.h"

namespace sweepscan::ui {

using cloud_view_internal::kScalarName;

namespace {

// Appends one level's vertex cells to the batch's, their point ids moved
// by `base` (the points before the level's in the batch).
template <typename Id>
void AppendCells(const Id* offsets, const Id* ids, vtkIdType cells, int32_t base,
                 int32_t* out_offsets, int32_t* out_ids) {
  const int32_t start = out_offsets[0];
  for (vtkIdType k = 0; k < cells; ++k) out_offsets[k] = start + static_cast<int32_t>(offsets[k]);
  out_offsets[cells] = start + static_cast<int32_t>(offsets[cells]);
  for (Id k = 0; k < offsets[cells]; ++k) out_ids[start + k] = base + static_cast<int32_t>(ids[k]);
}

// The batch's poly data: its levels' float points, colour scalars and
// vertex cells one after another. By hand rather than through
// vtkAppendPolyData, whose cells come out with 64-bit ids: 16 bytes a drawn
// point instead of 8, 7 MiB at the 0.9 M points of a 9.5 M-point cloud at
// rest. (A batch holds at most a few hundred thousand points: 32-bit ids
// hold them.)
vtkSmartPointer<vtkPolyData> Concatenate(const std::vector<vtkPolyData*>& levels) {
  vtkIdType n = 0, cells = 0, ids = 0;
  for (vtkPolyData* level : levels) {
    n += level->GetNumberOfPoints();
    cells += level->GetVerts()->GetNumberOfCells();
    ids += level->GetVerts()->GetNumberOfConnectivityIds();
  }
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetDataTypeToFloat();
  points->SetNumberOfPoints(n);
  auto scalar = vtkSmartPointer<vtkFloatArray>::New();
  scalar->SetName(kScalarName);
  scalar->SetNumberOfValues(n);
  auto offsets = vtkSmartPointer<vtkTypeInt32Array>::New();
  offsets->SetNumberOfValues(cells + 1);
  auto connectivity = vtkSmartPointer<vtkTypeInt32Array>::New();
  connectivity->SetNumberOfValues(ids);
  float* xyz = static_cast<float*>(points->GetVoidPointer(0));
  float* s = scalar->GetPointer(0);
  int32_t* off = offsets->GetPointer(0);
  int32_t* conn = connectivity->GetPointer(0);
  off[0] = 0;
  vtkIdType base = 0;
  for (vtkPolyData* level : levels) {
    const vtkIdType m = level->GetNumberOfPoints();
    // Every drawn level's points are float (FillDrawn, FilterMotion, GrowingChunk).
    const float* from = static_cast<const float*>(level->GetPoints()->GetVoidPointer(0));
    std::copy_n(from, 3 * m, xyz + 3 * base);
    auto* level_scalar = vtkFloatArray::SafeDownCast(level->GetPointData()->GetArray(kScalarName));
    if (level_scalar != nullptr && level_scalar->GetNumberOfValues() == m) {
      std::copy_n(level_scalar->GetPointer(0), m, s + base);
    } else {
      // Drawn in the lookup table's NaN colour.
      std::fill_n(s + base, m, cloud_view_internal::kNaN);
    }
    vtkCellArray* verts = level->GetVerts();
    const vtkIdType c = verts->GetNumberOfCells();
    if (c == 0) {
      // No cell shown (the pass filter hides the level): its points ride along.
    } else if (verts->IsStorage64Bit()) {
      AppendCells(verts->GetOffsetsArray64()->GetPointer(0),
                  verts->GetConnectivityArray64()->GetPointer(0), c, static_cast<int32_t>(base),
                  off, conn);
    } else {
      AppendCells(verts->GetOffsetsArray32()->GetPointer(0),
                  verts->GetConnectivityArray32()->GetPointer(0), c, static_cast<int32_t>(base),
                  off, conn);
    }
    off += c;
    base += m;
  }
  auto verts = vtkSmartPointer<vtkCellArray>::New();
  verts->SetData(offsets, connectivity);
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetVerts(verts);
  poly->GetPointData()->AddArray(scalar);
  return poly;
}

}  // namespace

void CloudView::SyncBatches() {
  // Nothing drawn changed since the last check: the batches hold. Asking
  // each chunk's poly data (vtkPolyData::GetMTime walks its points, cells
  // and arrays) cost ~3 ms a frame at 100 M points (3 000 levels, twice).
  if (drawn_generation_ == synced_generation_) return;
  synced_generation_ = drawn_generation_;
  size_t sealed = chunks_.size();
  if (sealed > 0 && !chunks_.back()->sealed()) --sealed;
  std::vector<std::pair<size_t, size_t>> motion, rest;  // [first, end) chunk ranges
  const size_t span = kMotionBatches * kBatchChunks;
  for (size_t first = 0; first < sealed; first += span) motion.emplace_back(first, std::min(sealed, first + span));
  size_t first = 0, points = 0;
  for (size_t j = 0; j < sealed; ++j) {
    const size_t n = RestSource(*chunks_[j]).size();
    if (j > first && (j - first == kBatchChunks || points + n > kRestBatchPoints)) {
      rest.emplace_back(first, j);
      first = j;
      points = 0;
    }
    points += n;
  }
  if (first < sealed) rest.emplace_back(first, sealed);
  const bool added_motion = SyncLevel(motion, false, &motion_batches_);
  const bool added_rest = SyncLevel(rest, true, &rest_batches_);
  if (added_motion || added_rest) ShowLevels();
}

const CloudView::Drawn& CloudView::RestSource(const Chunk& c) {
  return c.rest.stride > 0 ? c.rest : c.motion;
}

bool CloudView::SyncLevel(const std::vector<std::pair<size_t, size_t>>& ranges, bool rest,
                          std::vector<std::unique_ptr<Batch>>* batches) {
  while (batches->size() > ranges.size()) {
    renderer_->RemoveActor(batches->back()->drawn.actor);
    batches->pop_back();
  }
  const bool added = batches->size() < ranges.size();
  while (batches->size() < ranges.size()) {
    auto b = std::make_unique<Batch>();
    NewDrawnActor(&b->drawn);
    batches->push_back(std::move(b));
  }
  for (size_t i = 0; i < ranges.size(); ++i) {
    Batch& b = *(*batches)[i];
    std::vector<vtkPolyData*> sources;
    bool dirty = false;
    for (size_t j = ranges[i].first; j < ranges[i].second; ++j) {
      const Chunk& c = *chunks_[j];
      const Drawn& d = rest ? RestSource(c) : c.motion;
      if (!d.poly) continue;
      sources.push_back(d.poly);
      dirty = dirty || d.poly->GetMTime() > b.built;
    }
    if (!dirty && sources == b.sources) continue;
    b.sources = std::move(sources);
    b.drawn.poly = Concatenate(b.sources);
    b.drawn.mapper->SetInputData(b.drawn.poly);
    vtkTimeStamp now;
    now.Modified();
    b.built = now.GetMTime();
  }
  return added;
}

void CloudView::ClearBatches() {
  for (auto* level : {&motion_batches_, &rest_batches_}) {
    for (const auto& b : *level) renderer_->RemoveActor(b->drawn.actor);
    level->clear();
  }
}

void CloudView::InstallBatchObserver() {
  // Whoever renders (our timer, the interactor while the camera moves), the
  // batches are brought up to date first.
  auto sync = vtkSmartPointer<vtkCallbackCommand>::New();
  sync->SetClientData(this);
  sync->SetCallback([](vtkObject*, unsigned long, void* self, void*) {
    static_cast<CloudView*>(self)->SyncBatches();
  });
  window_->AddObserver(vtkCommand::StartEvent, sync, 1.0);  // Before the frame clock.
}

}  // namespace sweepscan::ui
