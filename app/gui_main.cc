// sweepscan: the operator's desktop app. Thin: parses the command line,
// wires Workspace and MainWindow (ui/), and runs the demo options:
//   sweepscan [--simulate] [--scenario FILE] [--drive-demo] [--replay SESSION]
//             [--speed X] [--screenshot PATH] [--export-cloud PATH] [--quit-after S]
// On quit after a demo option it prints one JSON line (points, scans,
// link_state, session, frames_rendered, ...).
#include <QApplication>
#include <QCommandLineParser>
#include <QDir>
#include <QFileInfo>
#include <QSurfaceFormat>
#include <QTimer>
#include <QVTKOpenGLNativeWidget.h>
#include <algorithm>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "core/cloud/cloud_io.h"
#include "core/scenario/scenario.h"
#include "ui/main_window.h"
#include "ui/panels/connection_panel.h"
#include "ui/panels/replay_panel.h"
#include "ui/view/cloud_view.h"
#include "ui/workspace/workspace.h"

namespace {

// resources/: next to the executable's install prefix, else the source tree.
QString ResourcesDir() {
  const QString beside = QCoreApplication::applicationDirPath() + QStringLiteral("/../resources");
  if (QFileInfo::exists(beside + QStringLiteral("/scenarios"))) return QDir(beside).absolutePath();
  return QStringLiteral(SWEEPSCAN_SOURCE_DIR "/resources");
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5))];
}

}  // namespace

int main(int argc, char** argv) {
  QSurfaceFormat::setDefaultFormat(QVTKOpenGLNativeWidget::defaultFormat());
  QApplication app(argc, argv);
  QCoreApplication::setOrganizationName(QStringLiteral("sweepscan"));
  QCoreApplication::setApplicationName(QStringLiteral("sweepscan"));
  QCoreApplication::setApplicationVersion(QStringLiteral("0.1.0"));

  QCommandLineParser parser;
  parser.setApplicationDescription(QStringLiteral(
      "Operator workstation for mobile 3D lidar scanning: connect, drive, watch the cloud grow, "
      "record, replay, export."));
  parser.addHelpOption();
  parser.addVersionOption();
  const QCommandLineOption simulate(QStringLiteral("simulate"),
                                    "Connect to the built-in simulated robot at start.");
  const QCommandLineOption scenario(QStringLiteral("scenario"),
                                    "Scenario of the simulated robot (default: resources/scenarios/lab.json).",
                                    QStringLiteral("FILE"));
  const QCommandLineOption drive_demo(
      QStringLiteral("drive-demo"),
      "Record and drive the scenario's path with the same drive commands the keyboard sends.");
  const QCommandLineOption replay(QStringLiteral("replay"), "Open and replay a session folder.",
                                  QStringLiteral("SESSION"));
  const QCommandLineOption speed(QStringLiteral("speed"),
                                 "Replay speed: 1 to 20, or 0 for as fast as possible (default 0).",
                                 QStringLiteral("X"), QStringLiteral("0"));
  const QCommandLineOption screenshot(QStringLiteral("screenshot"),
                                      "Save the view as PNG just before quitting.",
                                      QStringLiteral("PATH"));
  const QCommandLineOption window_shot(QStringLiteral("window-screenshot"),
                                       "Save the whole window as PNG just before quitting.",
                                       QStringLiteral("PATH"));
  const QCommandLineOption export_cloud(QStringLiteral("export-cloud"),
                                        "Write the cloud (PLY or PCD) just before quitting.",
                                        QStringLiteral("PATH"));
  const QCommandLineOption quit_after(QStringLiteral("quit-after"),
                                      "Quit after S seconds (prints a JSON summary line).",
                                      QStringLiteral("S"));
  const QCommandLineOption sessions(QStringLiteral("sessions-dir"),
                                    "Where new recordings go (default: ~/sweepscan-sessions).",
                                    QStringLiteral("DIR"));
  parser.addOptions(
      {simulate, scenario, drive_demo, replay, speed, screenshot, window_shot, export_cloud, quit_after,
       sessions});
  parser.process(app);

  const QString resources = ResourcesDir();
  sweepscan::ui::Workspace workspace;
  if (parser.isSet(sessions)) workspace.set_sessions_root(parser.value(sessions));
  sweepscan::ui::MainWindow window(&workspace, resources);
  const bool scripted = parser.isSet(quit_after);
  window.SetInteractive(!scripted);
  window.resize(1400, 860);
  window.show();

  const QString scenario_path = parser.isSet(scenario)
                                    ? parser.value(scenario)
                                    : resources + QStringLiteral("/scenarios/lab.json");
  if (parser.isSet(simulate) || parser.isSet(drive_demo)) {
    sweepscan::ui::ConnectOptions o = window.connection_panel()->options();
    o.kind = sweepscan::ui::LinkKind::kSimulator;
    o.scenario_path = scenario_path;
    window.connection_panel()->SetOptions(o);
    QString error;
    if (!window.connection_panel()->ConnectNow(&error)) {
      std::fprintf(stderr, "sweepscan: %s\n", qPrintable(error));
      return 2;
    }
  }
  if (parser.isSet(drive_demo)) {
    sweepscan::sim::SimConfig config;
    const sweepscan::Status s = sweepscan::LoadScenario(scenario_path.toStdString(), &config);
    if (!s.ok()) {
      std::fprintf(stderr, "sweepscan: %s\n", s.message().c_str());
      return 2;
    }
    // Record and drive once the link is up.
    auto started = std::make_shared<bool>(false);
    QObject::connect(&workspace, &sweepscan::ui::Workspace::authenticatedChanged, &window,
                     [&workspace, &window, config, started](bool ok) {
                       if (!ok || *started) return;
                       *started = true;
                       QString error;
                       if (!workspace.StartRecording(&error)) window.ShowError("Record", error);
                       workspace.StartScriptedDrive(config.path);
                     });
  }
  if (parser.isSet(replay)) {
    window.replay_panel()->SetSpeed(parser.value(speed).toDouble());
    workspace.OpenSession(parser.value(replay), parser.value(speed).toDouble());
  }
  // Follow the robot in the demo: fit the view every few seconds.
  if (scripted) {
    auto* fit = new QTimer(&window);
    QObject::connect(fit, &QTimer::timeout, window.view(), &sweepscan::ui::CloudView::FitToCloud);
    fit->start(3000);
  }

  int exit_code = 0;
  if (parser.isSet(quit_after)) {
    const int ms = static_cast<int>(parser.value(quit_after).toDouble() * 1000.0);
    QTimer::singleShot(ms, &window, [&] {
      if (workspace.recording()) {
        QString error;
        workspace.StopRecording(&error);
      }
      // The replay or drive may still hold scans: let the processing thread
      // finish them and the view take them.
      QThread::msleep(200);
      QCoreApplication::processEvents();
      QThread::msleep(100);
      QCoreApplication::processEvents();
      window.view()->FitToCloud();
      QString error;
      if (parser.isSet(screenshot) && !window.view()->SaveScreenshot(parser.value(screenshot), &error)) {
        std::fprintf(stderr, "sweepscan: %s\n", qPrintable(error));
        exit_code = 1;
      }
      if (parser.isSet(window_shot)) {
        window.view()->RenderNow();
        if (!window.grab().save(parser.value(window_shot))) {
          std::fprintf(stderr, "sweepscan: %s: cannot write the image\n",
                       qPrintable(parser.value(window_shot)));
          exit_code = 1;
        }
      }
      const std::vector<sweepscan::CloudPoint> cloud = workspace.CloudSnapshot();
      if (parser.isSet(export_cloud)) {
        const sweepscan::Status s = sweepscan::SaveCloud(parser.value(export_cloud).toStdString(), cloud);
        if (!s.ok()) {
          std::fprintf(stderr, "sweepscan: %s\n", s.message().c_str());
          exit_code = 1;
        }
      }
      const auto& lat = window.tick_latencies_ms();
      nlohmann::json j = {
          {"points", cloud.size()},
          {"points_shown", window.view()->point_count()},
          {"scans", workspace.scan_count()},
          {"link_state", sweepscan::hardware::LinkHealth::StateName(workspace.health().state)},
          {"authenticated", workspace.authenticated()},
          {"session", workspace.session_dir().toStdString()},
          {"frames_rendered", window.view()->frames_rendered()},
          {"event_loop_latency_ms", {{"p50", Percentile(lat, 0.5)}, {"p99", Percentile(lat, 0.99)}}},
          {"last_error", window.last_error().toStdString()}};
      std::printf("%s\n", j.dump().c_str());
      std::fflush(stdout);
      window.close();
    });
  }
  const int rc = app.exec();
  return exit_code != 0 ? exit_code : rc;
}
