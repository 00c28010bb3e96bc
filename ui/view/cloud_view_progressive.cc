// CloudView's progressive rest passes: a rest level larger than the LOD
// budget is drawn over several frames, so that no frame at rest holds the
// GUI thread much longer than a frame in motion does.
//
// Why: under Mesa llvmpipe the rest level's million points are a 0.35-0.46 s
// frame on this 2-core machine (the draw module's vertex work runs on the
// calling thread, and the call returns when the rasterising threads are
// done). Every render at rest paid it whole: the first after the camera
// settles, and the next after anything changed.
//
// How (a large cloud filled in over several frames, as CloudCompare's
// level-of-detail display does):
// * pass 0 clears and draws the scene as in motion: the motion level in
//   place of the rest level, with every other prop but the translucent
//   ones. It is a frame in motion, and what the eye already sees;
// * each further pass draws only the next rest batches, nearest the eye
//   first, about a LOD budget of points (the points a frame in motion
//   draws), with the renderer's colour and depth buffers preserved: each
//   point lands where a one-frame render would put it. The motion level's
//   points are among the rest level's (each chunk's rest level holds its
//   motion level's points: CloudView::BuildDrawn), drawn again at the same
//   depth in the same colour;
// * the last pass also draws the translucent props (drawn once, over every
//   point, as a one-frame render blends them), the 2D overlays (the colour
//   bar, drawn in pass 0 too) and the other renderers (the axes marker).
// The depth range is the whole scene's, set before pass 0 and kept.
//
// Between passes every prop is as it was: a frame someone else renders (the
// interactor as the camera starts to move, an exposure's repaint) draws the
// whole scene. Anything that asks for a new frame starts again at pass 0;
// the camera starting to move cancels the passes (SetLodActive). A resize
// is drawn at the motion level (resizeEvent): Qt repaints a resized view at
// once, outside the passes, and with the rest level up that was one frame
// of the whole rest level (91-260 ms of the GUI thread for the office
// floor's 1.1 M points each time the floor-plan dock opened, 0.35-0.46 s
// for a million points above).
#include <vtkActor.h>
#include <vtkActor2D.h>
#include <vtkCamera.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkMapper.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProp.h>
#include <vtkPropCollection.h>
#include <vtkRenderer.h>
#include <vtkRendererCollection.h>
#include <vtkScalarBarActor.h>

#include <malloc.h>

#include <QElapsedTimer>
#include <QResizeEvent>
#include <QTimer>
#include <algorithm>
#include <set>
#include <utility>
#include <vector>

#include "ui/view/cloud_view.h"
#include "ui/view/cloud_view_chunk.h"

namespace sweepscan::ui {
namespace {

// Props hidden or shown, and actors' mappers swapped, for one pass, put
// back as they were when it ends.
class PassScope {
 public:
  PassScope() = default;
  PassScope(const PassScope&) = delete;
  PassScope& operator=(const PassScope&) = delete;
  ~PassScope() {
    for (auto it = saved_.rbegin(); it != saved_.rend(); ++it) it->first->SetVisibility(it->second);
    for (auto it = mappers_.rbegin(); it != mappers_.rend(); ++it) it->first->SetMapper(it->second);
  }
  void Set(vtkProp* prop, bool visible) {
    if (static_cast<bool>(prop->GetVisibility()) == visible) return;
    saved_.emplace_back(prop, prop->GetVisibility());
    prop->SetVisibility(visible);
  }
  void SetMapper(vtkActor* actor, vtkMapper* mapper) {
    if (actor->GetMapper() == mapper) return;
    mappers_.emplace_back(actor, actor->GetMapper());
    actor->SetMapper(mapper);
  }

 private:
  std::vector<std::pair<vtkProp*, vtkTypeBool>> saved_;
  std::vector<std::pair<vtkActor*, vtkSmartPointer<vtkMapper>>> mappers_;
};

std::vector<vtkProp*> VisibleProps(vtkRenderer* renderer) {
  std::vector<vtkProp*> out;
  vtkPropCollection* props = renderer->GetViewProps();
  vtkCollectionSimpleIterator it;
  props->InitTraversal(it);
  while (vtkProp* p = props->GetNextProp(it)) {
    if (p->GetVisibility()) out.push_back(p);
  }
  return out;
}

}  // namespace

void CloudView::resizeEvent(QResizeEvent* event) {
  // Switched before Qt's repaint of the new size (QOpenGLWidget's resize
  // paints at once), back to rest by the settle timer, as after the camera
  // stops: PlanRest for the new aspect, then the passes.
  if (WantPasses()) {
    SetLodActive(true);
    settle_->start();
  }
  QVTKOpenGLNativeWidget::resizeEvent(event);
}

bool CloudView::WantPasses() {
  if (lod_active_ || !renderer_known_) return false;
  SyncBatches();
  size_t points = 0;
  for (const auto& b : rest_batches_) points += b->points();
  for (const Layer& l : layers_) {
    if (l.motion && l.actor->GetVisibility()) points += l.rest->GetInput()->GetNumberOfPoints();
  }
  return points > lod_budget_;
}

void CloudView::StartPasses() {
  dirty_ = false;
  QElapsedTimer clock;
  clock.start();
  color_bar_->SetVisibility(ColorBarShown());
  renderer_->ResetCameraClippingRange();  // The whole scene's, kept by every pass.

  // The rest batches nearest the eye first (their boxes' distance).
  double eye[3];
  renderer_->GetActiveCamera()->GetPosition(eye);
  // The layers' pieces (a project's sessions) with them, by their boxes in
  // the project's frame (the actors' bounds, through their matrices).
  std::vector<std::pair<double, std::pair<vtkActor*, size_t>>> by_distance;
  auto add = [&](vtkActor* actor, const double* box, size_t points) {
    double d2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double q = std::clamp(eye[k], box[2 * k], box[2 * k + 1]);
      d2 += (eye[k] - q) * (eye[k] - q);
    }
    by_distance.push_back({d2, {actor, points}});
  };
  for (const auto& b : rest_batches_) {
    if (b->points() > 0) add(b->drawn.actor, b->drawn.poly->GetBounds(), b->points());
  }
  for (const Layer& l : layers_) {
    const vtkIdType n = l.rest->GetInput()->GetNumberOfPoints();
    if (l.motion && l.actor->GetVisibility() && n > 0) {
      add(l.actor, l.actor->GetBounds(), static_cast<size_t>(n));
    }
  }
  std::stable_sort(by_distance.begin(), by_distance.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  progress_.order.clear();
  for (const auto& [d2, item] : by_distance) progress_.order.push_back(item);
  progress_.next = 0;
  progress_.last_points = 0;
  ++progress_.drawn;
  progress_.active = !progress_.order.empty();

  {
    PassScope scope;
    std::set<vtkProp*> batch_actors;
    for (const auto& b : rest_batches_) {
      scope.Set(b->drawn.actor, false);
      batch_actors.insert(b->drawn.actor);
    }
    for (const auto& b : motion_batches_) {
      scope.Set(b->drawn.actor, true);
      batch_actors.insert(b->drawn.actor);
    }
    for (const Layer& l : layers_) {
      if (l.motion) scope.SetMapper(l.actor, l.motion);
      batch_actors.insert(l.actor);
    }
    for (vtkProp* p : VisibleProps(renderer_)) {
      if (batch_actors.count(p) == 0 && vtkActor2D::SafeDownCast(p) == nullptr &&
          p->HasTranslucentPolygonalGeometry()) {
        scope.Set(p, false);  // Drawn in the last pass.
      }
    }
    window_->Render();
  }
  last_render_ms_ = clock.nsecsElapsed() * 1e-6;
}

void CloudView::NextPass() {
  QElapsedTimer clock;
  clock.start();
  const std::vector<std::pair<vtkActor*, size_t>>& order = progress_.order;
  size_t end = progress_.next, points = 0;
  while (end < order.size()) {
    const size_t n = order[end].second;
    if (end > progress_.next && points + n > lod_budget_) break;
    points += n;
    ++end;
  }
  const bool last = end == order.size();
  {
    PassScope scope;
    std::set<vtkProp*> pass, batch_actors;
    for (size_t i = progress_.next; i < end; ++i) pass.insert(order[i].first);
    for (const auto* level : {&motion_batches_, &rest_batches_}) {
      for (const auto& b : *level) batch_actors.insert(b->drawn.actor);
    }
    for (const Layer& l : layers_) batch_actors.insert(l.actor);
    for (vtkProp* p : VisibleProps(renderer_)) {
      if (pass.count(p) != 0) continue;
      const bool overlay = batch_actors.count(p) == 0 &&
                           (vtkActor2D::SafeDownCast(p) != nullptr || p->HasTranslucentPolygonalGeometry());
      if (!(last && overlay)) scope.Set(p, false);
    }
    // The other renderers (the axes marker's) draw over their viewport in
    // pass 0 and the last pass only.
    std::vector<vtkRenderer*> quiet;
    vtkRendererCollection* renderers = window_->GetRenderers();
    vtkCollectionSimpleIterator it;
    renderers->InitTraversal(it);
    while (vtkRenderer* r = renderers->GetNextRenderer(it)) {
      if (r != renderer_ && r->GetDraw() && !last) {
        r->DrawOff();
        quiet.push_back(r);
      }
    }
    // Over the image so far: its colour and depth kept. (Not EraseOff(),
    // which skips the renderer's Clear(): with it the colour was kept but
    // farther points drew over nearer ones, 19 382 pixels off in
    // cloud_store_ui_test against 943.)
    renderer_->PreserveColorBufferOn();
    renderer_->PreserveDepthBufferOn();
    window_->Render();
    renderer_->PreserveColorBufferOff();
    renderer_->PreserveDepthBufferOff();
    for (vtkRenderer* r : quiet) r->DrawOn();
  }
  progress_.next = end;
  progress_.last_points = points;
  ++progress_.drawn;
  progress_.active = !last;
  // The view at rest: the heap glibc keeps for reuse (the app keeps freed
  // memory, app/gui_main.cc: llvmpipe's per-draw buffers) goes back to the
  // system, among it the transient of any frame drawn whole before (~250
  // MB for a million points in one frame: the binner's and the draw
  // module's). 1.6-2.7 ms; the next frames fault in what they need again
  // (a frame in motion measured no slower after it).
  if (last) malloc_trim(0);
  last_render_ms_ = clock.nsecsElapsed() * 1e-6;
}

}  // namespace sweepscan::ui
