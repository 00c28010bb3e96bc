// CloudView's annotations: the evaluation's fitted planes as translucent
// coloured rectangles with their names (laid out on screen each frame, off
// each other), the two-point distance tool, and the placing of every text
// drawn over the view (those names, the distance, the picks' numbers, the
// colour bar).
// They live apart from the cloud's chunks; the planes are the only
// translucent actor (one extra pass, drawn only while planes are shown).
#include <vtkActor.h>
#include <vtkCallbackCommand.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCommand.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkScalarBarActor.h>
#include <vtkScalarsToColors.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkUnsignedCharArray.h>

#include <QColor>
#include <algorithm>
#include <array>
#include <cmath>

#include "ui/view/cloud_view.h"

namespace sweepscan::ui {

namespace {

// A plane's opacity: 0.35 with none selected; the selected one 0.6 and the
// others 0.2, so that the one the table names is the one seen.
double PlaneOpacity(int selected, size_t i) {
  if (selected < 0) return 0.35;
  return static_cast<int>(i) == selected ? 0.6 : 0.2;
}

}  // namespace

// A text over the view (a plane's name, a distance, a pick's number), drawn
// on top of the cloud: in the scene, a name behind a wall was cut by the
// wall's points.
vtkSmartPointer<vtkTextActor> CloudView::NewOverlayLabel() {
  auto label = vtkSmartPointer<vtkTextActor>::New();
  vtkTextProperty* t = label->GetTextProperty();
  t->SetFontSize(15);
  t->SetBold(true);
  t->SetBackgroundColor(0.1, 0.1, 0.12);
  t->SetBackgroundOpacity(0.85);
  t->SetFrame(false);
  t->SetJustificationToCentered();
  t->SetVerticalJustificationToCentered();
  label->GetPositionCoordinate()->SetCoordinateSystemToDisplay();
  label->PickableOff();
  return label;
}

void CloudView::BuildAnnotations() {
  auto layout = vtkSmartPointer<vtkCallbackCommand>::New();
  layout->SetClientData(this);
  layout->SetCallback([](vtkObject*, unsigned long, void* self, void*) {
    static_cast<CloudView*>(self)->LayoutOverlayLabels();
  });
  renderer_->AddObserver(vtkCommand::StartEvent, layout);

  auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  mapper->SetInputData(vtkSmartPointer<vtkPolyData>::New());
  mapper->SetScalarModeToUseCellData();
  mapper->SetColorModeToDirectScalars();
  planes_ = vtkSmartPointer<vtkActor>::New();
  planes_->SetMapper(mapper);
  // Translucent through the colours' alpha (PlaneOpacity), a plane each.
  planes_->PickableOff();
  planes_->VisibilityOff();
  renderer_->AddActor(planes_);
  // The selected plane's outline in white, the others' edges in faint
  // black (VTK 9.1 has no edge opacity of their own: the fill's alpha is
  // per cell, so the edges are lines of an actor each), in front of the
  // points they were fitted to (which hide most of their fill).
  const auto outline = [this](double grey, double width, double opacity) {
    auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
    mapper->SetInputData(vtkSmartPointer<vtkPolyData>::New());
    mapper->SetResolveCoincidentTopologyToPolygonOffset();
    mapper->SetRelativeCoincidentTopologyLineOffsetParameters(0.0, -20000.0);
    auto actor = vtkSmartPointer<vtkActor>::New();
    actor->SetMapper(mapper);
    actor->GetProperty()->SetColor(grey, grey, grey);
    actor->GetProperty()->SetLineWidth(width);
    actor->GetProperty()->SetOpacity(opacity);
    actor->PickableOff();
    actor->VisibilityOff();
    renderer_->AddActor(actor);
    return actor;
  };
  plane_outline_ = outline(1.0, 3.0, 1.0);
  plane_edges_ = outline(0.0, 1.5, 0.35);

  auto line_mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  line_mapper->SetInputData(vtkSmartPointer<vtkPolyData>::New());
  line_mapper->SetResolveCoincidentTopologyToPolygonOffset();
  // Drawn in front of the surfaces its ends were picked on (the floor's
  // points hid a segment along it), as the path is.
  line_mapper->SetRelativeCoincidentTopologyLineOffsetParameters(0.0, -20000.0);
  line_mapper->SetRelativeCoincidentTopologyPointOffsetParameter(-20000.0);
  measure_line_ = vtkSmartPointer<vtkActor>::New();
  measure_line_->SetMapper(line_mapper);
  // Magenta: no height, time or range colour, and apart from the path's
  // amber (the yellow it had read as the robot's path).
  measure_line_->GetProperty()->SetColor(kMeasureColor[0], kMeasureColor[1], kMeasureColor[2]);
  measure_line_->GetProperty()->SetLineWidth(3.0);
  measure_line_->GetProperty()->SetPointSize(9.0);
  measure_line_->GetProperty()->SetRenderPointsAsSpheres(true);
  measure_line_->GetProperty()->SetRenderLinesAsTubes(true);
  measure_line_->PickableOff();
  measure_line_->VisibilityOff();
  renderer_->AddActor(measure_line_);
  // Over the view, as the planes' names: in the scene, the walls in front
  // of the segment's middle cut its text.
  measure_label_ = NewOverlayLabel();
  measure_label_->GetTextProperty()->SetColor(kMeasureColor[0], kMeasureColor[1], kMeasureColor[2]);
  measure_label_->VisibilityOff();
  renderer_->AddActor2D(measure_label_);
}

void CloudView::SetPlanes(const std::vector<PlanePatch>& planes) {
  auto points = vtkSmartPointer<vtkPoints>::New();
  auto quads = vtkSmartPointer<vtkCellArray>::New();
  auto colors = vtkSmartPointer<vtkUnsignedCharArray>::New();
  colors->SetNumberOfComponents(4);
  colors->SetName("colors");
  selected_plane_ = -1;
  for (size_t i = 0; i < planes.size(); ++i) {
    if (planes[i].selected) selected_plane_ = static_cast<int>(i);
  }
  for (const auto& label : plane_labels_) renderer_->RemoveActor2D(label);
  plane_labels_.clear();
  plane_label_anchors_.clear();
  plane_label_boxes_.clear();
  for (const PlanePatch& p : planes) {
    vtkIdType ids[4];
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) {
      ids[k] = points->InsertNextPoint(p.corners[k].data());
      centre += 0.25 * p.corners[k];
    }
    quads->InsertNextCell(4, ids);
    // The opacity in the colour (the actor's is 1): a cell each.
    const size_t i = plane_labels_.size();
    const unsigned char rgba[4] = {
        static_cast<unsigned char>(p.color.red()), static_cast<unsigned char>(p.color.green()),
        static_cast<unsigned char>(p.color.blue()),
        static_cast<unsigned char>(std::lround(255.0 * PlaneOpacity(selected_plane_, i)))};
    colors->InsertNextTypedTuple(rgba);
    auto label = NewOverlayLabel();
    label->SetInput(p.label.toUtf8().constData());
    // The plane's hue, lightened where it is dark (the floor's brown read
    // grey on the plate's near-black over a bright cloud).
    const QColor hsl = p.color.toHsl();
    const QColor text = QColor::fromHsl(std::max(0, hsl.hslHue()), hsl.hslSaturation(),
                                        std::max(hsl.lightness(), 175));
    label->GetTextProperty()->SetColor(text.redF(), text.greenF(), text.blueF());
    label->GetTextProperty()->SetBold(p.selected);
    label->VisibilityOff();  // until laid out
    renderer_->AddActor2D(label);
    plane_labels_.push_back(label);
    plane_label_anchors_.push_back(centre);
  }
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetPolys(quads);
  poly->GetCellData()->SetScalars(colors);
  static_cast<vtkPolyDataMapper*>(planes_->GetMapper())->SetInputData(poly);
  // The rectangles of the planes selected (`selected`) or not, as loops.
  const auto loops = [&](bool selected) {
    auto corners = vtkSmartPointer<vtkPoints>::New();
    auto lines = vtkSmartPointer<vtkCellArray>::New();
    for (size_t i = 0; i < planes.size(); ++i) {
      if ((static_cast<int>(i) == selected_plane_) != selected) continue;
      vtkIdType ids[5];
      for (int k = 0; k < 4; ++k) ids[k] = corners->InsertNextPoint(planes[i].corners[k].data());
      ids[4] = ids[0];
      lines->InsertNextCell(5, ids);
    }
    auto poly = vtkSmartPointer<vtkPolyData>::New();
    poly->SetPoints(corners);
    poly->SetLines(lines);
    return poly;
  };
  static_cast<vtkPolyDataMapper*>(plane_outline_->GetMapper())->SetInputData(loops(true));
  static_cast<vtkPolyDataMapper*>(plane_edges_->GetMapper())->SetInputData(loops(false));
  plane_count_ = planes.size();
  SetPlanesVisible(planes_visible_);
}

double CloudView::plane_opacity(size_t i) const { return PlaneOpacity(selected_plane_, i); }

size_t CloudView::plane_edges() const {
  return static_cast<size_t>(
      static_cast<vtkPolyDataMapper*>(plane_edges_->GetMapper())->GetInput()->GetNumberOfLines());
}

void CloudView::SetPlanesVisible(bool visible) {
  planes_visible_ = visible;
  planes_->SetVisibility(visible && plane_count_ > 0);
  plane_outline_->SetVisibility(visible && selected_plane_ >= 0);
  plane_edges_->SetVisibility(visible && plane_edges() > 0);
  // The labels follow at the next frame (LayoutOverlayLabels).
  RequestRender();
}

QRectF CloudView::LayoutColorBar() {
  // The bar's frame: 7 % of the view's width at 88 %, from 5 % to 50 % of
  // its height (BuildColorBar). The title is centred over the frame and the
  // labels of a categorical bar (the passes) stand left of it, so on a
  // narrow view the title ran off the right edge: the frame moves left
  // until the title fits.
  //
  // Measuring a text costs ~25 us (FreeType) and the layout runs before
  // every frame, so it is measured again only when what it depends on
  // changed: the key below, taken after the bar was moved.
  color_bar_box_ = QRectF();
  int* size = renderer_->GetSize();
  if (!color_bar_->GetVisibility() || size[0] <= 0 || size[1] <= 0) return QRectF();
  vtkScalarsToColors* lut = color_bar_->GetLookupTable();
  const auto key = [&] {
    return std::array<uint64_t, 8>{static_cast<uint64_t>(size[0]),
                                   static_cast<uint64_t>(size[1]),
                                   static_cast<uint64_t>(renderer_->GetRenderWindow()->GetDPI()),
                                   reinterpret_cast<uintptr_t>(lut),
                                   color_bar_->GetMTime(),
                                   lut != nullptr ? lut->GetMTime() : 0,
                                   color_bar_->GetTitleTextProperty()->GetMTime(),
                                   color_bar_->GetAnnotationTextProperty()->GetMTime()};
  };
  if (key() == color_bar_key_) return color_bar_layout_;
  if (!text_measure_) text_measure_ = vtkSmartPointer<vtkTextActor>::New();
  auto measure = [&](vtkTextProperty* property, const char* text) {
    ++color_bar_measures_;
    text_measure_->GetTextProperty()->ShallowCopy(property);
    text_measure_->SetInput(text);
    double extent[2] = {0.0, 0.0};
    text_measure_->GetSize(renderer_, extent);
    return QSizeF(extent[0], extent[1]);
  };
  const double w = size[0], h = size[1], margin = 6.0;
  const QSizeF title = measure(color_bar_->GetTitleTextProperty(), color_bar_->GetTitle());
  const double frame_w = 0.07 * w;
  double x = std::min(0.88 * w, w - margin - 0.5 * (frame_w + title.width()));
  x = std::max(0.0, x);
  if (std::abs(x / w - color_bar_->GetPosition()[0]) > 1e-9) {
    color_bar_->SetPosition(x / w, 0.05);
  }
  const double centre = x + 0.5 * frame_w;
  const double half = 0.5 * std::max(frame_w, title.width());
  QRectF box(centre - half, 0.05 * h, 2.0 * half, 0.45 * h);
  if (lut != nullptr && lut->GetIndexedLookup() && color_bar_->GetDrawAnnotations()) {
    // The categories' names, left of the swatches with their leaders.
    double widest = 0.0;
    for (vtkIdType i = 0; i < lut->GetNumberOfAnnotatedValues(); ++i) {
      widest = std::max(
          widest,
          measure(color_bar_->GetAnnotationTextProperty(), lut->GetAnnotation(i).c_str()).width());
    }
    box.setLeft(
        std::min(box.left(), x - widest - 2.0 * margin - color_bar_->GetAnnotationLeaderPadding()));
  }
  color_bar_layout_ = box.adjusted(-2.0, -2.0, 2.0, 2.0);
  color_bar_key_ = key();
  return color_bar_layout_;
}

void CloudView::FitLeftOfColorBar(const double bounds[6]) {
  // ResetCamera fits the bounds' sphere to the whole view, centred, and the
  // colour bar stands over the view's right eighth: a room seen from above
  // (key 1) fills the view's width, and its east wall was under the bar.
  // The bounds' box as projected is fitted instead into the part left of
  // the bar. A perspective draws what is at distance d at a size of 1/d, so
  // moving the eye back along its axis to d / s shrinks the box by s
  // (exactly in the focal plane, nearly so for the box's nearer and farther
  // corners); a pan by the box's offset from the free part's centre, at the
  // focal plane's 2 d tan(a/2) / h metres a pixel (a the vertical view
  // angle, h the view's height), centres it. A few rounds absorb what the
  // box's depth makes inexact: the eye moved back by D/s - D shrinks a
  // corner at distance d < D by more than s.
  if (!ColorBarShown()) return;
  color_bar_->SetVisibility(true);  // as the next frame will draw it
  const QRectF bar = LayoutColorBar();
  if (bar.isEmpty() || bounds[0] > bounds[1]) return;
  const int* size = renderer_->GetSize();
  const int* origin = renderer_->GetOrigin();
  constexpr double kMargin = 8.0;
  const QRectF free(origin[0] + kMargin, origin[1] + kMargin,
                    bar.left() - origin[0] - 2.0 * kMargin, size[1] - 2.0 * kMargin);
  // A view too narrow to give the bar a column of its own keeps the fit.
  if (free.width() < 0.5 * size[0] || free.height() <= 0.0) return;
  vtkCamera* camera = renderer_->GetActiveCamera();
  double zoom = 1.0;
  for (int round = 0; round < 8; ++round) {
    double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d corner(bounds[c & 1], bounds[2 + ((c >> 1) & 1)],
                                   bounds[4 + ((c >> 2) & 1)]);
      double d[3];
      if (!ToDisplay(corner, d)) return;  // the eye inside the box: nothing to fit
      for (int k = 0; k < 2; ++k) {
        lo[k] = std::min(lo[k], d[k]);
        hi[k] = std::max(hi[k], d[k]);
      }
    }
    const QRectF box(QPointF(lo[0], lo[1]), QPointF(hi[0], hi[1]));
    if (round == 0 && !box.intersects(bar)) return;  // clear of it already
    // Never nearer than ResetCamera's fit (zoom <= 1): what it shows, whole.
    const double s =
        std::min({1.0 / zoom, free.width() / box.width(), free.height() / box.height()});
    if (free.adjusted(-1.0, -1.0, 1.0, 1.0).contains(box) && s < 1.01) return;
    if (std::abs(s - 1.0) > 0.005) {
      camera->Dolly(s);  // the distance over s
      zoom *= s;
      continue;
    }
    const double per_pixel =
        2.0 * camera->GetDistance() * std::tan(camera->GetViewAngle() * M_PI / 360.0) / size[1];
    const Eigen::Vector3d forward(camera->GetDirectionOfProjection());
    Eigen::Vector3d up(camera->GetViewUp());
    up = (up - up.dot(forward) * forward).normalized();
    const Eigen::Vector3d right = forward.cross(up);
    const QPointF offset = free.center() - box.center();
    // The eye moves against the offset for the scene to move with it.
    const Eigen::Vector3d move = -(offset.x() * right + offset.y() * up) * per_pixel;
    const Eigen::Vector3d position = Eigen::Vector3d(camera->GetPosition()) + move;
    const Eigen::Vector3d focal = Eigen::Vector3d(camera->GetFocalPoint()) + move;
    camera->SetPosition(position.data());
    camera->SetFocalPoint(focal.data());
  }
}

void CloudView::LayoutOverlayLabels() {
  plane_label_boxes_.clear();
  const double ratio = devicePixelRatioF();
  auto to_widget = [&](const QRectF& b) {  // display pixels (y up) to widget pixels (y down)
    return QRectF(b.left() / ratio, height() - b.bottom() / ratio, b.width() / ratio,
                  b.height() / ratio);
  };
  // The colour bar and the axes' corner are placed first: a plane's label
  // on them hid the bar's own labels.
  const QRectF bar = LayoutColorBar();
  color_bar_box_ = bar.isEmpty() ? QRectF() : to_widget(bar);
  int* size = renderer_->GetSize();
  int* origin = renderer_->GetOrigin();
  const QRectF viewport(origin[0], origin[1], size[0], size[1]);
  std::vector<QRectF> placed;
  if (!bar.isEmpty()) placed.push_back(bar);
  placed.push_back(QRectF(0.0, 0.0, 0.16 * size[0], 0.22 * size[1]));  // the axes
  // The distance at its segment's middle, placed before the planes' names.
  measure_label_->SetVisibility(false);
  measure_label_box_ = QRectF();
  double d[3];
  if (measuring_ && ToDisplay(measure_mid_, d) && viewport.contains(d[0], d[1])) {
    double extent[2];
    measure_label_->GetSize(renderer_, extent);
    const QRectF box(d[0] - extent[0] / 2 - 2.0, d[1] - extent[1] / 2 - 1.0, extent[0] + 4.0,
                     extent[1] + 2.0);
    measure_label_->SetDisplayPosition(static_cast<int>(std::lround(d[0])),
                                       static_cast<int>(std::lround(d[1])));
    measure_label_->SetVisibility(true);
    placed.push_back(box);
    measure_label_box_ = to_widget(box);
  }
  // The picks' numbers beside their markers, above and right of the dot.
  marker_label_boxes_.clear();
  for (MarkerLabel& m : marker_labels_) {
    m.actor->SetVisibility(false);
    if (!ToDisplay(m.at, d) || !viewport.contains(d[0], d[1])) continue;
    double extent[2];
    m.actor->GetSize(renderer_, extent);
    const double x = d[0] + 10.0, y = d[1] + 8.0;
    m.actor->SetDisplayPosition(static_cast<int>(std::lround(x)), static_cast<int>(std::lround(y)));
    m.actor->SetVisibility(true);
    const QRectF box(x - 2.0, y - 1.0, extent[0] + 4.0, extent[1] + 2.0);
    placed.push_back(box);
    marker_label_boxes_.push_back(to_widget(box));
  }
  if (plane_labels_.empty()) return;
  // The selected plane's name first, then SetPlanes' order (the
  // evaluation's: floor, ceiling, then the walls by size) is the order of
  // precedence: the first keeps its place.
  std::vector<size_t> order;
  if (selected_plane_ >= 0) order.push_back(static_cast<size_t>(selected_plane_));
  for (size_t i = 0; i < plane_labels_.size(); ++i) {
    if (static_cast<int>(i) != selected_plane_) order.push_back(i);
  }
  for (const size_t i : order) {
    vtkTextActor* label = plane_labels_[i];
    const Eigen::Vector3d& a = plane_label_anchors_[i];
    // A label above the clip height belongs to a hidden plane (the ceiling).
    const bool clipped = !std::isnan(clip_height_) && a.z() > clip_height_;
    label->SetVisibility(false);
    if (!planes_visible_ || clipped) continue;
    // Behind the camera or off the view: not drawn.
    if (!ToDisplay(a, d) || !viewport.contains(d[0], d[1])) continue;
    double extent[2];
    label->GetSize(renderer_, extent);
    const double w = extent[0] + 4.0, h = extent[1] + 2.0;
    // Up or down a line at a time, the nearest clear place first.
    bool found = false;
    QRectF box;
    for (int step = 0; step <= 8 && !found; ++step) {
      const int k = (step + 1) / 2 * (step % 2 == 1 ? 1 : -1);
      box = QRectF(d[0] - w / 2, d[1] + k * h - h / 2, w, h);
      if (!viewport.contains(box)) continue;
      found = std::none_of(placed.begin(), placed.end(),
                           [&](const QRectF& q) { return q.intersects(box); });
    }
    if (!found) continue;
    placed.push_back(box);
    label->SetDisplayPosition(static_cast<int>(std::lround(box.center().x())),
                              static_cast<int>(std::lround(box.center().y())));
    label->SetVisibility(true);
    // Widget pixels (y down), as WorldToWidget gives them.
    plane_label_boxes_.push_back({static_cast<int>(i), to_widget(box)});
  }
}

bool CloudView::ToDisplay(const Eigen::Vector3d& p, double* d) const {
  renderer_->SetWorldPoint(p.x(), p.y(), p.z(), 1.0);
  renderer_->WorldToDisplay();
  renderer_->GetDisplayPoint(d);
  // Behind the eye, the projection comes back mirrored through the centre.
  vtkCamera* camera = renderer_->GetActiveCamera();
  const Eigen::Vector3d eye(camera->GetPosition());
  const Eigen::Vector3d forward(camera->GetDirectionOfProjection());
  return camera->GetParallelProjection() != 0 || (p - eye).dot(forward) > 0.0;
}

void CloudView::SetMeasurement(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  auto points = vtkSmartPointer<vtkPoints>::New();
  const vtkIdType ids[2] = {points->InsertNextPoint(a.data()), points->InsertNextPoint(b.data())};
  auto lines = vtkSmartPointer<vtkCellArray>::New();
  lines->InsertNextCell(2, ids);
  auto verts = vtkSmartPointer<vtkCellArray>::New();
  verts->InsertNextCell(1, &ids[0]);
  verts->InsertNextCell(1, &ids[1]);
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetLines(lines);
  poly->SetVerts(verts);
  static_cast<vtkPolyDataMapper*>(measure_line_->GetMapper())->SetInputData(poly);
  measure_line_->VisibilityOn();
  measure_mid_ = 0.5 * (a + b);
  measuring_ = true;  // the label is placed before each frame (LayoutOverlayLabels)
  measure_label_->SetInput(
      QStringLiteral("%1 m").arg((b - a).norm(), 0, 'f', 3).toUtf8().constData());
  RequestRender();
}

void CloudView::ClearMeasurement() {
  measure_line_->VisibilityOff();
  measure_label_->VisibilityOff();
  measuring_ = false;
  RequestRender();
}

}  // namespace sweepscan::ui
