// sweepscan-render: renders a cloud file to a PNG with VTK, off screen, for
// reports, the README and for looking at results without the desktop app.
// Needs an X display or xvfb-run (VTK's OpenGL2 backend on Debian is GLX).
//
//   sweepscan-render CLOUD.ply OUT.png [--view iso|top|front|side] [--size WxH]
//                    [--color height|time|source] [--title TEXT] [--max-z Z]
//                    [--crop XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX]
#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkFloatArray.h>
#include <vtkLookupTable.h>
#include <vtkNew.h>
#include <vtkPNGWriter.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkScalarBarActor.h>
#include <vtkSmartPointer.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkWindowToImageFilter.h>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "app/cli_args.h"
#include "core/cloud/cloud_io.h"

namespace {

using sweepscan::CloudPoint;
using sweepscan::app::Args;

int Fail(const std::string& message, int code) {
  std::cerr << "sweepscan-render: error: " << message << "\n";
  return code;
}

// The cloud, without what --max-z and --crop leave out. Returns an exit
// code (0: go on).
int LoadPoints(const Args& args, std::vector<CloudPoint>* points_out) {
  std::vector<CloudPoint>& points = *points_out;
  std::string error;
  const sweepscan::Status s = sweepscan::LoadCloud(args.positional()[0], &points);
  if (!s.ok()) return Fail(s.message(), 2);
  double max_z = 0.0;
  if (!args.GetDouble("max-z", &max_z, &error)) return Fail(error, 2);
  if (args.Has("max-z")) {
    // Leave out the ceiling (or anything above max_z) to see inside a room.
    points.erase(std::remove_if(points.begin(), points.end(),
                                [max_z](const sweepscan::CloudPoint& p) { return p.z > max_z; }),
                 points.end());
  }
  if (args.Has("crop")) {
    // Keep one box of the world (e.g. the calibration target and its ghosts).
    double b[6];
    if (std::sscanf(args.Get("crop").c_str(), "%lf,%lf,%lf,%lf,%lf,%lf", &b[0], &b[1], &b[2], &b[3],
                    &b[4], &b[5]) != 6 ||
        !(b[0] < b[3] && b[1] < b[4] && b[2] < b[5])) {
      return Fail("--crop expects XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX with each min < max", 2);
    }
    points.erase(std::remove_if(points.begin(), points.end(),
                                [&b](const sweepscan::CloudPoint& p) {
                                  return p.x < b[0] || p.y < b[1] || p.z < b[2] || p.x > b[3] ||
                                         p.y > b[4] || p.z > b[5];
                                }),
                 points.end());
  }
  if (points.empty()) return Fail(args.positional()[0] + ": the cloud is empty", 2);
  return 0;
}

struct RenderOptions {
  int width = 1280, height = 720;
  std::string color, view;
};

// --size, --color, --view. Returns an exit code (0: go on).
int ParseRenderOptions(const Args& args, RenderOptions* o) {
  int& width = o->width;
  int& height = o->height;
  if (args.Has("size") && std::sscanf(args.Get("size").c_str(), "%dx%d", &width, &height) != 2) {
    return Fail("--size expects WxH, e.g. 1280x720", 2);
  }
  o->color = args.Get("color", "height");
  o->view = args.Get("view", "iso");
  const std::string& color = o->color;
  const std::string& view = o->view;
  if (color != "height" && color != "time" && color != "source") return Fail("--color: height, time or source", 2);
  if (view != "iso" && view != "top" && view != "front" && view != "back" && view != "side") {
    return Fail("--view: iso, top, front, back or side", 2);
  }
  return 0;
}

// The points as VTK vertices with one scalar each (height, time or pose
// source), and the scalars' range [lo, hi].
vtkSmartPointer<vtkPolyData> ColoredPoints(const std::vector<CloudPoint>& points,
                                           const std::string& color, double* lo_out,
                                           double* hi_out) {
  vtkNew<vtkPoints> pts;
  pts->SetDataTypeToFloat();
  pts->SetNumberOfPoints(static_cast<vtkIdType>(points.size()));
  vtkNew<vtkFloatArray> scalars;
  scalars->SetNumberOfValues(static_cast<vtkIdType>(points.size()));
  vtkNew<vtkCellArray> verts;
  double lo = 1e300, hi = -1e300;
  for (size_t i = 0; i < points.size(); ++i) {
    const auto& p = points[i];
    pts->SetPoint(static_cast<vtkIdType>(i), p.x, p.y, p.z);
    double v = p.z;
    if (color == "time") v = static_cast<double>(p.time_ns) * 1e-9;
    if (color == "source") v = p.pose_source;
    scalars->SetValue(static_cast<vtkIdType>(i), static_cast<float>(v));
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  verts->AllocateEstimate(static_cast<vtkIdType>(points.size()), 1);
  for (vtkIdType i = 0; i < static_cast<vtkIdType>(points.size()); ++i) verts->InsertNextCell(1, &i);
  vtkSmartPointer<vtkPolyData> poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(pts);
  poly->SetVerts(verts);
  poly->GetPointData()->SetScalars(scalars);
  *lo_out = lo;
  *hi_out = hi;
  return poly;
}

// The points coloured blue (low) to red (high) with a scalar bar, and the
// title if given.
vtkSmartPointer<vtkRenderer> Scene(const Args& args, vtkPolyData* poly, double lo, double hi,
                                   const RenderOptions& options) {
  const std::string& color = options.color;
  const int height = options.height;
  vtkNew<vtkLookupTable> lut;
  lut->SetHueRange(0.667, 0.0);  // blue (low) to red (high)
  lut->SetTableRange(lo, hi > lo ? hi : lo + 1);
  lut->Build();
  vtkNew<vtkPolyDataMapper> mapper;
  mapper->SetInputData(poly);
  mapper->SetLookupTable(lut);
  mapper->SetScalarRange(lut->GetTableRange());
  vtkNew<vtkActor> actor;
  actor->SetMapper(mapper);
  actor->GetProperty()->SetPointSize(1.5);

  vtkSmartPointer<vtkRenderer> renderer = vtkSmartPointer<vtkRenderer>::New();
  renderer->AddActor(actor);
  renderer->SetBackground(0.08, 0.09, 0.11);
  vtkNew<vtkScalarBarActor> bar;
  bar->SetLookupTable(lut);
  bar->SetTitle(color == "height" ? "z (m)" : color == "time" ? "time (s)" : "pose source");
  bar->SetNumberOfLabels(5);
  bar->SetMaximumWidthInPixels(90);
  renderer->AddActor2D(bar);
  if (args.Has("title")) {
    vtkNew<vtkTextActor> title;
    title->SetInput(args.Get("title").c_str());
    title->GetTextProperty()->SetFontSize(20);
    title->GetTextProperty()->SetColor(0.9, 0.9, 0.9);
    title->SetDisplayPosition(12, height - 34);
    renderer->AddActor2D(title);
  }
  return renderer;
}

// The camera on the cloud's centre from the view's side.
void PlaceCamera(vtkPolyData* poly, const std::string& view, vtkRenderer* renderer) {
  double b[6];
  poly->GetBounds(b);
  const double cx = 0.5 * (b[0] + b[1]), cy = 0.5 * (b[2] + b[3]), cz = 0.5 * (b[4] + b[5]);
  vtkCamera* cam = renderer->GetActiveCamera();
  cam->SetFocalPoint(cx, cy, cz);
  if (view == "top") {
    cam->SetPosition(cx, cy, cz + 10);
    cam->SetViewUp(0, 1, 0);
  } else if (view == "front") {
    cam->SetPosition(cx, cy - 10, cz);
    cam->SetViewUp(0, 0, 1);
  } else if (view == "back") {  // from +y: faces the y = 0 wall (the lab's target)
    cam->SetPosition(cx, cy + 10, cz);
    cam->SetViewUp(0, 0, 1);
  } else if (view == "side") {
    cam->SetPosition(cx - 10, cy, cz);
    cam->SetViewUp(0, 0, 1);
  } else {
    cam->SetPosition(cx - 6, cy - 9, cz + 8);
    cam->SetViewUp(0, 0, 1);
  }
  renderer->ResetCamera();
  cam->Zoom(view == "iso" ? 1.3 : 1.1);
}

// Renders off screen and writes the PNG. Returns an exit code.
int WritePng(vtkRenderer* renderer, const RenderOptions& options, const std::string& path) {
  const int width = options.width, height = options.height;
  vtkNew<vtkRenderWindow> window;
  window->SetOffScreenRendering(1);
  window->AddRenderer(renderer);
  window->SetSize(width, height);
  window->Render();
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput(window);
  grab->Update();
  vtkNew<vtkPNGWriter> writer;
  writer->SetFileName(path.c_str());
  writer->SetInputConnection(grab->GetOutputPort());
  writer->Write();
  if (writer->GetErrorCode() != 0) return Fail("cannot write " + path, 1);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Args args({"help"}, {"view", "size", "color", "title", "max-z", "crop"});
  std::string error;
  if (!args.Parse(argc, argv, 1, &error)) return Fail(error, 2);
  if (args.Flag("help") || args.positional().size() != 2) {
    std::cout << "usage: sweepscan-render CLOUD.ply|.pcd OUT.png [--view iso|top|front|back|side] "
                 "[--size WxH] [--color height|time|source] [--title TEXT] [--max-z Z]\n"
                 "                        [--crop XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX]\n";
    return args.Flag("help") ? 0 : 2;
  }
  std::vector<sweepscan::CloudPoint> points;
  int code = LoadPoints(args, &points);
  if (code != 0) return code;
  RenderOptions options;
  code = ParseRenderOptions(args, &options);
  if (code != 0) return code;
  double lo = 0.0, hi = 0.0;
  const vtkSmartPointer<vtkPolyData> poly = ColoredPoints(points, options.color, &lo, &hi);
  const vtkSmartPointer<vtkRenderer> renderer = Scene(args, poly, lo, hi, options);
  PlaceCamera(poly, options.view, renderer);
  code = WritePng(renderer, options, args.positional()[1]);
  if (code != 0) return code;
  std::printf("rendered %zu points to %s\n", points.size(), args.positional()[1].c_str());
  return 0;
}
