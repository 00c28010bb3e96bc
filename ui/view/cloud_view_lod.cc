// CloudView's level of detail: what VTK holds of each chunk (the motion and
// rest levels), the rest plan under the point budget, and its building in
// slices. See cloud_view.h for the scheme and docs/cloud-store.md for why.
#include <vtkCamera.h>
#include <vtkIdList.h>
#include <vtkPointData.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>

#include <QElapsedTimer>
#include <QTimer>
#include <algorithm>
#include <climits>
#include <cmath>
#include <iterator>
#include <limits>

#include "core/cloud/cube_budget.h"
#include "core/geometry/box_planes.h"
#include "ui/view/cloud_view.h"
#include "ui/view/cloud_view_chunk.h"

namespace sweepscan::ui {
using cloud_view_internal::kNaN;
using cloud_view_internal::kNoCube;
using cloud_view_internal::kNoValue;
using cloud_view_internal::kScalarName;

namespace {

// A drawn level's points, with a fresh colour scalar (filled by the caller)
// and the polydata that carries both; its vertex cells come after. (A
// template: CloudView::Drawn is private to the view.)
template <typename Drawn>
void SetPoints(Drawn* d, vtkSmartPointer<vtkPoints> points) {
  d->points = points;
  d->scalar = vtkSmartPointer<vtkFloatArray>::New();
  d->scalar->SetName(kScalarName);
  d->scalar->SetNumberOfValues(points->GetNumberOfPoints());
  d->poly = vtkSmartPointer<vtkPolyData>::New();
  d->poly->SetPoints(points);
  d->poly->GetPointData()->AddArray(d->scalar);
}

// Each point's census cube's shift (Drawn::shifts; kNoCube: not drawn):
// from a dense grid over the census's cubes (a room's chunk spans a few
// thousand), else by binary search in the census, looked up again only when
// the cube changes (every second point or so along a scan line).
class CubeShiftOf {
 public:
  CubeShiftOf(const std::vector<uint64_t>& keys, const std::vector<uint8_t>& shifts)
      : keys_(keys), shifts_(shifts) {
    if (keys.empty()) return;
    int32_t hi[3] = {INT32_MIN, INT32_MIN, INT32_MIN};
    for (uint64_t key : keys) {
      for (int a = 0; a < 3; ++a) {
        lo_[a] = std::min(lo_[a], PackedChunk::CellOfKey(key, a));
        hi[a] = std::max(hi[a], PackedChunk::CellOfKey(key, a));
      }
    }
    for (int a = 0; a < 3; ++a) dim_[a] = static_cast<size_t>(hi[a] - lo_[a]) + 1;
    if (dim_[0] * dim_[1] * dim_[2] > (size_t{1} << 18)) return;
    grid_.assign(dim_[0] * dim_[1] * dim_[2], kNoCube);
    for (size_t k = 0; k < keys.size(); ++k) {
      size_t at = 0;
      for (int a = 0; a < 3; ++a) {
        at = at * dim_[a] + static_cast<size_t>(PackedChunk::CellOfKey(keys[k], a) - lo_[a]);
      }
      grid_[at] = shifts[k];
    }
  }

  // The finest shift of the cubes a box (x min, x max, y min, y max, z min,
  // z max) meets: every point in the box lies in one of them. Without the
  // grid, or for a box over more than 64 cubes, 0 (the caller's finest
  // stride, the chunk's, stands).
  uint8_t FinestIn(const float* box) const {
    if (grid_.empty()) return 0;
    size_t lo[3], n[3];
    for (int a = 0; a < 3; ++a) {
      const int32_t c0 = PackedChunk::CellIndex(box[2 * a]) - lo_[a];
      const int32_t c1 = PackedChunk::CellIndex(box[2 * a + 1]) - lo_[a];
      if (c0 < 0 || c1 < c0 || static_cast<size_t>(c1) >= dim_[a]) return 0;
      lo[a] = static_cast<size_t>(c0);
      n[a] = static_cast<size_t>(c1 - c0) + 1;
    }
    if (n[0] * n[1] * n[2] > 64) return 0;
    uint8_t finest = kNoCube;
    for (size_t x = lo[0]; x < lo[0] + n[0]; ++x) {
      for (size_t y = lo[1]; y < lo[1] + n[1]; ++y) {
        const uint8_t* row = &grid_[(x * dim_[1] + y) * dim_[2] + lo[2]];
        for (size_t z = 0; z < n[2]; ++z) finest = std::min(finest, row[z]);
      }
    }
    return finest;
  }

  uint8_t operator()(const float v[3]) {
    if (!grid_.empty()) {
      size_t at = 0;
      for (int a = 0; a < 3; ++a) {
        const size_t c = static_cast<size_t>(PackedChunk::CellIndex(v[a]) - lo_[a]);
        if (c >= dim_[a]) return kNoCube;
        at = at * dim_[a] + c;
      }
      return grid_[at];
    }
    const uint64_t key = PackedChunk::CellKey(v);
    if (key != last_key_) {
      const auto it = std::lower_bound(keys_.begin(), keys_.end(), key);
      last_key_ = key;
      last_shift_ = it != keys_.end() && *it == key
                        ? shifts_[static_cast<size_t>(it - keys_.begin())]
                        : kNoCube;
    }
    return last_shift_;
  }

 private:
  const std::vector<uint64_t>& keys_;
  const std::vector<uint8_t>& shifts_;
  int32_t lo_[3] = {INT32_MAX, INT32_MAX, INT32_MAX};
  size_t dim_[3] = {0, 0, 0};
  std::vector<uint8_t> grid_;
  uint64_t last_key_ = ~uint64_t{0};
  uint8_t last_shift_ = kNoCube;
};

}  // namespace

float CloudView::ValueOf(const Chunk& chunk, int mode, size_t i) const {
  const std::vector<uint16_t>& v = chunk.Values(mode - 3);
  if (i >= v.size() || v[i] == kNoValue) return kNaN;
  return static_cast<float>(value_lo_[mode - 3] + v[i] * value_step_[mode - 3]);
}

bool CloudView::Passes(const Chunk& chunk, size_t i) const {
  static_assert(PassTest::kNone == kNoValue);
  return PassTest{pass_filter_, value_lo_[0], value_step_[0]}.Passes(chunk.Values(0), i);
}

void CloudView::BuildDrawn(Chunk* chunk, int stride, Drawn* d,
                           std::shared_ptr<const ChunkPayload> payload,
                           std::vector<uint8_t> shifts) {
  // Every stride-th point (counted from the chunk's first; of each census
  // cube, its own stride if `shifts` are given): representative of the
  // chunk, as a chunk's points are consecutive samples along the scan lines
  // (each line thinned evenly); and the motion level's points, which the
  // progressive passes' pass 0 drew, so that the finished image holds no
  // point the rest level lacks. The strides are powers of two, the finest
  // `stride`, so every cube's points are among the multiples of it.
  const size_t step = static_cast<size_t>(stride);
  std::vector<uint32_t> strided;
  strided.reserve((chunk->size + step - 1) / step);
  if (shifts.empty() || !chunk->sealed()) {
    for (size_t i = 0; i < chunk->size; i += step) strided.push_back(static_cast<uint32_t>(i));
  } else {
    if (payload == nullptr) payload = chunk->packed->Pin();
    const std::vector<uint64_t>& keys = chunk->packed->cell_keys();
    CubeShiftOf shift_of(keys, shifts);
    // Block by block (PackedChunk::block_bounds()), at the finest stride of
    // the cubes its box meets: a chunk's finest stride is mostly that of a
    // few sparse cubes drawn whole, and passing every point at it cost the
    // first plan of the 99.5 M-point drive 1.8 s against 0.85.
    const std::vector<std::array<float, 6>>& blocks = chunk->packed->block_bounds();
    for (size_t b = 0; b < blocks.size(); ++b) {
      const uint8_t block_shift = shift_of.FinestIn(blocks[b].data());
      if (block_shift == kNoCube) continue;  // none of its cubes drawn
      const size_t block_step = std::max(step, size_t{1} << block_shift);
      const size_t first = b * PackedChunk::kBlockPoints;
      const size_t end = std::min(chunk->size, first + PackedChunk::kBlockPoints);
      for (size_t i = (first + block_step - 1) / block_step * block_step; i < end; i += block_step) {
        float v[3];
        chunk->packed->PositionOf(*payload, i, v);
        const uint8_t shift = shift_of(v);
        if (shift != kNoCube && (i & ((size_t{1} << shift) - 1)) == 0) {
          strided.push_back(static_cast<uint32_t>(i));
        }
      }
    }
  }
  const std::vector<uint32_t>& motion = chunk->motion.index;
  std::vector<uint32_t> index;
  index.reserve(strided.size() + motion.size());
  std::set_union(strided.begin(), strided.end(), motion.begin(), motion.end(),
                 std::back_inserter(index));
  d->shifts = std::move(shifts);
  FillDrawn(chunk, std::move(index), stride, d, std::move(payload));
}

void CloudView::FillDrawn(Chunk* chunk, std::vector<uint32_t> index, int stride, Drawn* d,
                          std::shared_ptr<const ChunkPayload> payload) {
  DrawnChanged();
  const size_t n = index.size();
  const bool motion = d == &chunk->motion;
  if (chunk->sealed() && payload == nullptr) payload = chunk->packed->Pin();
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetDataTypeToFloat();
  points->SetNumberOfPoints(static_cast<vtkIdType>(n));
  float* xyz = static_cast<float*>(points->GetVoidPointer(0));
  std::vector<float> time_s(n), range_m(n);
  const std::vector<ScanRun>* runs = chunk->sealed() ? &chunk->packed->runs() : nullptr;
  size_t run = 0;
  for (size_t k = 0; k < n; ++k) {
    const size_t i = index[k];
    if (chunk->sealed()) {
      while (run + 1 < runs->size() && (*runs)[run + 1].first <= i) ++run;
      chunk->packed->PositionOf(*payload, i, xyz + 3 * k);
      time_s[k] = static_cast<float>((chunk->packed->TimeOf(*payload, i, run) - time_origin_ns_) * 1e-9);
      range_m[k] = chunk->packed->RangeOf(*payload, i);
    } else {
      const CloudPoint& p = chunk->growing[i];
      xyz[3 * k] = p.x;
      xyz[3 * k + 1] = p.y;
      xyz[3 * k + 2] = p.z;
      time_s[k] = static_cast<float>((p.time_ns - time_origin_ns_) * 1e-9);
      range_m[k] = p.range_m;
    }
  }
  d->stride = stride;
  d->index = std::move(index);
  SetPoints(d, points);
  if (motion) {
    d->time_s = std::move(time_s);
    d->range_m = std::move(range_m);
    Recolor(chunk, d);
  } else {
    // The rest level keeps no side arrays: its scalar is filled here, and a
    // new colour mode reads the chunk again.
    const int m = static_cast<int>(color_mode_);
    float* s = d->scalar->GetPointer(0);
    for (size_t k = 0; k < n; ++k) {
      s[k] = m == 0 ? xyz[3 * k + 2] : m == 1 ? time_s[k] : m == 2 ? range_m[k]
                                                           : ValueOf(*chunk, m, d->At(k));
    }
  }
  RefilterVerts(*chunk, d);
  // Drawn through its batch (cloud_view_batches.cc), no actor of its own.
}

void CloudView::BuildMotion(Chunk* chunk, std::shared_ptr<const ChunkPayload> payload) {
  // The candidates: every c-th point of the chunk, c a power of two that
  // gives the chunk its share of 8 lod budgets over the cloud, between
  // 2 048 and 16 384 a chunk: several times more candidates than
  // representatives, so that each cell's first candidate stands for it, at
  // a bounded cost on the GUI thread (at most a hash lookup a candidate; at
  // 100 M points and a budget of 30 000, 2 048 a chunk, 3 M in all; live,
  // 16 384 for each of the first chunks).
  const size_t count = std::max({count_hint_, point_count_, chunk->size});
  const double total = static_cast<double>(std::min<size_t>(8 * lod_budget_, 2'000'000));
  const size_t want = std::clamp<size_t>(static_cast<size_t>(total * chunk->size / count), 2048, 16384);
  int c = 1;
  while (chunk->size / c > want) c *= 2;
  if (payload == nullptr) payload = chunk->packed->Pin();
  const size_t n = (chunk->size + c - 1) / c;
  std::vector<float> xyz(3 * n);
  std::vector<uint32_t> index(n);
  for (size_t k = 0; k < n; ++k) {
    index[k] = static_cast<uint32_t>(k * c);
    chunk->packed->PositionOf(*payload, index[k], xyz.data() + 3 * k);
  }
  std::vector<uint32_t> taken;
  motion_sample_.Offer(chunk->serial, xyz.data(), index.data(), n, &taken);
  for (uint32_t& k : taken) k = index[k];
  FillDrawn(chunk, std::move(taken), c, &chunk->motion, std::move(payload));
}

void CloudView::FilterMotion(Chunk* chunk) {
  Drawn& d = chunk->motion;
  if (d.stride == 0) return;
  // The representatives the sample still holds (it merged cells): a subset
  // of the level, so the (maybe paged) chunk is not read.
  const size_t n0 = d.size();
  const float* src = static_cast<const float*>(d.points->GetVoidPointer(0));
  std::vector<size_t> keep;
  for (size_t k = 0; k < n0; ++k) {
    if (motion_sample_.Holds(chunk->serial, d.index[k], src + 3 * k)) keep.push_back(k);
  }
  if (keep.size() == n0) return;
  DrawnChanged();
  const size_t n = keep.size();
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetDataTypeToFloat();
  points->SetNumberOfPoints(static_cast<vtkIdType>(n));
  float* dst = static_cast<float*>(points->GetVoidPointer(0));
  for (size_t j = 0; j < n; ++j) {
    const size_t k = keep[j];
    std::copy_n(src + 3 * k, 3, dst + 3 * j);
    d.index[j] = d.index[k];
    d.time_s[j] = d.time_s[k];
    d.range_m[j] = d.range_m[k];
  }
  for (auto* v : {&d.time_s, &d.range_m}) {
    v->resize(n);
    v->shrink_to_fit();
  }
  d.index.resize(n);
  d.index.shrink_to_fit();
  SetPoints(&d, points);
  Recolor(chunk, &d);
  RefilterVerts(*chunk, &d);
}

void CloudView::FitMotion() {
  if (!motion_sample_.Fit()) return;
  for (auto& c : chunks_) {
    if (c->sealed()) FilterMotion(c.get());
  }
}

void CloudView::RebuildMotion() {
  // A larger budget: cells cannot split without the points they were not
  // given, so every chunk offers its candidates again, in order. The rest
  // levels were built around the old representatives: planned again.
  motion_sample_.Clear();
  motion_sample_.SetBudget(lod_budget_);
  for (auto& c : chunks_) {
    if (!c->sealed()) continue;
    c->rest_target = 0;
    c->rest = Drawn();
    BuildMotion(c.get());
    FitMotion();
  }
  DrawnChanged();
  if (!lod_active_) SetLodActive(false);
  ShowLevels();
}

void CloudView::ApplyLodBudget() {
  if (lod_budget_ > motion_sample_.budget()) {
    RebuildMotion();
  } else {
    motion_sample_.SetBudget(lod_budget_);  // Merges at once.
    for (auto& c : chunks_) {
      if (c->sealed()) FilterMotion(c.get());
    }
    ShowLevels();
  }
}

void CloudView::Recolor(Chunk* chunk, Drawn* d) {
  DrawnChanged();
  if (!d->scalar) return;
  const int m = static_cast<int>(color_mode_);
  const size_t n = d->size();
  float* s = d->scalar->GetPointer(0);
  const float* xyz = static_cast<const float*>(d->points->GetVoidPointer(0));
  if (d == &chunk->motion) {
    for (size_t k = 0; k < n; ++k) {
      s[k] = m == 0 ? xyz[3 * k + 2] : m == 1 ? d->time_s[k] : m == 2 ? d->range_m[k]
                                                             : ValueOf(*chunk, m, d->At(k));
    }
  } else if (!chunk->sealed()) {
    chunk->growing.ForEach([&](size_t k, const CloudPoint& p) {
      if (k >= n) return;
      s[k] = m == 0 ? p.z
             : m == 1 ? static_cast<float>((p.time_ns - time_origin_ns_) * 1e-9)
             : m == 2 ? p.range_m
                      : ValueOf(*chunk, m, k);
    });
  } else if (m == 0) {
    for (size_t k = 0; k < n; ++k) s[k] = xyz[3 * k + 2];
  } else if (m >= 3) {
    for (size_t k = 0; k < n; ++k) s[k] = ValueOf(*chunk, m, d->At(k));
  } else {
    BuildDrawn(chunk, d->stride, d, nullptr, d->shifts);  // Time and range: read the chunk again.
    return;
  }
  d->scalar->Modified();
}

void CloudView::RefilterVerts(const Chunk& chunk, Drawn* d) {
  DrawnChanged();
  const size_t n = d->size();
  auto verts = vtkSmartPointer<vtkCellArray>::New();
  verts->Use32BitStorage();  // 8 bytes a point instead of 16.
  verts->AllocateEstimate(static_cast<vtkIdType>(n), 1);
  for (size_t k = 0; k < n; ++k) {
    if (!Passes(chunk, d->At(k))) continue;
    const vtkIdType id = static_cast<vtkIdType>(k);
    verts->InsertNextCell(1, &id);
  }
  d->verts = verts;
  d->poly->SetVerts(verts);
  d->poly->Modified();
}

void CloudView::ShowLevels() {
  // Sealed chunks show through their batches (the growing chunk's own actor
  // is always shown, in full): the motion level while active, else the
  // rest level (each chunk's where it has one, cloud_view_batches.cc).
  for (const auto& b : motion_batches_) b->drawn.actor->SetVisibility(lod_active_);
  for (const auto& b : rest_batches_) b->drawn.actor->SetVisibility(!lod_active_);
  // A project's layers: their motion mapper in place of their own (both
  // keep their buffers, so a switch uploads nothing).
  for (const Layer& l : layers_) {
    if (l.motion) l.actor->SetMapper(lod_active_ ? l.motion.Get() : l.rest.Get());
  }
}

namespace {

// Where an axis-aligned box (x min, x max, y min, y max, z min, z max) lies
// against the view frustum's six inward planes and the clip height.
template <typename T>
InView BoxInView(const T* b, const double planes[24], double clip_height) {
  if (!std::isnan(clip_height) && b[4] > clip_height) return InView::kOut;
  const InView frustum = BoxAgainstPlanes(b, planes, 6);
  if (frustum == InView::kWhole && !std::isnan(clip_height) && b[5] > clip_height)
    return InView::kPartly;
  return frustum;
}

int Log2(int stride) {
  int shift = 0;
  while ((1 << shift) < stride) ++shift;
  return shift;
}

// Whether a rest level built with strides `built` (as Drawn::shifts; empty:
// `built_stride` throughout) may stay for the strides the plan wants: every
// cube it wants is in it, at most one halving coarser (none where every
// point is wanted), and it holds at most twice the points wanted (*excess:
// those beyond, summed by the caller against the budget). The strides are
// powers of two with distance from the camera squared in them, so a small
// move of the camera tips cubes all over the room across a power of two:
// without the halving's margin every chunk (each spans the room) would be
// read again after an orbit back to the same camera (0.95 s at 99.5 M
// points, against 0.2 s).
bool StillFits(const PackedChunk& chunk, const std::vector<uint8_t>& built, int built_stride,
               const std::vector<uint8_t>& want, int want_stride, double* excess) {
  const std::vector<uint32_t>& counts = chunk.cell_counts();
  const int b0 = Log2(built_stride), w0 = Log2(want_stride);
  double have = 0.0, need = 0.0;
  for (size_t k = 0; k < counts.size(); ++k) {
    const int b = built.empty() ? b0 : built[k];
    const int w = want.empty() ? w0 : want[k];
    if (w != kNoCube) {
      if (b == kNoCube || b > w + (w > 0 ? 1 : 0)) return false;
      need += std::ldexp(counts[k], -w);
    }
    if (b != kNoCube) have += std::ldexp(counts[k], -b);
  }
  *excess = have - need;
  return have <= 2.0 * need;
}

}  // namespace

void CloudView::MergeCensus() {
  for (auto& c : chunks_) {
    if (!c->sealed() || c->merged) continue;
    const std::vector<uint64_t>& keys = c->packed->cell_keys();
    const std::vector<uint32_t>& counts = c->packed->cell_counts();
    c->cubes.resize(keys.size());
    for (size_t k = 0; k < keys.size(); ++k) {
      const auto [it, fresh] =
          cube_index_.try_emplace(keys[k], static_cast<uint32_t>(cube_keys_.size()));
      if (fresh) {
        cube_keys_.push_back(keys[k]);
        cube_counts_.push_back(0);
      }
      cube_counts_[it->second] += counts[k];
      c->cubes[k] = it->second;
    }
    c->merged = true;
  }
}

void CloudView::PlanRest() {
  // The cloud's census cubes in the view frustum (and under the clip
  // height) get strides that spend the rest budget evenly on screen, nearer
  // cubes finer (core/cloud/cube_budget.h: Potree spends its point budget on
  // the nodes nearest and largest on screen); each chunk draws its share of
  // each cube. A chunk is 13 s of sweeps across the room, so a cube's points
  // lie in many chunks, and from inside the room nearly every chunk meets
  // the view; each is read again only when the plan wants a cube finer than
  // it holds, or less than half of what it holds.
  refine_queue_.clear();
  planned_camera_ = CurrentCameraKey();
  MergeCensus();
  vtkCamera* camera = renderer_->GetActiveCamera();
  double planes[24];
  camera->GetFrustumPlanes(renderer_->GetTiledAspectRatio(), planes);
  double eye[3];
  camera->GetPosition(eye);
  std::vector<CubeDemand> demand;
  std::vector<uint32_t> demanded;
  for (size_t w = 0; w < cube_keys_.size(); ++w) {
    const std::array<float, 6> box = PackedChunk::CellBox(cube_keys_[w]);
    if (BoxInView(box.data(), planes, clip_height_) == InView::kOut) continue;
    demand.push_back({SquaredDistanceToBox(eye, box.data()), cube_counts_[w]});
    demanded.push_back(static_cast<uint32_t>(w));
  }
  // Unless every point in view fits, an eighth of the budget is kept for
  // the levels that stay a little finer than planned (StillFits).
  size_t in_view = 0;
  for (const CubeDemand& q : demand) in_view += q.count;
  const double slack = in_view <= rest_budget_ ? 0.0 : static_cast<double>(rest_budget_) / 8.0;
  const std::vector<uint8_t> shifts = CubeShifts(demand, rest_budget_ - static_cast<size_t>(slack));
  std::vector<uint8_t> cube_shift(cube_keys_.size(), kNoCube);
  std::vector<float> cube_distance2(cube_keys_.size(), 0.0f);
  for (size_t j = 0; j < demanded.size(); ++j) {
    cube_shift[demanded[j]] = shifts[j];
    cube_distance2[demanded[j]] = static_cast<float>(demand[j].distance2);
  }
  std::vector<std::pair<float, Chunk*>> queue;
  double excess = 0.0;
  for (auto& c : chunks_) {
    if (!c->sealed()) continue;
    std::vector<uint8_t> want(c->cubes.size(), kNoCube);
    int finest = kNoCube, coarsest = 0;
    bool whole = true;
    float d2 = std::numeric_limits<float>::infinity();
    if (BoxInView(c->bounds.data(), planes, clip_height_) != InView::kOut) {
      for (size_t k = 0; k < want.size(); ++k) {
        want[k] = cube_shift[c->cubes[k]];
        whole = whole && want[k] != kNoCube;
        if (want[k] == kNoCube) continue;
        finest = std::min<int>(finest, want[k]);
        coarsest = std::max<int>(coarsest, want[k]);
        d2 = std::min(d2, cube_distance2[c->cubes[k]]);
      }
    }
    if (finest == kNoCube) {
      c->rest_target = 0;
      c->rest_shifts.clear();
      if (c->rest.actor) renderer_->RemoveActor(c->rest.actor);
      c->rest = Drawn();  // Out of view: its memory back.
      DrawnChanged();
      continue;
    }
    c->rest_target = 1 << finest;
    if (whole && finest == coarsest) want.clear();  // One stride throughout.
    c->rest_shifts = std::move(want);
    double more = 0.0;
    if (c->rest.stride == 0 ||
        !StillFits(*c->packed, c->rest.shifts, c->rest.stride, c->rest_shifts, c->rest_target,
                   &more) ||
        excess + more > slack) {
      queue.emplace_back(d2, c.get());
    } else {
      excess += more;
    }
  }
  std::stable_sort(queue.begin(), queue.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& q : queue) refine_queue_.push_back(q.second);
  emit restPlanned();
}

bool CloudView::RefineSlice(int max_ms) {
  QElapsedTimer clock;
  clock.start();
  size_t done = 0;
  while (done < refine_queue_.size() && clock.elapsed() < max_ms) {
    Chunk* c = refine_queue_[done++];
    BuildDrawn(c, c->rest_target, &c->rest, nullptr, c->rest_shifts);
  }
  refine_queue_.erase(refine_queue_.begin(), refine_queue_.begin() + done);
  return refine_queue_.empty();
}

void CloudView::SetLodActive(bool active) {
  progress_.active = false;  // Whatever is drawn next is drawn whole.
  if (active) {
    refine_queue_.clear();
    refine_timer_->stop();
    if (lod_active_) return;
    lod_active_ = true;
  } else {
    refine_timer_->stop();
    PlanRest();
    while (!RefineSlice(1 << 30)) {
    }
    lod_active_ = false;
  }
  ShowLevels();
  RequestRender();
}

void CloudView::SetLodBudget(size_t points) {
  lod_budget_ = std::max<size_t>(points, 1000);
  lod_budget_set_ = true;
  ApplyLodBudget();
  RequestRender();
}

void CloudView::SetRestBudget(size_t points) {
  rest_budget_ = std::max<size_t>(points, 1000);
  rest_budget_set_ = true;
  if (!lod_active_) SetLodActive(false);  // Re-planned at once.
}

size_t CloudView::vtk_point_count() const {
  size_t n = 0;
  for (const auto& c : chunks_) n += c->motion.size() + c->rest.size();
  for (const auto* level : {&motion_batches_, &rest_batches_}) {
    for (const auto& b : *level) n += b->points();
  }
  return n;
}

std::vector<Eigen::Vector3f> CloudView::MotionPoints() const {
  std::vector<Eigen::Vector3f> out;
  for (const auto& c : chunks_) {
    const Drawn& d = c->motion;
    if (!c->sealed() || !d.points) continue;
    const float* p = static_cast<const float*>(d.points->GetVoidPointer(0));
    for (size_t k = 0; k < d.size(); ++k) out.emplace_back(p[3 * k], p[3 * k + 1], p[3 * k + 2]);
  }
  return out;
}

std::vector<Eigen::Vector3f> CloudView::DrawnPoints(std::vector<float>* scalars) const {
  std::vector<Eigen::Vector3f> out;
  if (scalars != nullptr) scalars->clear();
  for (const auto& c : chunks_) {
    // The level drawn now (ShowLevels(), the batches).
    const bool rest = !c->sealed() || (!lod_active_ && c->rest.stride > 0);
    const Drawn& d = rest ? c->rest : c->motion;
    if (!d.points) continue;
    const float* p = static_cast<const float*>(d.points->GetVoidPointer(0));
    for (size_t k = 0; k < d.size(); ++k) out.emplace_back(p[3 * k], p[3 * k + 1], p[3 * k + 2]);
    if (scalars != nullptr && d.scalar) {
      scalars->insert(scalars->end(), d.scalar->GetPointer(0), d.scalar->GetPointer(0) + d.size());
    }
  }
  return out;
}

std::vector<Eigen::Vector3f> CloudView::BatchedPoints() const {
  std::vector<Eigen::Vector3f> out;
  const auto add = [&](vtkPolyData* poly) {
    if (poly == nullptr || poly->GetPoints() == nullptr) return;
    vtkCellArray* verts = poly->GetVerts();
    auto cell = vtkSmartPointer<vtkIdList>::New();
    for (vtkIdType c = 0; c < verts->GetNumberOfCells(); ++c) {
      verts->GetCellAtId(c, cell);
      for (vtkIdType k = 0; k < cell->GetNumberOfIds(); ++k) {
        double p[3];
        poly->GetPoint(cell->GetId(k), p);
        out.emplace_back(static_cast<float>(p[0]), static_cast<float>(p[1]),
                         static_cast<float>(p[2]));
      }
    }
  };
  for (const auto& b : lod_active_ ? motion_batches_ : rest_batches_) add(b->drawn.poly);
  for (const auto& c : chunks_) {
    if (!c->sealed()) add(c->rest.poly);
  }
  return out;
}

}  // namespace sweepscan::ui
