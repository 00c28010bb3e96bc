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
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkWindowToImageFilter.h>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>

#include "app/cli_args.h"
#include "core/cloud_io.h"

namespace {

int Fail(const std::string& message, int code) {
  std::cerr << "sweepscan-render: error: " << message << "\n";
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  using sweepscan::app::Args;
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
  int width = 1280, height = 720;
  if (args.Has("size") && std::sscanf(args.Get("size").c_str(), "%dx%d", &width, &height) != 2) {
    return Fail("--size expects WxH, e.g. 1280x720", 2);
  }
  const std::string color = args.Get("color", "height");
  const std::string view = args.Get("view", "iso");
  if (color != "height" && color != "time" && color != "source") return Fail("--color: height, time or source", 2);
  if (view != "iso" && view != "top" && view != "front" && view != "back" && view != "side") {
    return Fail("--view: iso, top, front, back or side", 2);
  }

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
  vtkNew<vtkPolyData> poly;
  poly->SetPoints(pts);
  poly->SetVerts(verts);
  poly->GetPointData()->SetScalars(scalars);

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

  vtkNew<vtkRenderer> renderer;
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

  vtkNew<vtkRenderWindow> window;
  window->SetOffScreenRendering(1);
  window->AddRenderer(renderer);
  window->SetSize(width, height);
  window->Render();
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput(window);
  grab->Update();
  vtkNew<vtkPNGWriter> writer;
  writer->SetFileName(args.positional()[1].c_str());
  writer->SetInputConnection(grab->GetOutputPort());
  writer->Write();
  if (writer->GetErrorCode() != 0) return Fail("cannot write " + args.positional()[1], 1);
  std::printf("rendered %zu points to %s\n", points.size(), args.positional()[1].c_str());
  return 0;
}
