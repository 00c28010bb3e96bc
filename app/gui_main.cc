// sweepscan: the operator's desktop app. Thin: parses the command line,
// wires Workspace and MainWindow (ui/), and runs the demo options:
//   sweepscan [--simulate] [--scenario FILE] [--drive-demo] [--replay SESSION]
//             [--speed X] [--screenshot PATH] [--window-screenshot PATH]
//             [--export-cloud PATH] [--quit-after S] [--orbit-benchmark N]
//             [--pairs FILE [--calibration-tour DIR]]
//             [--pose-source ekf|odometry|sfm] [--pose-source-tour PNG]
//             [--memory-budget MIB] [--rest-budget N] [--lod-budget N] [--draw-pace N]
//             [--project FILE] [--floor-plan [--plan-height M]] [PATH]
// On quit after --quit-after it prints one JSON line (points, scans,
// link_state, session, frames_rendered, event-loop latency, memory).
#include <QVTKOpenGLNativeWidget.h>
#include <malloc.h>
#include <unistd.h>

#include <QApplication>
#include <QDir>
#include <QDoubleSpinBox>
#include <QElapsedTimer>
#include <QFile>
#include <QFileInfo>
#include <QMouseEvent>
#include <QScreen>
#include <QSettings>
#include <QSurfaceFormat>
#include <QThread>
#include <QTimer>
#include <algorithm>
#include <clocale>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "app/gui_options.h"
#include "app/gui_tour.h"
#include "core/cloud/cloud_io.h"
#include "core/cloud/cloud_pager.h"
#include "core/io/ros/ros_bag.h"
#include "core/scenario/scenario.h"
#include "ui/main_window.h"
#include "ui/panels/calibration_panel.h"
#include "ui/panels/connection_panel.h"
#include "ui/panels/replay_panel.h"
#include "ui/plan/plan_panel.h"
#include "ui/project/project_controller.h"
#include "ui/project/project_layer.h"
#include "ui/view/cloud_view.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::app {
namespace {

using ui::CloudView;
using ui::MainWindow;
using ui::Workspace;

// The scenarios' folder's parent: PREFIX/share/sweepscan when installed
// (the package: /usr/share/sweepscan), else the source tree's resources/.
QString ResourcesDir() {
  const QString bin = QCoreApplication::applicationDirPath();
  for (const QString& beside : {bin + QStringLiteral("/../share/sweepscan"), bin + QStringLiteral("/../resources")}) {
    if (QFileInfo::exists(beside + QStringLiteral("/scenarios"))) return QDir(beside).absolutePath();
  }
  return QStringLiteral(SWEEPSCAN_SOURCE_DIR "/resources");
}

// `sweepscan PATH`, as a file manager or a shell opens things: a session
// folder as File > Open Session, a project as File > Open Project, a ROS
// recording as File > Import ROS Recording. It was ignored without a word.
// What is none of them is said in a message, and the app stays open.
void OpenPathGiven(const QString& path, MainWindow* window) {
  const QFileInfo f(path);
  if (path.endsWith(QLatin1String(kProjectSuffix))) {
    window->project()->OpenProject(f.absoluteFilePath());  // Its errors are shown there.
  } else if (f.isDir() && QFileInfo::exists(f.absoluteFilePath() + QStringLiteral("/meta.json"))) {
    window->OpenSessionPath(f.absoluteFilePath());
  } else if (f.fileName() == QLatin1String("metadata.yaml") ||
             io::LooksLikeRosBag(QFile::encodeName(f.absoluteFilePath()).toStdString())) {
    // As the CLI tells a bag (a split ROS 2 folder without metadata.yaml too).
    window->ImportRosRecordingPath(f.absoluteFilePath());
  } else {
    window->ShowError(QObject::tr("Open"),
                      !f.exists() ? QObject::tr("%1 does not exist.").arg(path)
                                  : QObject::tr("%1 is not a sweepscan session (a folder with "
                                                "meta.json), a project (.sweepscan-project) or a "
                                                "ROS recording (.bag, .mcap, .db3, a ROS 2 bag "
                                                "folder).")
                                        .arg(path));
  }
}

// A field of /proc/self/status in MiB: VmRSS (resident now), VmHWM (peak).
double StatusMiB(const char* field) {
  QFile f(QStringLiteral("/proc/self/status"));
  if (!f.open(QIODevice::ReadOnly)) return 0.0;
  const QByteArray key = QByteArray(field) + ':';
  for (const QByteArray& line : f.readAll().split('\n')) {
    if (line.startsWith(key)) {
      return line.mid(key.size()).trimmed().split(' ')[0].toDouble() / 1024.0;
    }
  }
  return 0.0;
}
double ResidentMiB() { return StatusMiB("VmRSS"); }

// Where the memory is: the cloud store's resident payloads, the points in
// VTK's arrays (both levels), the C++ heap in use and free (kept by malloc
// for reuse), the resident set's anonymous and file-backed parts (the
// libraries, mapped files), and how often the view waited for the driver
// (--draw-pace).
nlohmann::json MemoryBreakdown(MainWindow* window) {
  const struct mallinfo2 heap = mallinfo2();
  return {{"store_mib", CloudPager::Default().resident_bytes() / 1048576.0},
          {"store_unpacked_mib", CloudPager::Default().unpacked_bytes() / 1048576.0},
          {"store_paged_out_chunks", CloudPager::Default().paged_out_chunks()},
          {"vtk_points", window->view()->vtk_point_count()},
          {"heap_in_use_mib", (heap.uordblks + heap.hblkhd) / 1048576.0},
          {"heap_free_mib", heap.fordblks / 1048576.0},
          {"rss_anon_mib", StatusMiB("RssAnon")},
          {"rss_file_mib", StatusMiB("RssFile")},
          {"peak_rss_mib", StatusMiB("VmHWM")},
          {"draw_waits", window->view()->draw_waits()}};
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5))];
}

// --drive-demo: record and drive the scenario's path once the link is up.
bool StartDriveDemo(const Options& o, Workspace* workspace, MainWindow* window) {
  sim::SimConfig config;
  const Status s = LoadScenario(o.scenario.toStdString(), &config);
  if (!s.ok()) {
    std::fprintf(stderr, "sweepscan: %s\n", s.message().c_str());
    return false;
  }
  auto started = std::make_shared<bool>(false);
  QObject::connect(workspace, &Workspace::authenticatedChanged, window,
                   [workspace, window, config, started](bool ok) {
                     if (!ok || *started) return;
                     *started = true;
                     QString error;
                     if (!workspace->StartRecording(&error)) window->ShowError("Record", error);
                     workspace->StartScriptedDrive(config.path);
                   });
  return true;
}

// --orbit-benchmark N: time to open and show the session, then frames per
// second while the camera orbits at the rest level planned for the first
// camera ("fps_full": every point when the cloud is within the rest budget)
// and at the motion level ("fps_lod"), the time back to the rest level for
// the last camera, picks, and where the memory is.
void StartOrbitBenchmark(int frames, Workspace* workspace, MainWindow* window) {
  auto clock = std::make_shared<QElapsedTimer>();
  clock->start();
  QObject::connect(workspace, &Workspace::replayFinished, window, [=] {
   // After the other slots of replayFinished and what the workspace does
   // after them (it lets go of a large session's samples).
   QTimer::singleShot(0, window, [=] {
    // Let the GUI tick take the last batches before timing the first frame.
    const size_t expected = workspace->CloudSize();
    QElapsedTimer wait;
    wait.start();
    while (window->view()->point_count() < expected && wait.elapsed() < 120000) {
      QCoreApplication::processEvents(QEventLoop::AllEvents, 20);
    }
    window->view()->SetLodActive(false);
    window->view()->FitToCloud();
    window->view()->RenderNow();
    const double open_s = clock->nsecsElapsed() * 1e-9;
    // A frame's two halves: VTK's render into the widget's framebuffer, and
    // the events after it, where Qt paints the widget and presents it.
    double render_ms = 0.0, present_ms = 0.0;
    auto fps = [&](bool lod) {
      window->view()->SetLodActive(lod);
      QElapsedTimer t, part;
      t.start();
      render_ms = present_ms = 0.0;
      for (int i = 0; i < frames; ++i) {
        window->view()->Orbit(360.0 / frames);
        part.start();
        window->view()->RenderNow();
        render_ms += part.nsecsElapsed() * 1e-6 / frames;
        part.start();
        QCoreApplication::processEvents();
        present_ms += part.nsecsElapsed() * 1e-6 / frames;
      }
      return frames / (t.nsecsElapsed() * 1e-9);
    };
    const double full = fps(false);
    const double lod = fps(true);
    const double lod_render_ms = render_ms, lod_present_ms = present_ms;
    const int lod_level = window->view()->lod_level();
    const size_t lod_points = window->view()->motion_point_count();
    // Back at rest: the rest level planned and built for the new camera.
    QElapsedTimer rest_clock;
    rest_clock.start();
    window->view()->SetLodActive(false);
    window->view()->RenderNow();
    const double rest_s = rest_clock.nsecsElapsed() * 1e-9;
    const size_t rest_points = window->view()->DrawnPoints().size();
    // The same rest level in one frame, and in progressive passes as the
    // GUI's timer draws them: the passes (pass 0 included) and the
    // event-loop turns that drew (a pass, or Qt's paint of the widget).
    QElapsedTimer frame_clock;
    frame_clock.start();
    window->view()->RenderNow();
    QCoreApplication::processEvents();
    const double rest_frame_ms = frame_clock.nsecsElapsed() * 1e-6;
    std::vector<double> pass_ms;
    QElapsedTimer passes_clock;
    passes_clock.start();
    const uint64_t passes_before = window->view()->passes_drawn();
    window->view()->RequestRender();
    do {
      const uint64_t frames = window->view()->frames_rendered();
      QElapsedTimer turn;
      turn.start();
      QCoreApplication::processEvents();
      if (window->view()->frames_rendered() != frames) pass_ms.push_back(turn.nsecsElapsed() * 1e-6);
    } while (window->view()->drawing_passes() || pass_ms.empty());
    const double passes_s = passes_clock.nsecsElapsed() * 1e-9;
    // The picking layer: 25 picks over a 5 x 5 grid of the view.
    QElapsedTimer pick_clock;
    pick_clock.start();
    int hits = 0;
    std::vector<double> each_pick_ms;
    const uint64_t page_ins_before = CloudPager::Default().page_ins();
    for (int i = 0; i < 25; ++i) {
      const QPoint at(window->view()->width() * (1 + i % 5) / 6,
                      window->view()->height() * (1 + i / 5) / 6);
      Eigen::Vector3d world;
      QElapsedTimer one;
      one.start();
      hits += window->view()->PickPoint(at, &world) ? 1 : 0;
      each_pick_ms.push_back(one.nsecsElapsed() * 1e-6);
    }
    const double pick_ms = pick_clock.nsecsElapsed() * 1e-6 / 25;
    const uint64_t pick_page_ins = CloudPager::Default().page_ins() - page_ins_before;
    // From a Shift + click (the mouse event) to the frame that shows the
    // pick's marker: picking, the calibration panel's pair list, the frame.
    std::vector<double> click_ms;
    for (int i = 0; i < 10; ++i) {
      const QPoint at(window->view()->width() * (2 + i % 3) / 6,
                      window->view()->height() * (2 + i / 3 % 3) / 6);
      const size_t before = window->calibration_panel()->pair_points().size();
      QElapsedTimer click;
      click.start();
      QMouseEvent press(QEvent::MouseButtonPress, at, Qt::LeftButton, Qt::LeftButton,
                        Qt::ShiftModifier);
      QCoreApplication::sendEvent(window->view(), &press);
      window->view()->RenderIfDirty();
      if (window->calibration_panel()->pair_points().size() != before) {
        click_ms.push_back(click.nsecsElapsed() * 1e-6);
      }
    }
    nlohmann::json j = {{"points", window->view()->point_count()},
                        {"open_and_show_s", open_s},
                        {"fps_full", full},
                        {"fps_lod", lod},
                        {"lod_level", lod_level},
                        {"lod_points", lod_points},
                        {"lod_frame_ms", {{"render", lod_render_ms}, {"present", lod_present_ms}}},
                        {"to_rest_s", rest_s},
                        {"rest_points", rest_points},
                        {"rest_frame_ms", rest_frame_ms},
                        {"rest_passes",
                         {{"passes", window->view()->passes_drawn() - passes_before},
                          {"turns", pass_ms.size()},
                          {"max_ms", Percentile(pass_ms, 1.0)},
                          {"median_ms", Percentile(pass_ms, 0.5)},
                          {"total_s", passes_s}}},
                        {"pick_ms", pick_ms},
                        {"pick_hits_of_25", hits},
                        {"pick_max_ms", Percentile(each_pick_ms, 1.0)},
                        {"pick_page_ins", pick_page_ins},
                        {"click_to_highlight_ms",
                         {{"median", Percentile(click_ms, 0.5)},
                          {"max", Percentile(click_ms, 1.0)},
                          {"clicks", click_ms.size()}}},
                        {"rss_mib", ResidentMiB()},
                        {"memory", MemoryBreakdown(window)}};
    // Then (after the memory, read at the whole room's rest level as before)
    // zoomed in at rest: the spot of the far end wall 1 m above the floor
    // (the motion point nearest it) looked at from 2 m towards the middle:
    // the time to plan and build its rest level, the rest points drawn, and
    // those within 0.3 m of the spot (how much of it is drawn).
    const std::vector<Eigen::Vector3f> motion = window->view()->MotionPoints();
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e9f), hi = -lo;
    for (const Eigen::Vector3f& p : motion) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    const Eigen::Vector3f aim(hi.x(), 0.5f * (lo.y() + hi.y()), lo.z() + 1.0f);
    Eigen::Vector3f spot = aim;
    for (const Eigen::Vector3f& p : motion) {
      if (spot == aim || (p - aim).squaredNorm() < (spot - aim).squaredNorm()) spot = p;
    }
    Eigen::Vector3f inward(0.5f * (lo.x() + hi.x()) - spot.x(), 0.5f * (lo.y() + hi.y()) - spot.y(),
                           0.0f);
    inward.normalize();
    window->view()->LookAt(spot.cast<double>(),
                           (spot + 2.0f * inward + Eigen::Vector3f(0, 0, 0.2f)).cast<double>());
    window->view()->RenderNow();
    window->view()->SetLodActive(true);
    QElapsedTimer zoom_clock;
    zoom_clock.start();
    window->view()->SetLodActive(false);
    window->view()->RenderNow();
    const double zoom_rest_s = zoom_clock.nsecsElapsed() * 1e-9;
    const std::vector<Eigen::Vector3f> zoom_drawn = window->view()->DrawnPoints();
    const size_t zoom_spot = static_cast<size_t>(
        std::count_if(zoom_drawn.begin(), zoom_drawn.end(),
                      [&](const Eigen::Vector3f& p) { return (p - spot).norm() < 0.3f; }));
    j["zoomed"] = {{"to_rest_s", zoom_rest_s},
                   {"rest_points", zoom_drawn.size()},
                   {"spot_points", zoom_spot}};
    std::printf("%s\n", j.dump().c_str());
    std::fflush(stdout);
    window->SetInteractive(false);
    window->close();
   });
  });
}

// --pairs FILE: load the picks once the session is shown, solve, and show
// the calibrated cloud (demos and docs screenshots).
void StartCalibrationDemo(const QString& pairs, Workspace* workspace, MainWindow* window) {
  auto done = std::make_shared<bool>(false);
  QObject::connect(workspace, &Workspace::replayFinished, window, [=] {
    if (*done) return;
    *done = true;
    ui::CalibrationPanel* panel = window->calibration_panel();
    QString error;
    if (!panel->LoadPairs(pairs, &error)) {
      window->ShowError("Pairs", error);
      return;
    }
    QObject::connect(panel, &ui::CalibrationPanel::solved, window, [panel, window](bool ok) {
      if (!ok) return;
      panel->ShowAfter(true);
      // The target stands inside the room: look at it from above, under the ceiling.
      window->view()->SetClipHeight(2.0);
      window->view()->ViewOblique();
    });
    panel->Solve();
  });
}

// The --seek benchmark: from the seek's request until the replay stands at
// its target (< 0: not there, or no seek).
struct SeekClock {
  QElapsedTimer clock;
  double ms = -1.0;
};

// --quit-after: stop recording, let the last scans arrive, write what was
// asked for, print the summary line and close. Returns 1 if a file failed.

int FinishAndSummarize(const Options& o, Workspace* workspace, MainWindow* window,
                       const SeekClock& seek) {
  int exit_code = 0;
  // The run's event-loop latencies, not the waits below (three turns 70-90 ms late).
  const std::vector<double> latency = window->tick_latencies_ms();
  if (workspace->recording()) {
    QString error;
    workspace->StopRecording(&error);
  }
  for (int i = 0; i < 3; ++i) {  // The processing thread places the last scans.
    QThread::msleep(100);
    QCoreApplication::processEvents();
  }
  window->view()->SetLodActive(false);  // Every point in the images, not the thinned preview.
  window->view()->FitToCloud();
  QString error;
  if (!o.screenshot.isEmpty() && !window->view()->SaveScreenshot(o.screenshot, &error)) {
    std::fprintf(stderr, "sweepscan: %s\n", qPrintable(error));
    exit_code = 1;
  }
  if (!o.window_screenshot.isEmpty()) {
    window->view()->RenderNow();
    if (!window->grab().save(o.window_screenshot)) {
      std::fprintf(stderr, "sweepscan: %s: cannot write the image\n",
                   qPrintable(o.window_screenshot));
      exit_code = 1;
    }
  }
  if (!o.export_cloud.isEmpty()) {
    const Status s = SaveCloud(o.export_cloud.toStdString(), workspace->CloudSnapshot());
    if (!s.ok()) {
      std::fprintf(stderr, "sweepscan: %s\n", s.message().c_str());
      exit_code = 1;
    }
  }
  const nlohmann::json j = {
      {"points", workspace->CloudSize()},
      {"points_shown", window->view()->point_count()},
      {"project_points_drawn", window->project()->layer()->drawn_points()},
      {"scans", workspace->scan_count()},
      {"link_state", hardware::LinkHealth::StateName(workspace->health().state)},
      {"authenticated", workspace->authenticated()},
      {"session", workspace->session_dir().toStdString()},
      {"frames_rendered", window->view()->frames_rendered()},
      {"event_loop_latency_ms",
       {{"p50", Percentile(latency, 0.5)},
        {"p99", Percentile(latency, 0.99)},
        {"max", latency.empty() ? 0.0 : *std::max_element(latency.begin(), latency.end())}}},
      {"insertion_ms", window->insertion_ms()},
      {"seek_ms", seek.ms},
      {"rss_mib", ResidentMiB()},
      {"memory", MemoryBreakdown(window)},
      {"last_error", window->last_error().toStdString()}};
  std::printf("%s\n", j.dump().c_str());
  std::fflush(stdout);
  window->close();
  return exit_code;
}

void SetApplicationNames() {
  QCoreApplication::setOrganizationName(QStringLiteral("sweepscan"));
  QCoreApplication::setApplicationName(QStringLiteral("sweepscan"));
  QCoreApplication::setApplicationVersion(QStringLiteral("0.1.0"));
}

bool AsksForHelpOrVersion(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h" || a == "-?" || a == "--help-all" || a == "--version" || a == "-v") {
      return true;
    }
  }
  return false;
}

// Qt finds a display through one of these; without any, QApplication aborts
// with a paragraph about platform plugins.
bool HasDisplay() {
  return !qEnvironmentVariableIsEmpty("DISPLAY") || !qEnvironmentVariableIsEmpty("WAYLAND_DISPLAY") ||
         !qEnvironmentVariableIsEmpty("QT_QPA_PLATFORM");
}

// Keeps freed heap memory for reuse instead of handing it back after every
// free. Mesa's llvmpipe allocates its vertex and binning buffers for each
// draw and frees them after it (megabytes a frame); glibc's defaults (the
// heap trimmed once 128 KiB-32 MiB is free at its top, larger blocks mapped
// and unmapped each time) made each frame fault those pages in afresh,
// which on a virtual machine cost up to four fifths of a frame: a 221 000-
// point view drew 3.6 frames/s, 20 with these settings (docs/performance.md,
// "Desktop app"). Memory is still given back where it matters: the pager
// and the workspace call malloc_trim after dropping chunks or a session, the
// view when it has drawn its last pass at rest.
void KeepFreedMemoryForReuse() {
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's largest; blocks below it come from the heap.
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  mallopt(M_TOP_PAD, 64 << 20);
}

// Transparent huge pages for the heap. Opening a 100 M-point session
// fills a 1.9 GB cloud store with fresh memory, and a fresh page costs a
// fault: on the 2-core VM of docs/performance.md that was about a third of
// the placing thread's time, and with the heap in 2 MiB pages
// (glibc.malloc.hugetlb=1: malloc madvises its heaps MADV_HUGEPAGE, glibc
// 2.35 and later) the open took 18.8-20.6 s instead of 24.0-24.4. glibc
// reads its tunables once, from the environment, before main: so the app
// adds the tunable and executes itself again, once (the variable is then
// present). An operator's own GLIBC_TUNABLES is kept; one that sets hugetlb,
// or SWEEPSCAN_NO_HUGEPAGES=1, leaves the process as it is. Where the
// kernel's THP mode is "never" the tunable changes nothing.
void UseHugePagesForTheHeap(char** argv) {
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  if (tunables != nullptr && std::strstr(tunables, "glibc.malloc.hugetlb") != nullptr) return;
  if (std::getenv("SWEEPSCAN_NO_HUGEPAGES") != nullptr) return;
  std::string value = "glibc.malloc.hugetlb=1";
  if (tunables != nullptr && *tunables != '\0') value = std::string(tunables) + ":" + value;
  // The binary's own path, not /proc/self/exe: the process keeps its name
  // ("sweepscan" in ps, top and pkill, not "exe").
  char self[4096];
  const ssize_t n = readlink("/proc/self/exe", self, sizeof(self) - 1);
  if (n <= 0) return;
  self[n] = '\0';
  if (setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  execv(self, argv);
  // Not replaced: on with 4 KiB pages, and no tunable for children.
  if (tunables != nullptr) {
    setenv("GLIBC_TUNABLES", tunables, 1);
  } else {
    unsetenv("GLIBC_TUNABLES");
  }
}

int Main(int argc, char** argv) {
  // --help and --version need no window: answered without a display (an
  // operator asking over ssh), as QCommandLineParser prints them and exits.
  if (AsksForHelpOrVersion(argc, argv)) {
    QCoreApplication core(argc, argv);
    SetApplicationNames();
    ParseOptions(core, ResourcesDir());
    return 0;
  }
  if (!HasDisplay()) {
    std::fprintf(stderr,
                 "sweepscan: no display (DISPLAY is not set): run it on a desktop, over ssh -X, or under "
                 "xvfb-run; sweepscan-cli does the processing without one\n");
    return 2;
  }
  UseHugePagesForTheHeap(argv);
  KeepFreedMemoryForReuse();
  QSurfaceFormat::setDefaultFormat(QVTKOpenGLNativeWidget::defaultFormat());
  QApplication app(argc, argv);
  // QApplication set every category to the user's locale; numbers in files
  // and in what printf / strtod read and write stay C's (Qt's advice). The
  // panels show numbers through QLocale, which this does not change.
  std::setlocale(LC_NUMERIC, "C");
  SetApplicationNames();
  // Wayland desktops match the window to packaging/sweepscan.desktop by this.
  QGuiApplication::setDesktopFileName(QStringLiteral("sweepscan"));
  const QString resources = ResourcesDir();
  const Options o = ParseOptions(app, resources);

  if (!o.bad_arguments.isEmpty() || (!o.open_path.isEmpty() && !o.replay.isEmpty())) {
    std::fprintf(stderr, "sweepscan: one PATH to open, and not beside --replay (see --help)\n");
    return 2;
  }
  if (!o.bad_number.isEmpty()) {
    std::fprintf(stderr, "sweepscan: %s is not a number the option takes (see --help)\n",
                 qPrintable(o.bad_number));
    return 2;
  }
  if (o.memory_budget_mib >= 0) {
    CloudPager::Default().SetBudget(static_cast<size_t>(o.memory_budget_mib * 1048576.0));
  }
  Workspace workspace;
  MainWindow window(&workspace, resources);
  if (o.rest_budget > 0) window.view()->SetRestBudget(static_cast<size_t>(o.rest_budget));
  if (o.draw_pace >= 0) window.view()->SetDrawPace(static_cast<size_t>(o.draw_pace));
  if (o.lod_budget > 0) window.view()->SetLodBudget(static_cast<size_t>(o.lod_budget));
  // After the window has restored its settings (which hold the folder the
  // operator chose last), so that the command line wins.
  if (!o.sessions_dir.isEmpty()) workspace.set_sessions_root(o.sessions_dir);
  if (o.seek_s < -1.5) {
    std::fprintf(stderr,
                 "sweepscan: --seek takes seconds from the session's start (a number >= 0)\n");
    return 2;
  }
  if (!o.pose_source.isEmpty()) {
    PoseSource source;
    if (!ParsePoseSource(o.pose_source.toStdString(), &source) || source == PoseSource::kTruth) {
      std::fprintf(stderr, "sweepscan: --pose-source must be ekf, odometry or sfm, got '%s'\n",
                   qPrintable(o.pose_source));
      return 2;
    }
    workspace.SetPoseSource(source);
  }
  const bool scripted = o.quit_after_s >= 0 || o.orbit_frames > 0 || !o.tour.isEmpty() ||
                        !o.pose_source_tour.isEmpty();
  window.SetInteractive(!scripted);
  if (scripted) window.ResetLayout();
  // The size the operator left it at (MainWindow restored it), else 1400 x
  // 860 within the screen; scripted runs (benchmarks, screenshots) always
  // get the same size.
  if (scripted || !QSettings().contains(QStringLiteral("window/geometry"))) {
    QSize size(1400, 860);
    if (!scripted && window.screen() != nullptr) {
      size = size.boundedTo(window.screen()->availableGeometry().size());
    }
    window.resize(size);
  }
  window.show();

  if (o.simulate || o.drive_demo) {
    ui::ConnectOptions c = window.connection_panel()->options();
    c.kind = ui::LinkKind::kSimulator;
    c.scenario_path = o.scenario;
    window.connection_panel()->SetOptions(c);
    QString error;
    if (!window.connection_panel()->ConnectNow(&error)) {
      std::fprintf(stderr, "sweepscan: %s\n", qPrintable(error));
      return 2;
    }
  }
  if (o.drive_demo && !StartDriveDemo(o, &workspace, &window)) return 2;
  // A project that cannot be opened: a scripted run (benchmark, tour) stops
  // with exit 2; the operator has read its box, and the app stays open,
  // as for a path given without --project (OpenPathGiven).
  if (!o.project.isEmpty() && !window.project()->OpenProject(o.project)) {
    std::fprintf(stderr, "sweepscan: %s\n", qPrintable(window.last_error()));
    if (scripted) return 2;
  }
  if (!o.open_path.isEmpty()) OpenPathGiven(o.open_path, &window);
  if (o.floor_plan) {
    if (o.plan_height_m > 0) window.plan_panel()->height_box()->setValue(o.plan_height_m);
    window.RaiseDock(QStringLiteral("planDock"));
  }
  SeekClock seek;
  if (!o.replay.isEmpty()) {
    window.replay_panel()->SetSpeed(o.speed);
    if (o.orbit_frames > 0) StartOrbitBenchmark(o.orbit_frames, &workspace, &window);
    if (o.seek_s >= 0) {
      // The seek's time: until the replay stands at the target.
      QObject::connect(&workspace, &Workspace::replayProgress, &window,
                       [&](double position_s, double length_s) {
                         if (seek.clock.isValid() && seek.ms < 0 &&
                             position_s >= std::min(o.seek_s, length_s) - 1e-6) {
                           seek.ms = seek.clock.nsecsElapsed() * 1e-6;
                         }
                       });
      // Once, after the open's own replayFinished slots have run.
      auto sought = std::make_shared<bool>(false);
      QObject::connect(&workspace, &Workspace::replayFinished, &window, [&, sought] {
        if (*sought) return;
        *sought = true;
        QTimer::singleShot(0, &window, [&] {
          window.ClearTickFigures();
          // After the target: on at 1x, not flooding the view.
          window.replay_panel()->SetSpeed(1.0);
          seek.clock.start();
          workspace.SeekReplay(o.seek_s);
        });
      });
    }
    if (!o.pose_source_tour.isEmpty()) {
      StartPoseSourceTour(o.pose_source_tour, &workspace, &window);
    } else if (!o.tour.isEmpty() && !o.pairs.isEmpty()) {
      StartCalibrationTour(o.pairs, o.tour, &workspace, &window);
    } else if (!o.pairs.isEmpty()) {
      StartCalibrationDemo(o.pairs, &workspace, &window);
    }
    workspace.OpenSession(o.replay, o.speed);
  }
  // Follow the robot in demos: fit the view every few seconds (not in the tours).
  if (scripted && o.tour.isEmpty() && o.pose_source_tour.isEmpty()) {
    auto* fit = new QTimer(&window);
    QObject::connect(fit, &QTimer::timeout, window.view(), &CloudView::FitToCloud);
    fit->start(3000);
  }
  int exit_code = 0;
  if (o.quit_after_s >= 0) {
    QTimer::singleShot(static_cast<int>(o.quit_after_s * 1000.0), &window,
                       [&] { exit_code = FinishAndSummarize(o, &workspace, &window, seek); });
  }
  const int rc = app.exec();
  return exit_code != 0 ? exit_code : rc;
}

}  // namespace
}  // namespace sweepscan::app

int main(int argc, char** argv) { return sweepscan::app::Main(argc, argv); }
