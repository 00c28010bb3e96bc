// CloudView's level of detail: what VTK holds of each chunk (the motion and
// rest levels), the rest plan under the point budget, and its building in
// slices. See cloud_view.h for the scheme and docs/cloud-store.md for why.
#include <vtkCamera.h>
#include <vtkPointData.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>

#include <QElapsedTimer>
#include <QTimer>
#include <algorithm>
#include <cmath>

#include "ui/view/cloud_view.h"
#include "ui/view/cloud_view_chunk.h"

namespace sweepscan::ui {
using cloud_view_internal::kNaN;
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

}  // namespace

float CloudView::ValueOf(const Chunk& chunk, int mode, size_t i) const {
  const std::vector<uint16_t>& v = chunk.values[mode - 3];
  if (i >= v.size() || v[i] == kNoValue) return kNaN;
  return static_cast<float>(value_lo_[mode - 3] + v[i] * value_step_[mode - 3]);
}

bool CloudView::Passes(const Chunk& chunk, size_t i) const {
  if (pass_filter_ < 0) return true;
  const float pass = ValueOf(chunk, 3, i);
  return !std::isnan(pass) && std::abs(pass - pass_filter_) < 0.5f;
}

void CloudView::BuildDrawn(Chunk* chunk, int stride, Drawn* d,
                           std::shared_ptr<const ChunkPayload> payload) {
  // Every stride-th point: representative of the chunk, as a chunk's points
  // are consecutive samples along the scan lines (each line thinned evenly);
  // and the motion level's points, which the progressive passes' pass 0
  // drew, so that the finished image holds no point the rest level lacks.
  std::vector<uint32_t> index;
  index.reserve((chunk->size + stride - 1) / stride + chunk->motion.index.size());
  const std::vector<uint32_t>& motion = chunk->motion.index;
  size_t m = 0;
  for (size_t i = 0; i < chunk->size; i += stride) {
    for (; m < motion.size() && motion[m] < i; ++m) index.push_back(motion[m]);
    if (m < motion.size() && motion[m] == i) ++m;
    index.push_back(static_cast<uint32_t>(i));
  }
  index.insert(index.end(), motion.begin() + static_cast<std::ptrdiff_t>(m), motion.end());
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
    for (size_t k = 0; k < n; ++k) {
      const CloudPoint& p = chunk->growing[k];
      s[k] = m == 0 ? p.z
             : m == 1 ? static_cast<float>((p.time_ns - time_origin_ns_) * 1e-9)
             : m == 2 ? p.range_m
                      : ValueOf(*chunk, m, k);
    }
  } else if (m == 0) {
    for (size_t k = 0; k < n; ++k) s[k] = xyz[3 * k + 2];
  } else if (m >= 3) {
    for (size_t k = 0; k < n; ++k) s[k] = ValueOf(*chunk, m, d->At(k));
  } else {
    BuildDrawn(chunk, d->stride, d);  // Time and range: read the chunk again.
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
}

void CloudView::PlanRest() {
  // The chunks in the view frustum (and under the clip height), nearest
  // first: a uniform stride that fits them in the rest budget, then the
  // budget left over spent on the nearest (finer strides, down to every
  // point), as Potree spends its point budget on the nodes nearest and
  // largest on screen.
  refine_queue_.clear();
  vtkCamera* camera = renderer_->GetActiveCamera();
  double planes[24];
  camera->GetFrustumPlanes(renderer_->GetTiledAspectRatio(), planes);
  double eye[3];
  camera->GetPosition(eye);
  struct Candidate {
    Chunk* chunk;
    double distance;
  };
  std::vector<Candidate> visible;
  size_t total = 0;
  for (auto& c : chunks_) {
    if (!c->sealed()) continue;
    const auto& b = c->bounds;
    bool inside = std::isnan(clip_height_) || b[4] <= clip_height_;
    for (int p = 0; p < 6 && inside; ++p) {
      // The box corner farthest along the plane's inward normal.
      const double* n = planes + 4 * p;
      const double x = n[0] >= 0 ? b[1] : b[0], y = n[1] >= 0 ? b[3] : b[2],
                   z = n[2] >= 0 ? b[5] : b[4];
      if (n[0] * x + n[1] * y + n[2] * z + n[3] < 0) inside = false;
    }
    if (!inside) {
      c->rest_target = 0;
      if (c->rest.actor) renderer_->RemoveActor(c->rest.actor);
      c->rest = Drawn();  // Out of view: its memory back.
      DrawnChanged();
      continue;
    }
    double d2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double q = std::clamp(eye[k], b[2 * k], b[2 * k + 1]);
      d2 += (eye[k] - q) * (eye[k] - q);
    }
    visible.push_back({c.get(), d2});
    total += c->size;
  }
  std::stable_sort(visible.begin(), visible.end(),
                   [](const Candidate& a, const Candidate& b) { return a.distance < b.distance; });
  size_t stride = 1;
  while (total / stride > rest_budget_) stride *= 2;
  size_t used = 0;
  for (const Candidate& v : visible) {
    v.chunk->rest_target = static_cast<int>(stride);
    used += (v.chunk->size + stride - 1) / stride;
  }
  for (const Candidate& v : visible) {
    int& t = v.chunk->rest_target;
    while (t > 1) {
      const size_t now = (v.chunk->size + t - 1) / t, finer = (v.chunk->size + t / 2 - 1) / (t / 2);
      if (used + finer - now > rest_budget_) break;
      used += finer - now;
      t /= 2;
    }
  }
  for (const Candidate& v : visible) {
    if (v.chunk->rest.stride != v.chunk->rest_target) refine_queue_.push_back(v.chunk);
  }
}

bool CloudView::RefineSlice(int max_ms) {
  QElapsedTimer clock;
  clock.start();
  size_t done = 0;
  while (done < refine_queue_.size() && clock.elapsed() < max_ms) {
    Chunk* c = refine_queue_[done++];
    BuildDrawn(c, c->rest_target, &c->rest);
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

std::vector<Eigen::Vector3f> CloudView::DrawnPoints() const {
  std::vector<Eigen::Vector3f> out;
  for (const auto& c : chunks_) {
    // The level drawn now (ShowLevels(), the batches).
    const bool rest = !c->sealed() || (!lod_active_ && c->rest.stride > 0);
    const Drawn& d = rest ? c->rest : c->motion;
    if (!d.points) continue;
    const float* p = static_cast<const float*>(d.points->GetVoidPointer(0));
    for (size_t k = 0; k < d.size(); ++k) out.emplace_back(p[3 * k], p[3 * k + 1], p[3 * k + 2]);
  }
  return out;
}

}  // namespace sweepscan::ui
