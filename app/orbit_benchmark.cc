// --orbit-benchmark N (app/orbit_benchmark.h).
#include "app/orbit_benchmark.h"

#include <QCoreApplication>
#include <QElapsedTimer>
#include <QMouseEvent>
#include <QTimer>
#include <algorithm>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <vector>

#include "app/gui_figures.h"
#include "core/cloud/cloud_pager.h"
#include "core/project/project.h"
#include "ui/main_window.h"
#include "ui/panels/calibration_panel.h"
#include "ui/project/project_controller.h"
#include "ui/project/project_document.h"
#include "ui/project/project_layer.h"
#include "ui/view/cloud_view.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::app {
namespace {

using ui::CloudView;
using ui::MainWindow;
using ui::Workspace;

// Frames per second while the camera orbits once in `frames` steps, at the
// rest level planned for the first camera (`lod` false) or at the motion
// level; and a frame's two halves: VTK's render into the widget's
// framebuffer, and the events after it, where Qt paints the widget and
// presents it.
struct Orbit {
  double fps = 0.0, render_ms = 0.0, present_ms = 0.0;
};
Orbit OrbitOnce(CloudView* view, int frames, bool lod) {
  view->SetLodActive(lod);
  Orbit o;
  QElapsedTimer t, part;
  t.start();
  for (int i = 0; i < frames; ++i) {
    view->Orbit(360.0 / frames);
    part.start();
    view->RenderNow();
    o.render_ms += part.nsecsElapsed() * 1e-6 / frames;
    part.start();
    QCoreApplication::processEvents();
    o.present_ms += part.nsecsElapsed() * 1e-6 / frames;
  }
  o.fps = frames / (t.nsecsElapsed() * 1e-9);
  return o;
}

// Orbits at both levels, then back at rest: the rest level planned and
// built for the last camera (`to_rest_s`), the same level in one frame, and
// in progressive passes as the GUI's timer draws them (the passes, pass 0
// included, and the event-loop turns that drew: a pass, or Qt's paint of
// the widget). `lod_points` is what `points_drawn` counts at the motion
// level, `rest_points` what it counts back at rest.
nlohmann::json OrbitAndRest(CloudView* view, int frames,
                            const std::function<size_t()>& points_drawn) {
  const Orbit full = OrbitOnce(view, frames, false);
  const Orbit lod = OrbitOnce(view, frames, true);
  nlohmann::json j = {{"fps_full", full.fps},
                      {"fps_lod", lod.fps},
                      {"lod_level", view->lod_level()},
                      {"lod_points", points_drawn()},
                      {"lod_frame_ms", {{"render", lod.render_ms}, {"present", lod.present_ms}}}};
  QElapsedTimer rest_clock;
  rest_clock.start();
  view->SetLodActive(false);
  view->RenderNow();
  j["to_rest_s"] = rest_clock.nsecsElapsed() * 1e-9;
  j["rest_points"] = points_drawn();
  QElapsedTimer frame_clock;
  frame_clock.start();
  view->RenderNow();
  QCoreApplication::processEvents();
  j["rest_frame_ms"] = frame_clock.nsecsElapsed() * 1e-6;
  std::vector<double> pass_ms;
  QElapsedTimer passes_clock;
  passes_clock.start();
  const uint64_t passes_before = view->passes_drawn();
  view->RequestRender();
  do {
    const uint64_t drawn = view->frames_rendered();
    QElapsedTimer turn;
    turn.start();
    QCoreApplication::processEvents();
    if (view->frames_rendered() != drawn) pass_ms.push_back(turn.nsecsElapsed() * 1e-6);
  } while (view->drawing_passes() || pass_ms.empty());
  j["rest_passes"] = {{"passes", view->passes_drawn() - passes_before},
                      {"turns", pass_ms.size()},
                      {"max_ms", Percentile(pass_ms, 1.0)},
                      {"median_ms", Percentile(pass_ms, 0.5)},
                      {"total_s", passes_clock.nsecsElapsed() * 1e-9}};
  return j;
}

// The picking layer: 25 picks over a 5 x 5 grid of the view.
nlohmann::json Picks(CloudView* view) {
  QElapsedTimer clock;
  clock.start();
  int hits = 0;
  std::vector<double> each_ms;
  const uint64_t page_ins_before = CloudPager::Default().page_ins();
  for (int i = 0; i < 25; ++i) {
    const QPoint at(view->width() * (1 + i % 5) / 6, view->height() * (1 + i / 5) / 6);
    Eigen::Vector3d world;
    QElapsedTimer one;
    one.start();
    hits += view->PickPoint(at, &world) ? 1 : 0;
    each_ms.push_back(one.nsecsElapsed() * 1e-6);
  }
  return {{"pick_ms", clock.nsecsElapsed() * 1e-6 / 25},
          {"pick_hits_of_25", hits},
          {"pick_max_ms", Percentile(each_ms, 1.0)},
          {"pick_page_ins", CloudPager::Default().page_ins() - page_ins_before}};
}

// From a Shift + click (the mouse event) to the frame that shows the pick's
// marker: the pick (on the view's pick thread), the calibration panel's
// pair list, the frame; and what the click held the GUI thread (taking the
// ray and the chunks for the pick: `gui_ms`).
nlohmann::json ClicksToMarker(MainWindow* window) {
  CloudView* view = window->view();
  std::vector<double> click_ms, gui_ms;
  for (int i = 0; i < 10; ++i) {
    const QPoint at(view->width() * (2 + i % 3) / 6, view->height() * (2 + i / 3 % 3) / 6);
    const size_t before = window->calibration_panel()->pair_points().size();
    QElapsedTimer click;
    click.start();
    QMouseEvent press(QEvent::MouseButtonPress, at, Qt::LeftButton, Qt::LeftButton,
                      Qt::ShiftModifier);
    QCoreApplication::sendEvent(view, &press);
    gui_ms.push_back(click.nsecsElapsed() * 1e-6);
    // The pick's result is posted to the GUI thread: an event wakes this.
    while (view->picks_in_flight() > 0) {
      QCoreApplication::processEvents(QEventLoop::AllEvents | QEventLoop::WaitForMoreEvents);
    }
    view->RenderIfDirty();
    if (window->calibration_panel()->pair_points().size() != before) {
      click_ms.push_back(click.nsecsElapsed() * 1e-6);
    }
  }
  return {{"median", Percentile(click_ms, 0.5)},
          {"max", Percentile(click_ms, 1.0)},
          {"clicks", click_ms.size()},
          {"gui_ms_max", Percentile(gui_ms, 1.0)}};
}

// The camera 2 m from the spot of the far end wall 1 m above the floor
// (the point of `points` nearest it; lo and hi the cloud's corners),
// looking towards the middle, drawn once; the spot. Floats for a session's
// motion points, doubles for a project's planned ones.
template <typename V>
V LookAtFarEnd(CloudView* view, const std::vector<V>& points, const V& lo, const V& hi) {
  using S = typename V::Scalar;
  const V aim(hi.x(), S(0.5) * (lo.y() + hi.y()), lo.z() + S(1));
  V spot = aim;
  S best = std::numeric_limits<S>::infinity();
  for (const V& p : points) {
    if ((p - aim).squaredNorm() < best) {
      best = (p - aim).squaredNorm();
      spot = p;
    }
  }
  V inward(S(0.5) * (lo.x() + hi.x()) - spot.x(), S(0.5) * (lo.y() + hi.y()) - spot.y(), S(0));
  inward.normalize();
  view->LookAt(spot.template cast<double>(),
               (spot + S(2) * inward + V(S(0), S(0), S(0.2))).template cast<double>());
  view->RenderNow();
  return spot;
}

// Zoomed in at rest (LookAtFarEnd of the motion points): the time to plan
// and build its rest level, the rest points drawn, and those within 0.3 m
// of the spot (how much of it is drawn).
nlohmann::json ZoomedIn(CloudView* view) {
  const std::vector<Eigen::Vector3f> motion = view->MotionPoints();
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e9f), hi = -lo;
  for (const Eigen::Vector3f& p : motion) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3f spot = LookAtFarEnd(view, motion, lo, hi);
  view->SetLodActive(true);
  QElapsedTimer clock;
  clock.start();
  view->SetLodActive(false);
  view->RenderNow();
  const double rest_s = clock.nsecsElapsed() * 1e-9;
  const std::vector<Eigen::Vector3f> drawn = view->DrawnPoints();
  const size_t at_spot =
      static_cast<size_t>(std::count_if(drawn.begin(), drawn.end(), [&](const Eigen::Vector3f& p) {
        return (p - spot).norm() < 0.3f;
      }));
  return {{"to_rest_s", rest_s}, {"rest_points", drawn.size()}, {"spot_points", at_spot}};
}

void PrintAndClose(const nlohmann::json& j, MainWindow* window) {
  std::printf("%s\n", j.dump().c_str());
  std::fflush(stdout);
  window->SetInteractive(false);
  window->close();
}

// The cloud fitted and drawn at rest once: the end of "open and show".
// Fitted first: the rest level is planned for the fitted camera (planned
// before, the view's render tick plans it again for the new one).
void ShowWhole(CloudView* view) {
  view->FitToCloud();
  view->SetLodActive(false);
  view->RenderNow();
}

}  // namespace

void StartOrbitBenchmark(int frames, Workspace* workspace, MainWindow* window) {
  auto clock = std::make_shared<QElapsedTimer>();
  clock->start();
  QObject::connect(workspace, &Workspace::replayFinished, window, [=] {
    // After the other slots of replayFinished and what the workspace does
    // after them (it lets go of a large session's samples).
    QTimer::singleShot(0, window, [=] {
      CloudView* view = window->view();
      // Let the GUI tick take the last batches before timing the first frame.
      const size_t expected = workspace->CloudSize();
      QElapsedTimer wait;
      wait.start();
      while (view->point_count() < expected && wait.elapsed() < 120000) {
        QCoreApplication::processEvents(QEventLoop::AllEvents, 20);
      }
      ShowWhole(view);
      nlohmann::json j = {{"points", view->point_count()},
                          {"open_and_show_s", clock->nsecsElapsed() * 1e-9}};
      // DrawnPoints() is the rest level's; the motion level's, its sample.
      j.update(OrbitAndRest(view, frames, [view] {
        return view->lod_active() ? view->motion_point_count() : view->DrawnPoints().size();
      }));
      j.update(Picks(view));
      j["click_to_highlight_ms"] = ClicksToMarker(window);
      // The memory read at the whole room's rest level, before the zoom.
      j["rss_mib"] = ResidentMiB();
      j["memory"] = MemoryBreakdown(window);
      j["zoomed"] = ZoomedIn(view);
      PrintAndClose(j, window);
    });
  });
}

// A project zoomed in at rest, as ZoomedIn for a session (LookAtFarEnd of
// the points planned for the whole view, in the drawn sessions' bounds):
// the time until the rest level planned for that camera is drawn, and the
// points drawn within 0.3 m of the spot against the sessions' points there.
nlohmann::json ProjectZoomedIn(CloudView* view, const ui::ProjectLayer* layer) {
  const Eigen::AlignedBox3d box = layer->drawn_bounds();
  const Eigen::Vector3d spot = LookAtFarEnd(view, layer->DetailPoints(), Eigen::Vector3d(box.min()),
                                            Eigen::Vector3d(box.max()));
  QElapsedTimer clock;
  clock.start();
  view->SetLodActive(true);
  view->SetLodActive(false);
  WaitForProjectDetail(layer, 60000);
  view->RenderNow();
  const double rest_s = clock.nsecsElapsed() * 1e-9;
  size_t at_spot = 0;
  for (const Eigen::Vector3d& p : layer->DetailPoints()) at_spot += (p - spot).norm() < 0.3;
  return {{"to_rest_s", rest_s},
          {"rest_points", view->layer_points_drawn()},
          {"spot_points", at_spot},
          {"spot_points_in_sessions", layer->PointsNear(spot, 0.3)}};
}

void StartProjectOrbitBenchmark(int frames, MainWindow* window) {
  auto clock = std::make_shared<QElapsedTimer>();
  clock->start();
  ui::ProjectController* project = window->project();
  // Until the open's jobs have built every placed, visible session's cloud
  // and the layer has handed its pieces to the view: polled, as busy() has
  // no signal. A placed, visible session not drawn then (its folder
  // unreadable: the app has said why), or none at all, gives no figure of
  // the project: said on stderr, exit 1; so does an open not done in 10
  // minutes.
  auto poll = new QTimer(window);
  QObject::connect(poll, &QTimer::timeout, window, [=] {
    const bool late = clock->elapsed() > 600000;
    if (project->busy() && !late) return;
    poll->stop();
    poll->deleteLater();
    size_t placed = 0;
    for (const ProjectSession& s : project->document()->project().sessions) {
      placed += s.project_from_session && s.visible ? 1 : 0;
    }
    const size_t drawn = project->layer()->drawn_sessions().size();
    if (late || drawn == 0 || drawn < placed) {
      std::fprintf(stderr,
                   "sweepscan: --orbit-benchmark: %zu of the project's %zu placed, visible "
                   "sessions drawn%s%s\n",
                   drawn, placed, late ? " after 10 minutes" : "",
                   window->last_error().isEmpty() ? "" : qPrintable(": " + window->last_error()));
      window->SetInteractive(false);
      window->close();
      QCoreApplication::exit(1);
      return;
    }
    CloudView* view = window->view();
    ShowWhole(view);
    // And the sessions' rest level planned for that camera on its thread.
    WaitForProjectDetail(project->layer(), 600000);
    view->RenderNow();
    nlohmann::json j = {{"sessions", drawn},
                        {"points", project->layer()->drawn_points()},
                        {"open_and_show_s", clock->nsecsElapsed() * 1e-9}};
    j.update(OrbitAndRest(view, frames, [view] { return view->layer_points_drawn(); }));
    j.erase("lod_level");  // The session cloud's grid; a project's motion level is a stride.
    j.update(Picks(view));
    j["zoomed"] = ProjectZoomedIn(view, project->layer());
    j["rss_mib"] = ResidentMiB();
    j["memory"] = MemoryBreakdown(window);
    // The layers' points in VTK's arrays: both levels (vtk_points is the
    // session cloud's).
    j["memory"]["layer_vtk_points"] = j["points"].get<size_t>() + j["lod_points"].get<size_t>();
    PrintAndClose(j, window);
  });
  poll->start(10);
}

void WaitForProjectDetail(const ui::ProjectLayer* layer, int timeout_ms) {
  // The loop sleeps until an event (the plan's result is posted to this
  // thread) or the tick that checks the timeout: one that never waited
  // took a core from the plan's own thread, which runs at nice 10.
  QTimer tick;
  tick.start(5);
  QElapsedTimer clock;
  clock.start();
  while (layer->detail_pending() && clock.elapsed() < timeout_ms) {
    QCoreApplication::processEvents(QEventLoop::AllEvents | QEventLoop::WaitForMoreEvents);
  }
}

}  // namespace sweepscan::app
