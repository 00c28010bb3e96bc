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

#include "app/gui_figures.h"
#include "app/gui_options.h"
#include "app/gui_tour.h"
#include "app/orbit_benchmark.h"
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
                     workspace->StartScriptedDrive(config.path,
                                                   QObject::tr("the scenario's path (%1)")
                                                       .arg(QString::fromStdString(config.name)));
                   });
  return true;
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
    // The pass split starts as a circle drive opens and may still run; one
    // job at a time, so the solve waits for the jobs to end (it was refused
    // as "still running" and never tried again).
    if (!workspace->job_running()) {
      panel->Solve();
      return;
    }
    auto waiting = std::make_shared<QMetaObject::Connection>();
    *waiting = QObject::connect(
        workspace, &Workspace::jobFinished, window,
        [workspace, panel, waiting] {
          if (workspace->job_running()) return;  // the finished job started another
          QObject::disconnect(*waiting);
          panel->Solve();
        },
        Qt::QueuedConnection);
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
  // Fitted first: the rest level is planned for the camera the images use.
  window->view()->FitToCloud();
  window->view()->SetLodActive(false);  // Every point in the images, not the thinned preview.
  // A project's sessions planned for that camera too (on their own thread).
  WaitForProjectDetail(window->project()->layer(), 10000);
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
    QStringList notes;
    Status s;
    // With a project shown and no session, the project's cloud (as File >
    // Export Cloud writes it then).
    if (workspace->CloudSize() == 0 && window->project()->document()->is_open()) {
      s = window->project()->ExportCloudNow(o.export_cloud, &notes);
    } else {
      std::string note;
      s = workspace->ExportCloudNow(o.export_cloud, &note);
      if (!note.empty()) notes << QString::fromStdString(note);
    }
    if (!s.ok()) {
      std::fprintf(stderr, "sweepscan: %s\n", s.message().c_str());
      exit_code = 1;
    }
    for (const QString& note : notes) {
      std::fprintf(stderr, "sweepscan: warning: %s: %s\n", qPrintable(o.export_cloud),
                   qPrintable(note));
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
//
// Two arenas, not glibc's eight a core: every thread that allocates (the
// GUI, the open's decoders and placer, llvmpipe's rasterizers, oneTBB's
// workers, Qt's) would get an arena of its own, each holding its own freed
// and, with huge pages (below), its own 2 MiB pages. At 9.5 M points that
// was 60 MiB: 501-507 MiB resident after the orbit benchmark with seven
// arenas, 441-444 with two, the open no slower (docs/performance.md,
// "Two heap arenas"). A thread keeps the arena it first took, and the lock
// is held for a block's bookkeeping only. An operator's MALLOC_ARENA_MAX
// is kept.
void KeepFreedMemoryForReuse() {
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's largest; blocks below it come from the heap.
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  mallopt(M_TOP_PAD, 64 << 20);
  if (std::getenv("MALLOC_ARENA_MAX") == nullptr) mallopt(M_ARENA_MAX, 2);
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
  // It measures an opened session or project; on nothing it would wait forever.
  if (o.orbit_frames > 0 && o.replay.isEmpty() && o.project.isEmpty()) {
    std::fprintf(stderr,
                 "sweepscan: --orbit-benchmark measures --replay SESSION or --project FILE: "
                 "give one\n");
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
  if (!o.project.isEmpty()) {
    // Its clock starts before the open.
    if (o.orbit_frames > 0 && o.replay.isEmpty())
      StartProjectOrbitBenchmark(o.orbit_frames, &window);
    if (!window.project()->OpenProject(o.project)) {
      std::fprintf(stderr, "sweepscan: %s\n", qPrintable(window.last_error()));
      if (scripted) return 2;
    }
  }
  // A session given as PATH replays at the panel's speed: --speed's.
  window.replay_panel()->SetSpeed(o.speed);
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
  // Follow the robot in demos: fit the view every few seconds (not in the
  // tours, nor in the orbit benchmark, whose cameras it would move between
  // their frames).
  if (scripted && o.tour.isEmpty() && o.pose_source_tour.isEmpty() && o.orbit_frames <= 0) {
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
