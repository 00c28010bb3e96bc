// --orbit-benchmark N: the view's figures on a session or a project
// (docs/performance.md; scripts/gui-bench.sh). Each prints one JSON line
// and closes the window.
#ifndef SWEEPSCAN_APP_ORBIT_BENCHMARK_H_
#define SWEEPSCAN_APP_ORBIT_BENCHMARK_H_

namespace sweepscan::ui {
class MainWindow;
class ProjectLayer;
class Workspace;
}  // namespace sweepscan::ui

namespace sweepscan::app {

// With --replay SESSION: the time to open and show the session, then frames
// per second while the camera orbits at the rest level planned for the
// first camera ("fps_full": every point when the cloud is within the rest
// budget) and at the motion level ("fps_lod"), the time back to the rest
// level for the last camera and its progressive passes, picks, a Shift +
// click to its marker, where the memory is, and the rest level zoomed in.
void StartOrbitBenchmark(int frames, ui::Workspace* workspace, ui::MainWindow* window);

// With --project FILE: the same once every placed session's cloud is drawn
// (the project's layers: "points" are the points the rest level draws,
// "lod_points" the motion level's), without the clicks (they pick for the
// calibration panel, a session's); the zoom waits for the sessions' rest
// level planned for it.
void StartProjectOrbitBenchmark(int frames, ui::MainWindow* window);

// Runs the event loop until the project's rest level planned on its thread
// is shown (ProjectLayer::detail_pending), at most `timeout_ms`: what a
// scripted run's figures and pictures wait for.
void WaitForProjectDetail(const ui::ProjectLayer* layer, int timeout_ms);

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_ORBIT_BENCHMARK_H_
