// CloudView's picking layer: Shift + click finds the point under the
// cursor among the view's own chunks and the layers' points (a project's
// sessions, through the layer owner's picker), and the markers that show
// picked points, numbered when they carry a label.
//
// A pick tests every point, not only those drawn at the current level of
// detail: the operator clicks what is on screen and gets the true sample
// under the cursor, whatever the budget thinned. Points the clip hides (the
// ceiling) or the pass filter leaves out are not pickable.
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <vtkActor.h>
#include <vtkBillboardTextActor3D.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>
#include <vtkTextProperty.h>
#include <vtkUnsignedCharArray.h>

#include <QMouseEvent>
#include <QTimer>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <utility>
#include <vector>

#include "core/cloud/payload_codec.h"
#include "core/geometry/ray_box.h"
#include "ui/view/cloud_view.h"
#include "ui/view/cloud_view_chunk.h"

namespace sweepscan::ui {

void CloudView::BuildMarkers() {
  // Marker overlay: picked points as large dots drawn over the cloud.
  for (int k = 0; k < 2; ++k) {
    auto poly = vtkSmartPointer<vtkPolyData>::New();
    auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
    mapper->SetInputData(poly);
    mapper->SetScalarModeToUsePointData();
    // Drawn after the cloud and in front of it: markers stay visible.
    mapper->SetResolveCoincidentTopologyToPolygonOffset();
    markers_[k] = vtkSmartPointer<vtkActor>::New();
    markers_[k]->SetMapper(mapper);
    markers_[k]->GetProperty()->SetPointSize(k == 0 ? 11.0 : 17.0);
    markers_[k]->GetProperty()->SetRenderPointsAsSpheres(true);
    markers_[k]->PickableOff();
    renderer_->AddActor(markers_[k]);
  }
}

void CloudView::mousePressEvent(QMouseEvent* event) {
  if (event->button() == Qt::LeftButton && (event->modifiers() & Qt::ShiftModifier)) {
    PickHit hit;
    if (PickPoint(event->pos(), &hit)) emit pointPicked(hit);
    event->accept();
    return;
  }
  QVTKOpenGLNativeWidget::mousePressEvent(event);
}

void CloudView::SetLayerPicker(LayerPicker picker) { layer_picker_ = std::move(picker); }

bool CloudView::PickPoint(const QPoint& pos, Eigen::Vector3d* world, double tolerance_px) {
  PickHit hit;
  if (!PickPoint(pos, &hit, tolerance_px)) return false;
  *world = hit.world;
  return true;
}

bool CloudView::PickPoint(const QPoint& pos, PickHit* hit, double tolerance_px) {
  if (point_count_ == 0 && layers_.empty()) return false;
  // Display coordinates: device pixels, origin bottom left.
  const double ratio = devicePixelRatioF();
  const double x = pos.x() * ratio;
  const double y = (height() - pos.y()) * ratio;
  double near_w[4], far_w[4];
  renderer_->SetDisplayPoint(x, y, 0.0);
  renderer_->DisplayToWorld();
  renderer_->GetWorldPoint(near_w);
  renderer_->SetDisplayPoint(x, y, 1.0);
  renderer_->DisplayToWorld();
  renderer_->GetWorldPoint(far_w);
  PickRay ray;
  const Eigen::Vector3d n(near_w[0] / near_w[3], near_w[1] / near_w[3], near_w[2] / near_w[3]);
  const Eigen::Vector3d f(far_w[0] / far_w[3], far_w[1] / far_w[3], far_w[2] / far_w[3]);
  ray.direction = (f - n).normalized();
  // The ray starts at the eye, not at the near plane: a pixel's world size
  // grows with the distance from the eye, and the near plane (fitted to the
  // props in view) may lie tens of metres from it, where a tolerance taken
  // from the near plane was a fraction of a pixel. Nothing drawn lies
  // between the eye and the near plane.
  vtkCamera* camera = renderer_->GetActiveCamera();
  double eye[3];
  camera->GetPosition(eye);
  ray.origin = Eigen::Vector3d(eye[0], eye[1], eye[2]);
  // World size of one pixel at distance t along the ray (perspective).
  const double pixel_per_t =
      2.0 * std::tan(0.5 * camera->GetViewAngle() * M_PI / 180.0) / std::max(1.0, height() * ratio);
  ray.tolerance_per_t = tolerance_px * pixel_per_t;
  ray.clip_z = std::isnan(clip_height_) ? std::numeric_limits<double>::infinity() : clip_height_;
  const Eigen::Vector3d& o = ray.origin;
  const Eigen::Vector3d& d = ray.direction;
  // A box is met if the ray comes within the tolerance at the box's far
  // side: every point p of the box has t <= |p - o| <= |centre - o| + half
  // its diagonal, so tol(t) is at most that times tolerance_per_t.
  auto margin = [&](const double b[6]) {
    const Eigen::Vector3d lo(b[0], b[2], b[4]), hi(b[1], b[3], b[5]);
    return ray.tolerance_per_t * ((0.5 * (lo + hi) - o).norm() + 0.5 * (hi - lo).norm());
  };
  double best_t = std::numeric_limits<double>::infinity();
  bool found = false;
  const float clip_z = static_cast<float>(ray.clip_z);
  // A point v (relative to the ray's origin) under the cursor and nearer
  // than `*best` becomes the best: its distance along the ray in *best.
  // Written so that NaN fails every test: a point with a NaN coordinate
  // (a chunk may hold one) is never under the cursor.
  auto nearer = [&](double vx, double vy, double vz, double* best) {
    const double t = vx * d.x() + vy * d.y() + vz * d.z();
    if (!(t > 0 && t < *best)) return false;
    const double tol = ray.tolerance_per_t * t;
    if (!(vx * vx + vy * vy + vz * vz - t * t <= tol * tol)) return false;
    *best = t;
    return true;
  };
  // The clip as a whole grid step: the highest k whose float is at or below it.
  int64_t clip_k = std::numeric_limits<int64_t>::max();
  if (std::isfinite(clip_z)) {
    clip_k = GridIndex(clip_z);
    while (GridPosition(clip_k) > clip_z) --clip_k;
    while (GridPosition(clip_k + 1) <= clip_z) ++clip_k;
  }
  auto take = [&](const float xyz[3]) {
    hit->world = Eigen::Vector3d(xyz[0], xyz[1], xyz[2]);
    hit->local = hit->world;
    hit->layer.clear();
    found = true;
  };
  // Every point of the cloud, not only those drawn: the pick is the true
  // point under the cursor, whatever the level of detail.
  //
  // The growing chunk (at most 65 536 points): every point.
  const RaySlabs slabs(o, d);
  for (const auto& c : chunks_) {
    double enter = 0.0;
    if (c->sealed() || c->size == 0 ||
        !slabs.Hits(c->bounds.data(), margin(c->bounds.data()),
                    std::numeric_limits<double>::infinity(), &enter)) {
      continue;
    }
    const CloudPoint* best = nullptr;
    c->growing.ForEach([&](size_t i, const CloudPoint& p) {
      if (p.z > clip_z || !Passes(*c, i)) return;  // Clipped or not drawn: not pickable.
      if (nearer(p.x - o.x(), p.y - o.y(), p.z - o.z(), &best_t)) best = &p;
    });
    if (best != nullptr) take(&best->x);
  }
  // Sealed chunks: only the blocks the ray passes near
  // (PackedChunk::block_bounds(); a ray through a room revisited for hours
  // meets nearly every chunk's box, and a block, a third of a scan line, is
  // a tall slab that many rays cross), nearest entry first, until a block's
  // entry lies beyond the best point so far. A point within the tolerance
  // of the ray at t lies within margin(box) of the ray's point at t, so the ray
  // is inside the grown box there: no point of a block entered beyond the
  // best can be nearer. A compressed chunk has only the blocks it tests
  // decoded (PackedChunk::PinBlockPositions).
  //
  // Within a block met, only its pieces the ray passes near
  // (PackedChunk::PieceBox: a block is a slab across the room, a piece a
  // few decimetres of a scan line): the block's entry is its nearest met
  // piece's, and only those pieces' points are tested.
  struct Candidate {
    double enter;
    const Chunk* chunk;
    uint32_t block;
    uint32_t pieces;  // Bit p: the block's piece p is met.
  };
  // The chunk's margin serves its blocks and pieces: they lie inside its
  // box, so no point of theirs is farther from the eye than its far side.
  // Chunks are gathered on every core, their candidates joined in the
  // chunks' order (the sort's ties then fall as on one thread).
  static_assert(PackedChunk::kPiecesPerBlock <= 32, "a piece a bit");
  const double bound = best_t;  // The growing chunk's point, if it has one.
  std::vector<std::vector<Candidate>> met(chunks_.size());
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, chunks_.size(), 16), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t ci = r.begin(); ci != r.end(); ++ci) {
          const Chunk& c = *chunks_[ci];
          double enter = 0.0;
          const double chunk_margin = margin(c.bounds.data());
          if (!c.sealed() || c.size == 0 ||
              !slabs.Hits(c.bounds.data(), chunk_margin, bound, &enter) || enter >= bound) {
            continue;
          }
          const PackedChunk& packed = *c.packed;
          const auto& blocks = packed.block_bounds();
          for (size_t k = 0; k < blocks.size(); ++k) {
            const double box[6] = {blocks[k][0], blocks[k][1], blocks[k][2],
                                   blocks[k][3], blocks[k][4], blocks[k][5]};
            if (box[4] > clip_z || !slabs.Hits(box, chunk_margin, bound, &enter) || enter >= bound)
              continue;
            Candidate candidate{std::numeric_limits<double>::infinity(), &c,
                                static_cast<uint32_t>(k), 0};
            const size_t first_piece = k * PackedChunk::kPiecesPerBlock;
            const size_t end_piece =
                std::min(packed.piece_count(), first_piece + PackedChunk::kPiecesPerBlock);
            for (size_t p = first_piece; p < end_piece; ++p) {
              double piece[6];
              if (!packed.PieceBox(p, piece) || piece[4] > clip_z ||
                  !slabs.Hits(piece, chunk_margin, bound, &enter) || enter >= bound) {
                continue;
              }
              candidate.pieces |= uint32_t{1} << (p - first_piece);
              candidate.enter = std::min(candidate.enter, enter);
            }
            if (candidate.pieces != 0) met[ci].push_back(candidate);
          }
        }
      });
  std::vector<Candidate> candidates;
  size_t count = 0;
  for (const std::vector<Candidate>& m : met) count += m.size();
  candidates.reserve(count);
  for (const std::vector<Candidate>& m : met)
    candidates.insert(candidates.end(), m.begin(), m.end());
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.enter < b.enter; });
  // A block's point nearest the camera under the cursor and before
  // `bound`, the first such in the block's order; t infinite if none.
  struct BlockHit {
    double t = std::numeric_limits<double>::infinity();
    size_t candidate = 0;  // Ties between blocks go to the earlier entry.
    float xyz[3] = {};
  };
  auto test_block = [&](const Candidate& candidate, const PackedChunk::PositionsPin& pin,
                        double bound, BlockHit* out) {
    const Chunk& c = *candidate.chunk;
    const PackedChunk& packed = *c.packed;
    const size_t begin = candidate.block * PackedChunk::kBlockPoints;
    const size_t end = std::min(c.size, begin + PackedChunk::kBlockPoints);
    size_t first = 0;  // The chunk's point i is the payload's i - first.
    // Compressed, the block is decoded up to its last met piece only.
    const std::shared_ptr<const ChunkPayload> payload =
        packed.BlockPositions(pin, candidate.block, &first,
                              (32 - __builtin_clz(candidate.pieces)) * PackedChunk::kPiecePoints);
    double best = bound;
    size_t best_i = c.size;
    // The met pieces' points, in the block's order (a tie goes to the first).
    auto for_pieces = [&](auto&& test) {
      for (uint32_t m = candidate.pieces; m != 0; m &= m - 1) {
        const size_t from =
            begin + static_cast<size_t>(__builtin_ctz(m)) * PackedChunk::kPiecePoints;
        test(from, std::min(end, from + PackedChunk::kPiecePoints));
      }
    };
    if (packed.positions_on_grid()) {
      // Whole millimetres after the chunk's origin (docs/cloud-store.md):
      // the ray's origin and the clip moved there, the points are not decoded.
      const std::array<int64_t, 3>& origin = packed.origin_mm();
      const double ox = o.x() - origin[0] * kGridStepM, oy = o.y() - origin[1] * kGridStepM,
                   oz = o.z() - origin[2] * kGridStepM;
      const int64_t top = std::isfinite(clip_z) ? clip_k - origin[2] : clip_k;
      for_pieces([&](size_t from, size_t to) {
        const int16_t* q = payload->xyz_mm.data() + 3 * (from - first);
        for (size_t i = from; i < to; ++i, q += 3) {
          if (q[2] > top || !Passes(c, i)) continue;  // Clipped or not drawn: not pickable.
          if (nearer(q[0] * kGridStepM - ox, q[1] * kGridStepM - oy, q[2] * kGridStepM - oz, &best))
            best_i = i;
        }
      });
    } else {
      for_pieces([&](size_t from, size_t to) {
        const float* p = payload->xyz.data() + 3 * (from - first);
        for (size_t i = from; i < to; ++i, p += 3) {
          if (p[2] > clip_z || !Passes(c, i)) continue;
          if (nearer(p[0] - o.x(), p[1] - o.y(), p[2] - o.z(), &best)) best_i = i;
        }
      });
    }
    if (best_i == c.size) return;
    out->t = best;
    out->candidate = static_cast<size_t>(&candidate - candidates.data());
    packed.PositionOf(*payload, best_i - first, out->xyz);
  };
  // The pick is the one a single thread finds testing the blocks in entry
  // order and taking a point only if strictly nearer: the least (t, the
  // block's place in that order), whatever the threads.
  auto before = [](const BlockHit& a, const BlockHit& b) {
    return a.t < b.t || (a.t == b.t && a.candidate < b.candidate);
  };
  auto take_hit = [&](const BlockHit& h) {
    best_t = h.t;
    take(h.xyz);
  };
  // First the nearest blocks, in entry order, in waves (32, 64 then 128
  // blocks, each tested on every core, then taken in order): the best is
  // usually found there, and the next wave starts only if its first block's
  // entry lies before it.
  last_pick_counts_ = PickCounts();
  std::vector<BlockHit> hits;
  size_t w1 = 0;
  const size_t in_order = std::min(candidates.size(), pick_blocks_in_order_);
  for (size_t w0 = 0, wave = 32; wave <= 128 && w0 < in_order && candidates[w0].enter < best_t;
       w0 = w1, wave *= 2) {
    w1 = std::min(in_order, w0 + wave);
    hits.assign(w1 - w0, BlockHit());
    const double bound = best_t;
    tbb::parallel_for(tbb::blocked_range<size_t>(w0, w1, 8), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t k = r.begin(); k != r.end(); ++k) {
        if (candidates[k].enter < bound) {
          test_block(candidates[k], candidates[k].chunk->packed->PinPositions(), bound,
                     &hits[k - w0]);
        }
      }
    });
    for (const BlockHit& h : hits) {
      if (h.t < best_t) take_hit(h);  // a block without a hit keeps t = inf
    }
    last_pick_counts_.blocks_in_order += w1 - w0;
  }
  // Then the rest that enter before the best, a chunk at a time (a ray
  // along a floor driven a hundred times meets tens of thousands of blocks
  // in a thousand chunks): each chunk's positions pinned once, not once a
  // block (under a small memory budget the chunks' compressed bytes were
  // read back from the cache file thousands of times a pick, 0.3-1.2 s on
  // 100 M points under --memory-budget 64). Blocks entered beyond the best
  // any thread has found so far are skipped; each chunk's tasks keep the
  // least (t, place) of their own, and the least of those is the pick.
  std::vector<uint32_t> rest;
  for (size_t k = w1; k < candidates.size(); ++k) {
    if (candidates[k].enter < best_t) rest.push_back(static_cast<uint32_t>(k));
  }
  if (!rest.empty()) {
    std::stable_sort(rest.begin(), rest.end(), [&](uint32_t a, uint32_t b) {
      return std::less<const Chunk*>()(candidates[a].chunk, candidates[b].chunk);
    });
    std::vector<size_t> groups;  // Where each chunk's run of `rest` starts.
    for (size_t i = 0; i < rest.size(); ++i) {
      if (i == 0 || candidates[rest[i]].chunk != candidates[rest[i - 1]].chunk) groups.push_back(i);
    }
    last_pick_counts_.blocks_by_chunk = rest.size();
    last_pick_counts_.chunks = groups.size();
    groups.push_back(rest.size());
    std::atomic<double> shared_best{best_t};
    tbb::enumerable_thread_specific<BlockHit> thread_best;
    tbb::parallel_for(size_t{0}, groups.size() - 1, [&](size_t g) {
      BlockHit& mine = thread_best.local();
      const PackedChunk::PositionsPin pin =
          candidates[rest[groups[g]]].chunk->packed->PinPositions();
      for (size_t i = groups[g]; i < groups[g + 1]; ++i) {
        const Candidate& candidate = candidates[rest[i]];
        const double shared = shared_best.load(std::memory_order_relaxed);
        if (candidate.enter > shared) continue;  // Its points all lie beyond the best found.
        // Points at the best found so far, this thread's or any's, are kept
        // too: `before` gives a tie to the earlier block, and this thread
        // meets the blocks in chunk order, not entry order.
        BlockHit h;
        test_block(candidate, pin, std::nextafter(std::min(mine.t, shared), HUGE_VAL), &h);
        if (!(h.t < std::numeric_limits<double>::infinity())) continue;
        if (before(h, mine)) mine = h;
        double seen = shared;
        while (h.t < seen &&
               !shared_best.compare_exchange_weak(seen, h.t, std::memory_order_relaxed)) {
        }
      }
    });
    BlockHit best_rest;
    for (const BlockHit& h : thread_best) {
      if (before(h, best_rest)) best_rest = h;
    }
    if (best_rest.t < best_t) take_hit(best_rest);
  }
  // The layers' points compete with the cloud's: the nearest to the camera wins.
  if (layer_picker_ && !layers_.empty() && layer_picker_(ray, &best_t, hit)) found = true;
  return found;
}

QPointF CloudView::WorldToWidget(const Eigen::Vector3d& w) {
  renderer_->SetWorldPoint(w.x(), w.y(), w.z(), 1.0);
  renderer_->WorldToDisplay();
  double d[3];
  renderer_->GetDisplayPoint(d);
  const double ratio = devicePixelRatioF();
  return QPointF(d[0] / ratio, height() - d[1] / ratio);
}

void CloudView::SetMarkers(const std::vector<Marker>& markers) {
  // Unchanged markers cost no render (a full-detail frame of millions of
  // points is long under a software renderer).
  const bool same = markers.size() == shown_markers_.size() &&
                    std::equal(markers.begin(), markers.end(), shown_markers_.begin(),
                               [](const Marker& a, const Marker& b) {
                                 return a.position == b.position && a.color == b.color &&
                                        a.highlighted == b.highlighted && a.label == b.label;
                               });
  if (same) return;
  shown_markers_ = markers;
  // The new marker is drawn over the thinned cloud at once (a full-detail
  // frame of 10 M points takes seconds in software); full detail follows
  // when the view has been still for kSettleMs, as after a camera move.
  if (point_count_ > lod_budget_) {
    SetLodActive(true);
    settle_->start();
  }
  for (int k = 0; k < 2; ++k) {
    auto points = vtkSmartPointer<vtkPoints>::New();
    auto verts = vtkSmartPointer<vtkCellArray>::New();
    auto colors = vtkSmartPointer<vtkUnsignedCharArray>::New();
    colors->SetNumberOfComponents(3);
    colors->SetName("colors");
    for (const Marker& m : markers) {
      if (m.highlighted != (k == 1)) continue;
      const vtkIdType id = points->InsertNextPoint(m.position.data());
      verts->InsertNextCell(1, &id);
      const unsigned char rgb[3] = {static_cast<unsigned char>(m.color.red()),
                                    static_cast<unsigned char>(m.color.green()),
                                    static_cast<unsigned char>(m.color.blue())};
      colors->InsertNextTypedTuple(rgb);
    }
    auto poly = vtkSmartPointer<vtkPolyData>::New();
    poly->SetPoints(points);
    poly->SetVerts(verts);
    poly->GetPointData()->SetScalars(colors);
    static_cast<vtkPolyDataMapper*>(markers_[k]->GetMapper())->SetInputData(poly);
    static_cast<vtkPolyDataMapper*>(markers_[k]->GetMapper())->SetColorModeToDirectScalars();
  }
  // Labels (a pair's number) beside their markers, facing the camera.
  for (auto& label : marker_labels_) renderer_->RemoveActor(label);
  marker_labels_.clear();
  for (const Marker& m : markers) {
    if (m.label.isEmpty()) continue;
    auto label = vtkSmartPointer<vtkBillboardTextActor3D>::New();
    label->SetInput(m.label.toUtf8().constData());
    double at[3] = {m.position.x(), m.position.y(), m.position.z()};
    label->SetPosition(at);
    label->SetDisplayOffset(10, 8);  // Beside the dot, not over it.
    vtkTextProperty* text = label->GetTextProperty();
    text->SetFontSize(16);
    text->SetBold(true);
    text->SetColor(m.color.redF(), m.color.greenF(), m.color.blueF());
    text->SetBackgroundColor(0.05, 0.05, 0.07);
    text->SetBackgroundOpacity(0.8);
    label->PickableOff();
    renderer_->AddActor(label);
    marker_labels_.push_back(label);
  }
  RequestRender();
}

}  // namespace sweepscan::ui
