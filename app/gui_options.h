// The desktop app's command line (sweepscan --help): its options, parsed
// once; Main (gui_main.cc) acts on them.
#ifndef SWEEPSCAN_APP_GUI_OPTIONS_H_
#define SWEEPSCAN_APP_GUI_OPTIONS_H_

#include <QCoreApplication>
#include <QString>

namespace sweepscan::app {

struct Options {
  bool simulate = false;
  bool drive_demo = false;
  QString scenario;  // Resolved to the default when not given.
  QString replay;
  QString project;              // A project file to open at start.
  bool floor_plan = false;      // View > Floor Plan shown at start.
  double plan_height_m = -1.0;  // its cut (< 0: the last one set)
  double speed = 0.0;
  QString screenshot, window_screenshot, export_cloud, sessions_dir;
  double quit_after_s = -1.0;  // < 0: run until the operator quits.
  int orbit_frames = 0;        // > 0: the orbit benchmark after --replay.
  QString pairs;               // With --replay: load into the calibration panel and solve.
  QString tour;                // With --replay and --pairs: the calibration tour's folder.
  QString pose_source;         // Of the session replayed (as if chosen in Tools > Pose Source).
  QString pose_source_tour;    // With --replay: the pose source screenshot.
  double memory_budget_mib = -1.0;  // The cloud store's; < 0: the default (a quarter of RAM).
  long long rest_budget = -1;       // Points drawn at rest; < 0: the view's default.
  long long draw_pace = -1;         // Points between the driver's finishes; < 0: the default.
  long long lod_budget = -1;        // Points drawn while the camera moves.
  double seek_s = -1.0;             // With --replay: seek there once shown (< 0: no).
  QString bad_number;               // "--option 'value'" that is not a number it takes
  QString open_path;                // The positional PATH: a session, a project or a ROS recording.
  QString bad_arguments;            // Positional arguments beyond the one PATH (refused in Main).
};

// Parses the command line (--help and --version exit here). Bad numbers and
// arguments are left in the Options for Main to refuse. `resources`: the
// folder whose scenarios/lab.json is the default scenario.
Options ParseOptions(const QCoreApplication& app, const QString& resources);

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_GUI_OPTIONS_H_
