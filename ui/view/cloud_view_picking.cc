// CloudView's picking layer: Shift + click finds the point under the
// cursor among the view's own chunks and the layers' points (a project's
// sessions, through the layer owner's picker), on the view's pick thread
// (the search: cloud_pick.h), and the markers that show picked points,
// numbered when they carry a label.
#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkUnsignedCharArray.h>

#include <QMouseEvent>
#include <QRunnable>
#include <QThreadPool>
#include <QTimer>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

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
    StartPick(event->pos());
    event->accept();
    return;
  }
  QVTKOpenGLNativeWidget::mousePressEvent(event);
}

void CloudView::SetLayerPicker(LayerPicker picker) {
  layer_picker_ = std::move(picker);
  InvalidatePicks();  // A pick of the layers that were is not theirs to report.
}

bool CloudView::PickPoint(const QPoint& pos, Eigen::Vector3d* world, double tolerance_px) {
  PickHit hit;
  if (!PickPoint(pos, &hit, tolerance_px)) return false;
  *world = hit.world;
  return true;
}

bool CloudView::PickPoint(const QPoint& pos, PickHit* hit, double tolerance_px) {
  if (point_count_ == 0 && layers_.empty()) return false;
  const PickResult result = PreparePick(pos, tolerance_px).Run();
  last_pick_counts_ = result.counts;
  if (result.found) *hit = result.hit;
  return result.found;
}

void CloudView::StartPick(const QPoint& pos) {
  if (point_count_ == 0 && layers_.empty()) return;
  if (!pick_pool_) {
    // One thread: clicks are answered in the order they were made (a pair
    // is two clicks in a row).
    pick_pool_ = std::make_unique<QThreadPool>();
    pick_pool_->setMaxThreadCount(1);
  }
  auto search = std::make_shared<const PickSearch>(PreparePick(pos, kPickTolerancePx));
  const uint64_t generation = pick_generation_;
  const int context = pick_context_ ? pick_context_() : 0;
  ++picks_in_flight_;
  // The view waits for this thread before it goes (~CloudView), so the
  // result is posted to a live object, and dropped with it if it goes first.
  pick_pool_->start(QRunnable::create([this, search, generation, context] {
    PickResult result = search->Run();
    QMetaObject::invokeMethod(
        this, [this, generation, context, result] { FinishPick(generation, context, result); },
        Qt::QueuedConnection);
  }));
}

void CloudView::FinishPick(uint64_t generation, int context, const PickResult& result) {
  --picks_in_flight_;
  // A pick of a cloud since cleared, or of a layer since removed, hidden or
  // moved, is stale (InvalidatePicks).
  if (generation != pick_generation_) return;
  last_pick_counts_ = result.counts;
  if (result.found) emit pointPicked(result.hit, context);
}

void CloudView::WaitForPicks() {
  if (pick_pool_) pick_pool_->waitForDone();
}

PickSearch CloudView::PreparePick(const QPoint& pos, double tolerance_px) {
  PickSearch search;
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
  PickRay& ray = search.ray;
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
  search.filter.pass = pass_filter_;
  search.filter.lo = value_lo_[0];
  search.filter.step = value_step_[0];
  search.blocks_in_order = pick_blocks_in_order_;
  const Eigen::Vector3d& o = ray.origin;
  const float clip_z = static_cast<float>(ray.clip_z);
  const RaySlabs slabs(o, ray.direction);
  // The growing chunk (at most 65 536 points, in the batches' vectors that
  // the GUI thread appends to): every point, here. The sealed chunks are
  // shared and never change: the search takes them as they are now.
  for (const auto& c : chunks_) {
    double enter = 0.0;
    if (c->size == 0 || !slabs.Hits(c->bounds.data(), PickMargin(ray, c->bounds.data()),
                                    std::numeric_limits<double>::infinity(), &enter)) {
      continue;
    }
    if (c->sealed()) {
      PickSearch::Sealed s;
      s.packed = c->packed;
      s.bounds = c->bounds;
      s.size = c->size;
      if (pass_filter_ >= 0) s.pass = c->values[0];  // Shared: replaced, never changed.
      search.sealed.push_back(std::move(s));
      continue;
    }
    const CloudPoint* best = nullptr;
    c->growing.ForEach([&](size_t i, const CloudPoint& p) {
      if (p.z > clip_z || !Passes(*c, i)) return;  // Clipped or not drawn: not pickable.
      if (NearerOnRay(ray, p.x - o.x(), p.y - o.y(), p.z - o.z(), &search.best_t)) best = &p;
    });
    if (best != nullptr) {
      search.hit.world = search.hit.local = Eigen::Vector3d(best->x, best->y, best->z);
      search.found = true;
    }
  }
  // The layers as they are now (their owner's snapshot).
  if (layer_picker_ && !layers_.empty()) search.layers = layer_picker_();
  return search;
}

QPointF CloudView::WorldToWidget(const Eigen::Vector3d& w) {
  double d[3];
  ToDisplay(w, d);  // behind the eye too, as VTK projects it
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
  // Labels (a pair's number) beside their markers, over the view; placed
  // before each frame with the planes' names (LayoutOverlayLabels).
  for (auto& label : marker_labels_) renderer_->RemoveActor2D(label.actor);
  marker_labels_.clear();
  for (const Marker& m : markers) {
    if (m.label.isEmpty()) continue;
    vtkSmartPointer<vtkTextActor> label = NewOverlayLabel();
    label->SetInput(m.label.toUtf8().constData());
    vtkTextProperty* text = label->GetTextProperty();
    text->SetJustificationToLeft();
    text->SetVerticalJustificationToBottom();
    text->SetColor(m.color.redF(), m.color.greenF(), m.color.blueF());
    label->VisibilityOff();
    renderer_->AddActor2D(label);
    marker_labels_.push_back({label, m.position});
  }
  RequestRender();
}

}  // namespace sweepscan::ui
