// CloudView's content as it arrives (cloud_view_chunk.h): points appended
// to the growing chunk, the chunks the cloud store sealed taking its place.
#include <vtkActor.h>
#include <vtkCellArray.h>
#include <vtkFloatArray.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>

#include <QTimer>
#include <algorithm>
#include <limits>
#include <vector>

#include "core/cloud/cloud_pager.h"
#include "ui/view/cloud_view.h"
#include "ui/view/cloud_view_chunk.h"

namespace sweepscan::ui {
using cloud_view_internal::kNaN;
using cloud_view_internal::kScalarName;

namespace {

// Bounds and ranges start from +-inf: a NaN coordinate (a chunk may hold
// one) is then never a bound, as std::min and std::max keep their first
// argument against NaN.
constexpr float kInf = std::numeric_limits<float>::infinity();

// 0, 1, 2, ... kChunkPoints: the growing chunk's vertex cells while every
// point is drawn are the identity (cell k is point k), their offsets and
// connectivity both prefixes of this one array. Shared read-only, it saves
// writing 8 bytes a point as they arrive: InsertNextCell was the largest
// share of live insertion (perf, view_insertion_benchmark).
int32_t* IdentityIds() {
  static std::vector<int32_t>* ids = [] {
    auto* v = new std::vector<int32_t>(CloudView::kChunkPoints + 1);
    for (size_t k = 0; k < v->size(); ++k) (*v)[k] = static_cast<int32_t>(k);
    return v;
  }();
  return ids->data();
}

// The vertex cells 0..n-1 over IdentityIds(): n + 1 offsets, n ids, no copy
// (VTK keeps the array it does not own; a later InsertNextCell would
// reallocate, never write into it).
void SetIdentityVerts(vtkCellArray* verts, size_t n) {
  if (!verts->IsStorage64Bit()) {
    vtkTypeInt32Array* offsets = verts->GetOffsetsArray32();
    vtkTypeInt32Array* connectivity = verts->GetConnectivityArray32();
    if (offsets->GetPointer(0) == IdentityIds() && connectivity->GetPointer(0) == IdentityIds()) {
      offsets->SetArray(IdentityIds(), static_cast<vtkIdType>(n + 1), 1);
      connectivity->SetArray(IdentityIds(), static_cast<vtkIdType>(n), 1);
      return;
    }
  }
  auto offsets = vtkSmartPointer<vtkTypeInt32Array>::New();
  offsets->SetArray(IdentityIds(), static_cast<vtkIdType>(n + 1), 1);
  auto connectivity = vtkSmartPointer<vtkTypeInt32Array>::New();
  connectivity->SetArray(IdentityIds(), static_cast<vtkIdType>(n), 1);
  verts->SetData(offsets, connectivity);
}

}  // namespace

CloudView::Chunk* CloudView::GrowingChunk() {
  if (!chunks_.empty() && !chunks_.back()->sealed()) return chunks_.back().get();
  auto chunk = std::make_unique<Chunk>();
  chunk->bounds = EmptyBounds();
  Drawn& d = chunk->rest;
  if (spare_growing_) {
    // The last growing chunk's arrays (their memory kept), mapper (its
    // buffers) and actor, emptied: a seal (every 13 s of an X4) allocates,
    // faults in and frees no 1 MB and builds no VTK pipeline (perf of
    // view_insertion_benchmark: a fifth of the seals' GUI time).
    d = std::move(spare_growing_->rest);
    spare_growing_.reset();
    d.points->Reset();
    d.points->Modified();
    d.scalar->Reset();
    d.scalar->Modified();
    SetIdentityVerts(d.verts, 0);
    d.verts->Modified();
    d.poly->Modified();
    // What changed while it waited (the clip, the point size).
    ApplyClip(d.mapper);
    d.actor->GetProperty()->SetPointSize(point_size_);
    d.actor->VisibilityOn();
  } else {
    d.stride = 1;
    d.points = vtkSmartPointer<vtkPoints>::New();
    d.points->SetDataTypeToFloat();
    d.points->Allocate(kChunkPoints);
    d.scalar = vtkSmartPointer<vtkFloatArray>::New();
    d.scalar->SetName(kScalarName);
    d.scalar->Allocate(kChunkPoints);
    d.verts = vtkSmartPointer<vtkCellArray>::New();
    SetIdentityVerts(d.verts, 0);
    d.poly = vtkSmartPointer<vtkPolyData>::New();
    d.poly->SetPoints(d.points);
    d.poly->SetVerts(d.verts);
    d.poly->GetPointData()->AddArray(d.scalar);
    NewDrawnActor(&d);
    d.mapper->SetInputData(d.poly);
  }
  chunks_.push_back(std::move(chunk));
  return chunks_.back().get();
}

void CloudView::RetireGrowing() {
  std::unique_ptr<Chunk> growing = std::move(chunks_.back());
  chunks_.pop_back();
  DrawnChanged();
  if (spare_growing_) RemoveChunkActors(spare_growing_.get());
  spare_growing_.reset();
  // Only the growing chunk's own level, as GrowingChunk built it, is kept.
  if (growing->rest.actor && growing->rest.points && growing->rest.scalar &&
      !growing->motion.actor) {
    growing->rest.actor->VisibilityOff();
    spare_growing_ = std::move(growing);
  } else {
    RemoveChunkActors(growing.get());
  }
}

void CloudView::RemoveChunkActors(Chunk* chunk) {
  DrawnChanged();
  for (Drawn* d : {&chunk->motion, &chunk->rest}) {
    if (d->actor) renderer_->RemoveActor(d->actor);
    *d = Drawn();
  }
}

void CloudView::AddSealed(std::shared_ptr<const PackedChunk> packed,
                          std::shared_ptr<const ChunkPayload> payload) {
  // The growing chunk's points are the packed chunk's first points: the
  // sealed chunk takes its place (and its values given so far).
  std::shared_ptr<std::vector<uint16_t>> values[3];
  size_t known = 0;
  if (!chunks_.empty() && !chunks_.back()->sealed()) {
    Chunk* growing = chunks_.back().get();
    known = growing->size;
    for (int k = 0; k < 3; ++k) values[k] = std::move(growing->values[k]);
    RetireGrowing();
  }
  auto chunk = std::make_unique<Chunk>();
  chunk->size = packed->size();
  chunk->bounds = packed->bounds();
  for (int k = 0; k < 3; ++k) {
    if ((values[k] && !values[k]->empty()) || has_values_[3 + k]) {
      // The growing chunk's own vector (never shared), grown to the chunk.
      if (!values[k]) values[k] = std::make_shared<std::vector<uint16_t>>();
      values[k]->resize(chunk->size, cloud_view_internal::kNoValue);
      chunk->values[k] = std::move(values[k]);
    }
  }
  chunk->packed = std::move(packed);
  DrawnChanged();
  Chunk* c = chunk.get();
  chunks_.push_back(std::move(chunk));
  point_count_ += c->size - known;
  c->serial = next_serial_++;
  if (payload == nullptr && !lod_active_) payload = c->packed->Pin();  // Read twice below.
  BuildMotion(c, payload);
  FitMotion();
  // A chunk sealed at rest is drawn in full until the next plan.
  if (!lod_active_) BuildDrawn(c, 1, &c->rest, payload);
  ShowLevels();
}

void CloudView::SealGrowing() {
  const std::vector<CloudPoint> points = chunks_.back()->growing.Flatten();
  AddSealed(PackedChunk::Pack(points.data(), points.size(), &CloudPager::Default()));
}

void CloudView::AppendSealed(const std::vector<std::shared_ptr<const PackedChunk>>& chunks,
                             const std::vector<std::shared_ptr<const ChunkPayload>>& unpacked) {
  if (chunks.empty()) return;
  // A large batch (an opened session's whole cloud at once) is drawn at
  // the level it will have: the motion sample's candidates for the final
  // count and no full-resolution rest level per chunk, which for 10 M
  // points would build 10 M drawn points only to drop them after the loop.
  size_t incoming = 0;
  for (const auto& packed : chunks) incoming += packed->size();
  count_hint_ = point_count_ + incoming;
  if (point_count_ + incoming > lod_budget_) SetLodActive(true);
  for (size_t k = 0; k < chunks.size(); ++k) {
    const auto& packed = chunks[k];
    if (packed->size() == 0) continue;
    if (!have_origin_) {
      time_origin_ns_ = packed->first_time_ns();
      have_origin_ = true;
    }
    const auto& b = packed->bounds();
    const float t_hi = static_cast<float>((packed->last_time_ns() - time_origin_ns_) * 1e-9);
    AddSealed(packed, k < unpacked.size() ? unpacked[k] : nullptr);
    UpdateRanges(static_cast<float>(b[4]), t_hi, packed->max_range_m());
    UpdateRanges(static_cast<float>(b[5]), t_hi, packed->max_range_m());
  }
  count_hint_ = 0;
  if (point_count_ > lod_budget_) {
    SetLodActive(true);
    settle_->start();
  }
  RequestRender();
}

void CloudView::AppendPoints(const std::vector<CloudPoint>& points) {
  AppendPoints(std::vector<CloudPoint>(points));
}

void CloudView::AppendPoints(std::vector<CloudPoint>&& moved) {
  if (moved.empty()) return;
  const auto batch = std::make_shared<const std::vector<CloudPoint>>(std::move(moved));
  const std::vector<CloudPoint>& points = *batch;
  if (!have_origin_) {
    time_origin_ns_ = points.front().time_ns;
    have_origin_ = true;
  }
  float z_lo = kInf, z_hi = -kInf, t_hi = 0.0f, r_hi = 0.0f;
  Chunk* chunk = GrowingChunk();
  for (size_t i = 0; i < points.size();) {
    if (chunk->size >= kChunkPoints) {
      SealGrowing();
      chunk = GrowingChunk();
    }
    const size_t n = std::min(points.size() - i, kChunkPoints - chunk->size);
    AppendToGrowing(chunk, batch, i, n, &z_lo, &z_hi, &t_hi, &r_hi);
    i += n;
  }
  // While points stream in, sealed chunks are drawn at the motion level
  // (renders stay short and the GUI responsive); the rest level returns when
  // the data pauses.
  if (point_count_ > lod_budget_) {
    SetLodActive(true);
    settle_->start();
  }
  if (z_lo <= z_hi) {  // Not when every height was NaN.
    UpdateRanges(z_lo, t_hi, r_hi);
    UpdateRanges(z_hi, t_hi, r_hi);
  }
  RequestRender();
}

void CloudView::AppendToGrowing(Chunk* chunk,
                                const std::shared_ptr<const std::vector<CloudPoint>>& batch,
                                size_t first, size_t n, float* z_lo, float* z_hi, float* t_hi,
                                float* r_hi) {
  const CloudPoint* p = batch->data() + first;
  // Written in place through the arrays' pointers, within the capacity
  // GrowingChunk allocated (a chunk's worth: nothing is reallocated).
  Drawn& d = chunk->rest;
  const size_t old = chunk->size;
  auto* xyz_array = vtkFloatArray::FastDownCast(d.points->GetData());
  // Setting more tuples than allocated would allocate afresh without
  // copying (VTK's Allocate); Resize copies.
  if (xyz_array->GetSize() < static_cast<vtkIdType>(3 * kChunkPoints))
    xyz_array->Resize(kChunkPoints);
  if (d.scalar->GetSize() < static_cast<vtkIdType>(kChunkPoints)) d.scalar->Resize(kChunkPoints);
  xyz_array->SetNumberOfTuples(static_cast<vtkIdType>(old + n));
  d.scalar->SetNumberOfValues(static_cast<vtkIdType>(old + n));
  float* xyz = xyz_array->GetPointer(static_cast<vtkIdType>(3 * old));
  float* s = d.scalar->GetPointer(static_cast<vtkIdType>(old));
  const int m = static_cast<int>(color_mode_);
  float lo[3] = {kInf, kInf, kInf}, hi[3] = {-kInf, -kInf, -kInf};
  float t_max = *t_hi, r_max = *r_hi;
  for (size_t k = 0; k < n; ++k) {
    const CloudPoint& q = p[k];
    xyz[3 * k] = q.x;
    xyz[3 * k + 1] = q.y;
    xyz[3 * k + 2] = q.z;
    const float t = static_cast<float>((q.time_ns - time_origin_ns_) * 1e-9);
    s[k] = m == 0 ? q.z : m == 1 ? t : m == 2 ? q.range_m : kNaN;
    lo[0] = std::min(lo[0], q.x);
    hi[0] = std::max(hi[0], q.x);
    lo[1] = std::min(lo[1], q.y);
    hi[1] = std::max(hi[1], q.y);
    lo[2] = std::min(lo[2], q.z);
    hi[2] = std::max(hi[2], q.z);
    t_max = std::max(t_max, t);
    r_max = std::max(r_max, q.range_m);
  }
  if (batch->size() > kChunkPoints && 4 * n < batch->size()) {
    // The tail of a batch larger than a chunk (the view's own packing, not
    // the live path): copied, so that it does not hold the whole batch.
    chunk->growing.Append(std::make_shared<const std::vector<CloudPoint>>(p, p + n), 0, n);
  } else {
    chunk->growing.Append(batch, first, n);
  }
  // Values given after the fact: none yet for the new points.
  for (auto& v : chunk->values) {  // The growing chunk's: not shared.
    if (v && !v->empty()) v->resize(v->size() + n, cloud_view_internal::kNoValue);
  }
  // A new point has no pass yet: drawn only while no pass filter is on.
  if (pass_filter_ < 0) SetIdentityVerts(d.verts, old + n);
  for (int a = 0; a < 3; ++a) {
    chunk->bounds[2 * a] = std::min<double>(chunk->bounds[2 * a], lo[a]);
    chunk->bounds[2 * a + 1] = std::max<double>(chunk->bounds[2 * a + 1], hi[a]);
  }
  chunk->size = old + n;
  point_count_ += n;
  *z_lo = std::min(*z_lo, lo[2]);
  *z_hi = std::max(*z_hi, hi[2]);
  *t_hi = t_max;
  *r_hi = r_max;
  // Only the growing chunk is marked modified: it alone is uploaded again.
  d.points->Modified();
  d.scalar->Modified();
  d.verts->Modified();
  d.poly->Modified();
}

}  // namespace sweepscan::ui
