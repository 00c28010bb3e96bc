// The desktop app's command line: the options and their parsing.
#include "app/gui_options.h"

#include <QCommandLineParser>
#include <QStringList>
#include <algorithm>
#include <cmath>

namespace sweepscan::app {

Options ParseOptions(const QCoreApplication& app, const QString& resources) {
  QCommandLineParser parser;
  parser.setApplicationDescription(QStringLiteral(
      "Operator workstation for mobile 3D lidar scanning: connect, drive, watch the cloud grow, "
      "record, replay, export."));
  parser.addHelpOption();
  parser.addVersionOption();
  const QCommandLineOption simulate("simulate",
                                    "Connect to the built-in simulated robot at start.");
  const QCommandLineOption scenario(
      "scenario", "Scenario of the simulated robot (default: resources/scenarios/lab.json).",
      "FILE");
  const QCommandLineOption drive_demo(
      "drive-demo",
      "Record and drive the scenario's path with the same drive commands the keyboard sends.");
  const QCommandLineOption replay("replay", "Open and replay a session folder.", "SESSION");
  const QCommandLineOption project(
      "project", "Open a project (many sessions in one frame, docs/project-format.md) at start.",
      "FILE");
  const QCommandLineOption speed(
      "speed", "Replay speed, times real time (the Replay panel offers 1 to 20; any up to 1000), or 0 for "
      "as fast as possible (default 0): of --replay, or of a session given as PATH.",
      "X", "0");
  const QCommandLineOption screenshot("screenshot", "Save the view as PNG just before quitting.",
                                      "PATH");
  const QCommandLineOption window_shot(
      "window-screenshot", "Save the whole window as PNG just before quitting.", "PATH");
  const QCommandLineOption export_cloud(
      "export-cloud",
      "Write the cloud (LAS, PLY or PCD by suffix) just before quitting (the project's, as "
      "`sweepscan-cli project export` writes it, with --project and no session).",
      "PATH");
  const QCommandLineOption quit_after("quit-after",
                                      "Quit after S seconds (prints a JSON summary line).", "S");
  const QCommandLineOption orbit(
      "orbit-benchmark",
      "With --replay (or --project: once every placed session is drawn): once the session is "
      "shown, render N frames orbiting the camera at the rest level and N at the motion level, "
      "print timings and memory as JSON and quit.",
      "N");
  const QCommandLineOption pairs(
      "pairs",
      "With --replay: load a pairs file into the calibration panel once the session is shown, "
      "solve (refined corners) and show the calibrated cloud.",
      "FILE");
  const QCommandLineOption tour(
      "calibration-tour",
      "With --replay (a circle drive) and --pairs: go through the calibration steps and the "
      "evaluation, saving a window screenshot of each into DIR, then quit.",
      "DIR");
  const QCommandLineOption pose_source(
      "pose-source",
      "Poses of opened sessions: ekf (default), odometry or sfm (the EKF corrected by the planes "
      "the scans cross), as `sweepscan-cli reconstruct --pose-source`. Kept like the choice in "
      "Tools > Pose Source.",
      "S");
  const QCommandLineOption pose_source_tour(
      "pose-source-tour",
      "With --replay: once the session is shown, choose Tools > Pose Source > SfM, wait for it, "
      "save a screenshot with the menu open as PNG, then quit.",
      "PNG");
  const QCommandLineOption sessions(
      "sessions-dir",
      "Where new recordings go (default: the folder last chosen in Tools > Sessions Folder, else "
      "~/sweepscan-sessions).",
      "DIR");
  const QCommandLineOption memory_budget(
      "memory-budget",
      "Memory for the cloud's points, in MiB (default: a quarter of the machine's RAM). Above it "
      "the oldest chunks are paged to an unnamed cache file beside the session and read back when "
      "shown or picked.",
      "MIB");
  const QCommandLineOption rest_budget(
      "rest-budget",
      "Points drawn at most when the camera is still (default: 1000000 with a software renderer, "
      "10000000 on a GPU).",
      "N");
  const QCommandLineOption lod_budget(
      "lod-budget",
      "Points drawn at most while the camera moves or points stream in (default 30000 under a "
      "software renderer, 1000000 on a GPU).",
      "N");
  const QCommandLineOption draw_pace(
      "draw-pace",
      "Let the OpenGL driver finish its work every N points drawn, so that a software "
      "renderer's memory for a frame stays bounded (default 262144 under a software renderer, "
      "0 on a GPU; 0: never).",
      "N");
  const QCommandLineOption seek(
      "seek",
      "With --replay: once the session is shown, seek its replay to S seconds from its start "
      "and replay on at 1x (a benchmark: the JSON line's seek_ms is the seek's time, and its "
      "event-loop latency and insertion_ms count from the seek on).",
      "S");
  const QCommandLineOption floor_plan(
      "floor-plan", "Show the floor plan (View > Floor Plan) of the project or session at start.");
  const QCommandLineOption plan_height("plan-height", "The floor plan's cut height (m, 0.05 to 10).", "M");
  parser.addOptions({floor_plan, plan_height, draw_pace, seek});
  parser.addPositionalArgument(
      QStringLiteral("path"),
      "A session folder (NAME.sweepscan) to open, a project (NAME.sweepscan-project), or a ROS "
      "recording to import (.bag, .mcap, .db3, or a ROS 2 bag folder).",
      QStringLiteral("[PATH]"));
  parser.addOptions({simulate, scenario, drive_demo, replay, speed, screenshot, window_shot,
                     export_cloud, quit_after, orbit, pairs, tour, pose_source, pose_source_tour,
                     sessions, memory_budget, rest_budget, lod_budget, project});
  parser.process(app);

  Options o;
  o.simulate = parser.isSet(simulate);
  o.drive_demo = parser.isSet(drive_demo);
  o.scenario = parser.isSet(scenario) ? parser.value(scenario)
                                      : resources + QStringLiteral("/scenarios/lab.json");
  o.replay = parser.value(replay);
  o.screenshot = parser.value(screenshot);
  o.window_screenshot = parser.value(window_shot);
  o.export_cloud = parser.value(export_cloud);
  o.sessions_dir = parser.value(sessions);
  // A number the option takes, or the option named in o.bad_number (refused
  // in Main): "2G" read as 0 would have been a zero-byte memory budget.
  const auto number = [&](const QCommandLineOption& option, double lo, double* out,
                          double hi = std::numeric_limits<double>::max()) {
    if (!parser.isSet(option)) return;
    bool ok = false;
    const double v = parser.value(option).toDouble(&ok);
    if (ok && v >= lo && v <= hi && std::isfinite(v)) {
      *out = v;
    } else if (o.bad_number.isEmpty()) {
      o.bad_number = QStringLiteral("--%1 '%2'").arg(option.names().front(), parser.value(option));
    }
  };
  const auto count = [&](const QCommandLineOption& option, long long* out) {
    double v = -1.0;
    number(option, 0.0, &v);
    if (v >= 0.0) *out = static_cast<long long>(v);
  };
  number(speed, 0.0, &o.speed, 1000.0);
  number(quit_after, 0.0, &o.quit_after_s);
  double frames = 0.0;
  number(orbit, 1.0, &frames, 1e6);
  o.orbit_frames = static_cast<int>(frames);
  o.pairs = parser.value(pairs);
  o.tour = parser.value(tour);
  o.pose_source = parser.value(pose_source);
  o.project = parser.value(project);
  o.floor_plan = parser.isSet(floor_plan);
  // The plan dock's range (PlanPanel's spin box).
  number(plan_height, 0.05, &o.plan_height_m, 10.0);
  o.pose_source_tour = parser.value(pose_source_tour);
  number(memory_budget, 0.0, &o.memory_budget_mib);
  count(rest_budget, &o.rest_budget);
  count(lod_budget, &o.lod_budget);
  count(draw_pace, &o.draw_pace);
  const QStringList positional = parser.positionalArguments();
  if (!positional.isEmpty()) o.open_path = positional.first();
  if (positional.size() > 1) o.bad_arguments = positional.mid(1).join(QLatin1Char(' '));
  if (parser.isSet(seek)) {
    bool ok = false;
    o.seek_s = parser.value(seek).toDouble(&ok);
    if (!ok || !(o.seek_s >= 0.0)) o.seek_s = -2.0;  // Refused in Main.
  }
  return o;
}

}  // namespace sweepscan::app
