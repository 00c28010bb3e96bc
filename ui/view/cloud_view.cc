#include "ui/view/cloud_view.h"

#include <vtkActor.h>
#include <vtkAxesActor.h>
#include <vtkCallbackCommand.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkFloatArray.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkInteractorStyleTrackballCamera.h>
#include <vtkLookupTable.h>
#include <vtkObjectFactory.h>
#include <vtkOrientationMarkerWidget.h>
#include <vtkPlane.h>
#include <vtkPlaneCollection.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkRenderer.h>
#include <vtkScalarBarActor.h>
#include <vtkTextProperty.h>
#include <vtkTransform.h>
#include <vtkUnsignedCharArray.h>
#include <vtkVariant.h>

#include <QBuffer>
#include <QCoreApplication>
#include <QElapsedTimer>
#include <QFileInfo>
#include <QMouseEvent>
#include <QThreadPool>
#include <QTimer>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <unordered_map>

#include "core/common/checked_file.h"
#include "ui/view/cloud_view_chunk.h"

namespace sweepscan::ui {
using cloud_view_internal::kScalarName;
using cloud_view_internal::kNaN;

namespace {

// VTK's trackball camera (left drag orbits, Ctrl + left rolls, middle pans,
// right and the wheel zoom) without its one-letter keys. Through the
// default style switch, 'j' made the camera a joystick, 't' back, 'a' moved
// the cloud instead of the camera, 'p' drew a red box round whatever was
// under the cursor, 'r' reset the camera and '3' asked for stereo: letters
// an operator types in a window where keys drive the robot and name views.
// The app's keys are its menus' (Help > Keyboard and Mouse).
class CameraStyle : public vtkInteractorStyleTrackballCamera {
 public:
  static CameraStyle* New();
  vtkTypeMacro(CameraStyle, vtkInteractorStyleTrackballCamera);
  void OnChar() override {}
};
vtkStandardNewMacro(CameraStyle);

}  // namespace

CloudView::CloudView(QWidget* parent) : QVTKOpenGLNativeWidget(parent) {
  // A native window of its own: Qt then composes and presents the view's
  // own area only. As an alien widget (Qt's default) every frame was
  // composed into the whole main window, the other widgets' backing store
  // drawn again as a window-sized texture: under llvmpipe presenting a frame
  // in motion took 19-22 ms after VTK's 27 ms render at 9.5 M points, and
  // 14-16 ms native (--orbit-benchmark's lod_frame_ms, docs/performance.md).
  setAttribute(Qt::WA_NativeWindow);
  window_ = vtkSmartPointer<vtkGenericOpenGLRenderWindow>::New();
  // No multisampling: points need no anti-aliasing, and 8x MSAA (VTK's
  // default) multiplies the rasterisation cost, which dominates under a
  // software renderer (measured with perf: ~85 % of the process in llvmpipe).
  window_->SetMultiSamples(0);
  setRenderWindow(window_);
  renderer_ = vtkSmartPointer<vtkRenderer>::New();
  renderer_->SetBackground(0.11, 0.12, 0.14);
  renderer_->SetBackground2(0.22, 0.24, 0.28);
  renderer_->GradientBackgroundOn();
  window_->AddRenderer(renderer_);
  interactor()->SetInteractorStyle(vtkSmartPointer<CameraStyle>::New());

  BuildColorBar();
  BuildGrid();
  BuildRobotAndTrajectory();
  BuildMarkers();
  BuildAxes();
  BuildAnnotations();
  InstallObservers();
  InstallBatchObserver();

  settle_ = new QTimer(this);
  settle_->setSingleShot(true);
  settle_->setInterval(kSettleMs);
  connect(settle_, &QTimer::timeout, this, [this] {
    if (interacting_) return;
    PlanRest();
    refine_timer_->start();
  });
  // The rest level, built in slices between events (never more than
  // kRefineSliceMs of the GUI thread at a time), then drawn.
  refine_timer_ = new QTimer(this);
  refine_timer_->setInterval(0);
  connect(refine_timer_, &QTimer::timeout, this, [this] {
    if (!RefineSlice(kRefineSliceMs)) return;
    refine_timer_->stop();
    lod_active_ = false;
    ShowLevels();
    RequestRender();
  });

  ViewOblique();
}

void CloudView::BuildColorBar() {
  // Colours: a perceptually ordered blue -> red ramp shared by every chunk.
  lut_ = vtkSmartPointer<vtkLookupTable>::New();
  lut_->SetHueRange(0.667, 0.0);
  lut_->SetNumberOfTableValues(256);
  lut_->Build();
  color_bar_ = vtkSmartPointer<vtkScalarBarActor>::New();
  color_bar_->SetLookupTable(lut_);
  color_bar_->SetNumberOfLabels(5);
  color_bar_->SetWidth(0.07);
  color_bar_->SetHeight(0.45);
  color_bar_->SetPosition(0.88, 0.05);
  // Fixed font sizes: a long title ("deviation (mm)") is not shrunk to the
  // bar's width.
  color_bar_->UnconstrainedFontSizeOn();
  color_bar_->GetTitleTextProperty()->SetFontSize(13);
  color_bar_->GetLabelTextProperty()->SetFontSize(12);
  // The pass names stand left of their swatches, over the cloud: upright
  // on a dark backing, readable on the points of either pass.
  vtkTextProperty* names = color_bar_->GetAnnotationTextProperty();
  names->SetFontSize(12);
  names->ItalicOff();
  names->ShadowOff();
  names->SetBackgroundColor(0.1, 0.1, 0.12);
  names->SetBackgroundOpacity(0.75);
  color_bar_->SetLabelFormat("%.1f");
  renderer_->AddViewProp(color_bar_);
  ApplyLookupTable();
}

void CloudView::BuildRobotAndTrajectory() {
  // Robot marker: a flat chevron pointing along the robot's x axis (its
  // heading), white with a dark outline so that it reads on any colour of
  // the cloud and apart from the amber path, 0.6 m long: about twice the
  // robot, found at a glance in a view of a whole room (a thin 0.5 m arrow
  // in the path's orange was lost on it). Drawn in front of the floor's
  // points and the path, as the path is in front of the floor.
  auto points = vtkSmartPointer<vtkPoints>::New();
  const double corners[4][2] = {{0.35, 0.0}, {-0.25, 0.22}, {-0.12, 0.0}, {-0.25, -0.22}};
  for (const auto& c : corners) points->InsertNextPoint(c[0], c[1], 0.0);
  auto polys = vtkSmartPointer<vtkCellArray>::New();
  const vtkIdType left[3] = {0, 1, 2}, right[3] = {0, 2, 3};
  polys->InsertNextCell(3, left);
  polys->InsertNextCell(3, right);
  auto outline = vtkSmartPointer<vtkCellArray>::New();
  const vtkIdType loop[5] = {0, 1, 2, 3, 0};
  outline->InsertNextCell(5, loop);
  auto colors = vtkSmartPointer<vtkUnsignedCharArray>::New();
  colors->SetNumberOfComponents(3);
  const unsigned char dark[3] = {25, 25, 30}, white[3] = {250, 250, 250};
  colors->InsertNextTypedTuple(dark);  // cells: lines first, then polygons
  colors->InsertNextTypedTuple(white);
  colors->InsertNextTypedTuple(white);
  auto chevron = vtkSmartPointer<vtkPolyData>::New();
  chevron->SetPoints(points);
  chevron->SetLines(outline);
  chevron->SetPolys(polys);
  chevron->GetCellData()->SetScalars(colors);
  auto robot_mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  robot_mapper->SetInputData(chevron);
  robot_mapper->SetScalarModeToUseCellData();
  robot_mapper->SetColorModeToDirectScalars();
  robot_mapper->SetRelativeCoincidentTopologyPolygonOffsetParameters(0.0, -30000.0);
  robot_mapper->SetRelativeCoincidentTopologyLineOffsetParameters(0.0, -40000.0);
  robot_ = vtkSmartPointer<vtkActor>::New();
  robot_->SetMapper(robot_mapper);
  robot_->GetProperty()->SetLineWidth(2.0);
  robot_->GetProperty()->LightingOff();  // flat: the same white seen from any side
  robot_->PickableOff();
  robot_->VisibilityOff();
  renderer_->AddActor(robot_);

  trajectory_points_ = vtkSmartPointer<vtkPoints>::New();
  trajectory_poly_ = vtkSmartPointer<vtkPolyData>::New();
  trajectory_poly_->SetPoints(trajectory_points_);
  trajectory_poly_->SetLines(vtkSmartPointer<vtkCellArray>::New());
  auto trajectory_mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  trajectory_mapper->SetInputData(trajectory_poly_);
  // Drawn in front of the floor's points it runs over (their noise is
  // centimetres): a large depth offset toward the camera.
  trajectory_mapper->SetRelativeCoincidentTopologyLineOffsetParameters(0.0, -20000.0);
  trajectory_ = vtkSmartPointer<vtkActor>::New();
  trajectory_->SetMapper(trajectory_mapper);
  trajectory_->GetProperty()->SetColor(1.0, 0.85, 0.2);
  trajectory_->GetProperty()->SetLineWidth(3.0);
  renderer_->AddActor(trajectory_);
}

void CloudView::BuildAxes() {
  axes_ = vtkSmartPointer<vtkAxesActor>::New();
  axes_widget_ = vtkSmartPointer<vtkOrientationMarkerWidget>::New();
  axes_widget_->SetOrientationMarker(axes_);
  axes_widget_->SetInteractor(interactor());
  axes_widget_->SetViewport(0.0, 0.0, 0.16, 0.22);
  axes_widget_->SetEnabled(1);
  axes_widget_->InteractiveOff();
}

void CloudView::InstallObservers() {
  // Level of detail while the camera moves (see the header).
  auto start = vtkSmartPointer<vtkCallbackCommand>::New();
  start->SetClientData(this);
  start->SetCallback([](vtkObject*, unsigned long, void* self, void*) {
    auto* view = static_cast<CloudView*>(self);
    view->interacting_ = true;
    ++view->camera_generation_;
    view->SetLodActive(true);
  });
  auto end = vtkSmartPointer<vtkCallbackCommand>::New();
  end->SetClientData(this);
  end->SetCallback([](vtkObject*, unsigned long, void* self, void*) {
    auto* view = static_cast<CloudView*>(self);
    view->interacting_ = false;
    view->settle_->start();  // Full detail once the camera has been still a moment.
  });
  interactor()->AddObserver(vtkCommand::StartInteractionEvent, start);
  interactor()->AddObserver(vtkCommand::EndInteractionEvent, end);

  // Frame counter and render time, whoever triggers the render (our timer or
  // the interactor while the operator moves the camera).
  auto on_start = vtkSmartPointer<vtkCallbackCommand>::New();
  auto* clock = new QElapsedTimer();
  on_start->SetClientData(clock);
  on_start->SetCallback(
      [](vtkObject*, unsigned long, void* c, void*) { static_cast<QElapsedTimer*>(c)->start(); });
  window_->AddObserver(vtkCommand::StartEvent, on_start);
  auto on_end = vtkSmartPointer<vtkCallbackCommand>::New();
  on_end->SetClientData(this);
  on_end->SetCallback([](vtkObject*, unsigned long, void* self, void*) {
    auto* view = static_cast<CloudView*>(self);
    ++view->frames_rendered_;
  });
  window_->AddObserver(vtkCommand::EndEvent, on_end);
  connect(this, &QObject::destroyed, [clock] { delete clock; });
}

CloudView::~CloudView() {
  // A pick still searching posts its result to this view: let it finish
  // first (the posted result is dropped with the view).
  WaitForPicks();
  QCoreApplication::removePostedEvents(this, QEvent::MetaCall);
}

void CloudView::BuildGrid() {
  // 1 m floor grid, 40 x 40 m around the origin.
  auto points = vtkSmartPointer<vtkPoints>::New();
  auto lines = vtkSmartPointer<vtkCellArray>::New();
  const int half = 20;
  for (int i = -half; i <= half; ++i) {
    const vtkIdType a = points->InsertNextPoint(i, -half, 0);
    const vtkIdType b = points->InsertNextPoint(i, half, 0);
    const vtkIdType c = points->InsertNextPoint(-half, i, 0);
    const vtkIdType d = points->InsertNextPoint(half, i, 0);
    vtkIdType ab[2] = {a, b}, cd[2] = {c, d};
    lines->InsertNextCell(2, ab);
    lines->InsertNextCell(2, cd);
  }
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetLines(lines);
  auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  mapper->SetInputData(poly);
  grid_ = vtkSmartPointer<vtkActor>::New();
  grid_->SetMapper(mapper);
  // Opaque and dim rather than translucent: a translucent actor would add a
  // translucency pass over the whole scene every frame.
  grid_->GetProperty()->SetColor(0.27, 0.29, 0.32);
  grid_->PickableOff();
  renderer_->AddActor(grid_);
}

void CloudView::NewDrawnActor(Drawn* d) {
  // Every cloud actor (either level of any chunk) shares the lookup table,
  // the point size and the clip; its one scalar array is the colour mode's.
  auto mapper = vtkSmartPointer<PacedMapper>::New();
  mapper->SetPacer(&pacer_);
  d->mapper = mapper;
  d->mapper->SetLookupTable(lut_);
  d->mapper->UseLookupTableScalarRangeOn();
  d->mapper->SetScalarModeToUsePointFieldData();
  d->mapper->SelectColorArray(kScalarName);
  d->mapper->ScalarVisibilityOn();
  ApplyClip(d->mapper);
  d->actor = vtkSmartPointer<vtkActor>::New();
  d->actor->SetMapper(d->mapper);
  d->actor->GetProperty()->SetPointSize(point_size_);
  d->actor->GetProperty()->SetRepresentationToPoints();
  renderer_->AddActor(d->actor);
}

void CloudView::Clear() {
  InvalidatePicks();  // A pick of the cloud that was reports nothing.
  for (auto& c : chunks_) RemoveChunkActors(c.get());
  chunks_.clear();
  if (spare_growing_) RemoveChunkActors(spare_growing_.get());
  spare_growing_.reset();
  cube_index_.clear();
  cube_keys_.clear();
  cube_counts_.clear();
  DrawnChanged();
  ClearBatches();
  refine_queue_.clear();
  point_count_ = 0;
  motion_sample_.Clear();
  next_serial_ = 0;
  lod_active_ = false;
  have_origin_ = false;
  have_points_ = false;
  has_values_[3] = has_values_[4] = has_values_[5] = false;
  emit pointValuesChanged();
  pass_filter_ = -1;
  range_lo_[0] = 0.0;
  range_hi_[0] = 3.0;
  range_hi_[1] = 60.0;
  range_hi_[2] = 8.0;
  // Annotations belong to the cloud they were made on.
  SetPlanes({});
  ClearMeasurement();
  trajectory_path_.Clear();
  trajectory_points_->Reset();
  trajectory_points_->Modified();
  trajectory_poly_->SetLines(vtkSmartPointer<vtkCellArray>::New());
  robot_->VisibilityOff();
  ApplyLookupTable();
  RequestRender();
}

void CloudView::SetRobotPose(const Pose2d& pose) {
  // A robot standing still asks for no frame: at rest a frame is drawn in
  // progressive passes, which a new frame every tick would keep at pass 0.
  const double* at = robot_->GetPosition();
  const double yaw_deg = pose.yaw * 180.0 / M_PI;
  if (robot_->GetVisibility() && std::abs(at[0] - pose.x) < 1e-3 && std::abs(at[1] - pose.y) < 1e-3 &&
      std::abs(std::remainder(robot_->GetOrientation()[2] - yaw_deg, 360.0)) < 0.1) {
    return;
  }
  robot_->SetPosition(pose.x, pose.y, 0.1);
  robot_->SetOrientation(0.0, 0.0, yaw_deg);
  robot_->VisibilityOn();
  RequestRender();
}

void CloudView::AppendTrajectory(const std::vector<Pose2d>& poses) {
  if (poses.empty()) return;
  // Simplified as it grows and ground driven again drawn once: a 5.7-hour
  // back-and-forth drive's 205 000 poses drawn as a 3-pixel line cost a
  // quarter of each frame under llvmpipe, and its passes simplified still
  // about 9 ms (docs/performance.md).
  for (const Pose2d& p : poses) trajectory_path_.Add({p.x, p.y});
  const std::vector<std::vector<Eigen::Vector2d>> lines = trajectory_path_.Polylines();
  vtkIdType n = 0;
  for (const auto& l : lines) n += static_cast<vtkIdType>(l.size());
  trajectory_points_->SetNumberOfPoints(n);
  auto line = vtkSmartPointer<vtkCellArray>::New();
  vtkIdType i = 0;
  for (const auto& l : lines) {
    if (l.size() >= 2) line->InsertNextCell(static_cast<vtkIdType>(l.size()));
    for (const Eigen::Vector2d& v : l) {
      // Above the floor's points (their noise is ~1-2 cm), so the path shows.
      trajectory_points_->SetPoint(i, v.x(), v.y(), 0.08);
      if (l.size() >= 2) line->InsertCellPoint(i);
      ++i;
    }
  }
  trajectory_points_->Modified();
  trajectory_poly_->SetLines(line);
  RequestRender();
}

void CloudView::SetPointSize(double pixels) {
  point_size_ = pixels;
  for (auto& c : chunks_) {
    for (Drawn* d : {&c->motion, &c->rest}) {
      if (d->actor) d->actor->GetProperty()->SetPointSize(pixels);
    }
  }
  for (const auto* level : {&motion_batches_, &rest_batches_}) {
    for (const auto& b : *level) b->drawn.actor->GetProperty()->SetPointSize(pixels);
  }
  for (auto& layer : layers_) layer.actor->GetProperty()->SetPointSize(pixels);
  RequestRender();
}

void CloudView::AddLayer(vtkActor* actor, vtkPolyDataMapper* motion) {
  Layer layer{actor, vtkPolyDataMapper::SafeDownCast(actor->GetMapper()), motion};
  actor->GetProperty()->SetPointSize(point_size_);
  for (vtkPolyDataMapper* m : {layer.rest.Get(), layer.motion.Get()}) {
    if (m != nullptr) ApplyClip(m);
    if (auto* paced = PacedMapper::SafeDownCast(m)) paced->SetPacer(&pacer_);
  }
  if (lod_active_ && motion != nullptr) actor->SetMapper(motion);
  layers_.push_back(std::move(layer));
  renderer_->AddActor(actor);
  RequestRender();
}

size_t CloudView::layer_points_drawn() const {
  size_t n = 0;
  for (const Layer& l : layers_) {
    auto* mapper = vtkPolyDataMapper::SafeDownCast(l.actor->GetMapper());
    if (l.actor->GetVisibility() && mapper != nullptr && mapper->GetInput() != nullptr) {
      n += static_cast<size_t>(mapper->GetInput()->GetNumberOfPoints());
    }
  }
  return n;
}

void CloudView::RemoveLayer(vtkActor* actor) {
  renderer_->RemoveActor(actor);
  layers_.erase(std::remove_if(layers_.begin(), layers_.end(),
                               [actor](const Layer& l) { return l.actor.Get() == actor; }),
                layers_.end());
  RequestRender();
}

void CloudView::SetLayerRests(const std::vector<std::pair<vtkActor*, vtkPolyDataMapper*>>& rests) {
  if (rests.empty()) return;
  const std::unordered_map<vtkActor*, vtkPolyDataMapper*> by_actor(rests.begin(), rests.end());
  for (Layer& l : layers_) {
    const auto it = by_actor.find(l.actor.Get());
    if (it == by_actor.end() || l.rest.Get() == it->second) continue;
    l.rest = it->second;
    ApplyClip(l.rest);
    if (auto* paced = PacedMapper::SafeDownCast(l.rest)) paced->SetPacer(&pacer_);
    if (!lod_active_ || !l.motion) l.actor->SetMapper(l.rest);
  }
  RequestRender();
}

void CloudView::ViewFrustum(double planes[24], double eye[3]) const {
  vtkCamera* camera = renderer_->GetActiveCamera();
  camera->GetFrustumPlanes(renderer_->GetTiledAspectRatio(), planes);
  camera->GetPosition(eye);
}

void CloudView::SetGridVisible(bool visible) {
  grid_->SetVisibility(visible);
  RequestRender();
}

void CloudView::SetAxesVisible(bool visible) {
  axes_widget_->SetEnabled(visible ? 1 : 0);
  RequestRender();
}

void CloudView::SetTrajectoryVisible(bool visible) {
  trajectory_->SetVisibility(visible);
  RequestRender();
}

void CloudView::SetRobotVisible(bool visible) {
  robot_->SetVisibility(visible && trajectory_points_->GetNumberOfPoints() > 0);
  RequestRender();
}

void CloudView::SetColorBarVisible(bool visible) {
  color_bar_wanted_ = visible;
  RequestRender();
}

bool CloudView::color_bar_drawn() const { return color_bar_->GetVisibility() != 0; }

void CloudView::ApplyClip(vtkPolyDataMapper* mapper) const {
  mapper->SetClippingPlanes(std::isnan(clip_height_) ? nullptr : clip_planes_.Get());
}

void CloudView::SetClipHeight(double z) {
  clip_height_ = z;
  if (!std::isnan(z)) {
    // Keeps n . x + d >= 0 with n = -z: the points below z.
    auto plane = vtkSmartPointer<vtkPlane>::New();
    plane->SetOrigin(0, 0, z);
    plane->SetNormal(0, 0, -1);
    clip_planes_ = vtkSmartPointer<vtkPlaneCollection>::New();
    clip_planes_->AddItem(plane);
  }
  for (auto& c : chunks_) {
    for (Drawn* d : {&c->motion, &c->rest}) {
      if (d->mapper) ApplyClip(d->mapper);
    }
  }
  for (const auto* level : {&motion_batches_, &rest_batches_}) {
    for (const auto& b : *level) ApplyClip(b->drawn.mapper);
  }
  for (auto& layer : layers_) {
    for (vtkPolyDataMapper* m : {layer.rest.Get(), layer.motion.Get()}) {
      if (m != nullptr) ApplyClip(m);
    }
  }
  // The planes too: a hidden ceiling must not tint the view from above.
  ApplyClip(static_cast<vtkPolyDataMapper*>(planes_->GetMapper()));
  ApplyClip(static_cast<vtkPolyDataMapper*>(plane_outline_->GetMapper()));
  ApplyClip(static_cast<vtkPolyDataMapper*>(plane_edges_->GetMapper()));
  SetPlanesVisible(planes_visible_);  // Labels of hidden planes go with them.
  RequestRender();
}

void CloudView::SetCamera(const double direction[3], const double up[3]) {
  ++camera_generation_;
  vtkCamera* camera = renderer_->GetActiveCamera();
  camera->SetFocalPoint(0, 0, 0);
  camera->SetPosition(-direction[0], -direction[1], -direction[2]);
  camera->SetViewUp(up[0], up[1], up[2]);
  FitToCloud();
}

void CloudView::ViewTop() {
  const double d[3] = {0, 0, -1}, up[3] = {0, 1, 0};
  SetCamera(d, up);
}

void CloudView::ViewOblique() {
  // From the south-west, 35 degrees above the floor: the room in 3D.
  const double d[3] = {0.6, 0.55, -0.58}, up[3] = {0, 0, 1};
  SetCamera(d, up);
}

void CloudView::ViewFront() {
  const double d[3] = {0, 1, 0}, up[3] = {0, 0, 1};
  SetCamera(d, up);
}

void CloudView::ViewSide() {
  const double d[3] = {-1, 0, 0}, up[3] = {0, 0, 1};
  SetCamera(d, up);
}

void CloudView::FitToCloud() {
  // The batches are rebuilt at render time: chunks appended this tick would
  // not be in the bounds ResetCamera fits (up to 32 chunks at a drive's end).
  SyncBatches();
  // Fit to the cloud (and the robot), not to the 40 m grid.
  const bool grid = grid_->GetVisibility();
  grid_->SetVisibility(point_count_ == 0 && layers_.empty());
  renderer_->ResetCamera();
  double bounds[6];
  renderer_->ComputeVisiblePropBounds(bounds);
  grid_->SetVisibility(grid);
  FitLeftOfColorBar(bounds);
  renderer_->ResetCameraClippingRange();
  RequestRender();
}

void CloudView::LookAt(const Eigen::Vector3d& focal, const Eigen::Vector3d& position) {
  ++camera_generation_;
  vtkCamera* camera = renderer_->GetActiveCamera();
  camera->SetFocalPoint(focal.data());
  camera->SetPosition(position.data());
  camera->SetViewUp(0.0, 0.0, 1.0);
  RequestRender();
}

void CloudView::MoveCameraWithFrame(const Rigid3d& new_from_old) {
  vtkCamera* camera = renderer_->GetActiveCamera();
  Eigen::Vector3d position, focal, up;
  camera->GetPosition(position.data());
  camera->GetFocalPoint(focal.data());
  camera->GetViewUp(up.data());
  // The ceiling clip is a height in the frame: it moves with it, kept level
  // and exact under the focal point. The new frame's tilt against the old
  // (the two start poses' difference: a few mrad, tens in a steep start)
  // moves the cut elsewhere by the tilt times the distance: 2 cm at 5 m
  // for 4 mrad.
  const double h = std::isnan(clip_height_) ? focal.z() : clip_height_;
  const double dz = (new_from_old * Eigen::Vector3d(focal.x(), focal.y(), h)).z() - h;
  if (!std::isnan(clip_height_)) SetClipHeight(clip_height_ + dz);
  position = new_from_old * position;
  focal = new_from_old * focal;
  up = new_from_old.rotation() * up;
  camera->SetPosition(position.data());
  camera->SetFocalPoint(focal.data());
  camera->SetViewUp(up.data());
  RequestRender();
  emit movedWithFrame(dz);
}

void CloudView::Orbit(double degrees) {
  const bool planned = !CameraMovedSincePlan();
  ++camera_generation_;
  renderer_->GetActiveCamera()->Azimuth(degrees);
  // Not a placement that plans the rest level again (RenderIfDirty): the
  // benchmarks orbit at the rest level planned for the first camera.
  if (planned) planned_camera_ = CurrentCameraKey();
  RequestRender();
}

CloudView::CameraKey CloudView::CurrentCameraKey() const {
  vtkCamera* camera = renderer_->GetActiveCamera();
  CameraKey key{};
  camera->GetPosition(&key[0]);
  camera->GetFocalPoint(&key[3]);
  camera->GetViewUp(&key[6]);
  key[9] = camera->GetViewAngle();
  key[10] = camera->GetParallelScale();
  key[11] = width();
  key[12] = height();
  key[13] = std::isnan(clip_height_) ? -1e300 : clip_height_;
  return key;
}

bool CloudView::SameCamera(const CameraKey& a, const CameraKey& b) {
  for (size_t k = 0; k < a.size(); ++k) {
    if (!(std::abs(a[k] - b[k]) <= 1e-9 * (1.0 + std::abs(a[k])))) return false;
  }
  return true;
}

bool CloudView::CameraMovedSincePlan() const {
  return !SameCamera(CurrentCameraKey(), planned_camera_);
}

bool CloudView::RenderIfDirty() {
  if (dirty_ && !lod_active_ && !interacting_ && (point_count_ > lod_budget_ || !layers_.empty()) &&
      CameraMovedSincePlan()) {
    SetLodActive(true);  // Drawn at the motion level now, planned for this camera at rest.
    settle_->start();
  }
  if (dirty_ && WantPasses()) {
    StartPasses();
  } else if (dirty_) {
    RenderNow();
  } else if (progress_.active) {
    NextPass();
  } else {
    return false;
  }
  return true;
}

void CloudView::RenderNow() {
  dirty_ = false;
  progress_.active = false;
  QElapsedTimer clock;
  clock.start();
  SyncBatches();  // Their bounds for the clipping range.
  color_bar_->SetVisibility(ColorBarShown());
  renderer_->ResetCameraClippingRange();
  window_->Render();
  last_render_ms_ = clock.nsecsElapsed() * 1e-6;
  if (!renderer_known_) {
    // The rest budget's default from the renderer: a software one (Mesa's
    // llvmpipe) draws ~6 M points a second and keeps ~250 bytes of working
    // memory per point drawn in a frame, held after it unless paced
    // (paced_mapper.h; measured: docs/performance.md), a GPU draws hundreds
    // of millions from its own memory.
    renderer_known_ = true;
    const std::string caps = window_->ReportCapabilities();
    software_renderer_ = caps.find("llvmpipe") != std::string::npos ||
                         caps.find("softpipe") != std::string::npos ||
                         caps.find("swrast") != std::string::npos;
    if (!rest_budget_set_) rest_budget_ = software_renderer_ ? 1'000'000 : 10'000'000;
    if (!draw_pace_set_) pacer_.limit = software_renderer_ ? kSoftwareDrawPace : 0;
    if (!lod_budget_set_) {
      lod_budget_ = software_renderer_ ? 30'000 : 1'000'000;
      ApplyLodBudget();
    }
  }
}

QImage CloudView::GrabImage() {
  RenderNow();
  return grabFramebuffer();
}

bool CloudView::SaveScreenshot(const QString& path, QString* error) {
  const QImage image = GrabImage();
  // Encoded in memory, then written through the checked writer (complete
  // or absent, never half an image; core/common/checked_file.h).
  QByteArray bytes;
  QBuffer buffer(&bytes);
  buffer.open(QIODevice::WriteOnly);
  const QByteArray format = QFileInfo(path).suffix().toLower().toLatin1();
  if (image.isNull() || !image.save(&buffer, format.isEmpty() ? "PNG" : format.constData())) {
    *error = QStringLiteral("%1: cannot encode the image").arg(path);
    return false;
  }
  const Status s = WriteFileChecked(path.toStdString(), bytes.toStdString());
  if (!s.ok()) {
    *error = QString::fromStdString(s.message());
    return false;
  }
  return true;
}

}  // namespace sweepscan::ui
