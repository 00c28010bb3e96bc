// sweepscan-cli plan: a floor plan (and optionally a vertical section) of a
// cloud file or of a session's cloud (core/plan/floor_plan.h), as text or
// JSON, drawn as SVG and DXF (docs/plan-formats.md).
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "app/cli_args.h"
#include "app/cli_common.h"
#include "app/cli_outputs.h"
#include "app/cli_project.h"
#include "app/cli_recording.h"
#include "core/calibration/calibration_file.h"
#include "core/cloud/cloud_io.h"
#include "core/common/file_suffix.h"
#include "core/plan/floor_plan.h"
#include "core/plan/plan_writers.h"
#include "core/plan/rooms.h"
#include "core/plan/section.h"

namespace sweepscan::app {

const char* const kPlanUsage =
    "usage: sweepscan-cli plan CLOUD.ply|CLOUD.pcd|SESSION|PROJECT|--scenario FILE [--height H] "
    "[--band B]\n"
    "                          [--opening W] [--scale N] [--svg F.svg] [--dxf F.dxf]\n"
    "                          [--section-line x0,y0,x1,y1 [--section-svg F.svg] [--section-dxf "
    "F.dxf]] [--json]\n"
    "\n"
    "A floor plan from the horizontal section at height H (default 1.0 m, z up) +- B\n"
    "(default 0.05 m): wall faces fitted as lines, walls (two faces 0.05-0.4 m apart\n"
    "back to back) with their thickness, openings (gaps of at least W, default 0.6 m,\n"
    "that are not shadows of furniture) with their width, the rooms' inner\n"
    "dimensions between facing walls across free space, and the rooms' outlines\n"
    "(closed polygons on the walls' faces, doors closed) with their areas. A SESSION's cloud is "
    "built as\n"
    "`reconstruct` builds it (meta.json's calibration or --calibration, EKF poses or\n"
    "--pose-source). A PROJECT (.sweepscan-project) is drawn in its frame from its placed,\n"
    "visible sessions (or --sessions ID,ID), each built as `project export` builds it.\n"
    "\n"
    "  --svg F.svg            the plan as SVG 1.1 at 1:N (--scale N, default 50), north up\n"
    "  --dxf F.dxf            the plan as DXF R12 in metres (layers WALLS, OPENINGS,\n"
    "                         DIMENSIONS, SECTION, ROOMS); docs/plan-formats.md\n"
    "  --section-line x0,y0,x1,y1 --section-svg F.svg and/or --section-dxf F.dxf\n"
    "                         the vertical section along that line (m, +- B either side)\n"
    "  --calibration FILE, --pose-source S, --strict, --seed N   as for evaluate\n"
    "  --json                 the plan as JSON on stdout\n";

namespace {

bool ParseNumber(const Args& args, const std::string& key, double* out) {
  std::string error;
  if (!args.GetDouble(key, out, &error)) {
    PrintError(error);
    return false;
  }
  return true;
}

bool ParseLine(const std::string& text, plan::VerticalSectionOptions* o) {
  std::stringstream in(text);
  double v[4];
  char comma;
  for (int i = 0; i < 4; ++i) {
    if (!(in >> v[i]) || (i < 3 && !(in >> comma && comma == ','))) return false;
  }
  if (!in.eof() && in.peek() != EOF) return false;
  o->a = {v[0], v[1]};
  o->b = {v[2], v[3]};
  return true;
}

nlohmann::json Xy(const Eigen::Vector2d& p) { return {p.x(), p.y()}; }

nlohmann::json PlanJson(const plan::FloorPlan& p) {
  nlohmann::json faces = nlohmann::json::array(), walls = nlohmann::json::array(),
                 openings = nlohmann::json::array(), dims = nlohmann::json::array();
  for (const plan::WallFace& f : p.faces) {
    faces.push_back({{"a", Xy(f.a)}, {"b", Xy(f.b)}, {"length_m", f.Length()}, {"normal", Xy(f.normal)},
                     {"structural", f.structural}, {"points", f.points}, {"rms_m", f.rms_m}, {"line", f.line}});
  }
  for (const plan::Wall& w : p.walls) {
    walls.push_back({{"a", Xy(w.a)}, {"b", Xy(w.b)}, {"thickness_m", w.thickness_m}, {"faces", {w.face_a, w.face_b}}});
  }
  for (const plan::Opening& o : p.openings) {
    openings.push_back({{"a", Xy(o.a)}, {"b", Xy(o.b)}, {"width_m", o.width_m}, {"face", o.face}, {"wall", o.wall}});
  }
  for (const plan::Dimension& d : p.dimensions) {
    dims.push_back({{"a", Xy(d.a)}, {"b", Xy(d.b)}, {"distance_m", d.distance_m}, {"faces", {d.face_a, d.face_b}}});
  }
  nlohmann::json rooms = nlohmann::json::array();
  for (size_t r = 0; r < p.rooms.size(); ++r) {
    const plan::Room& room = p.rooms[r];
    nlohmann::json outline = nlohmann::json::array();
    for (const Eigen::Vector2d& c : room.outline) outline.push_back(Xy(c));
    rooms.push_back({{"name", plan::RoomName(r)}, {"outline", outline}, {"area_m2", room.area_m2},
                     {"perimeter_m", room.perimeter_m}, {"label", Xy(room.label)}, {"faces", room.faces},
                     {"openings", room.openings}});
  }
  return {{"height_m", p.height_m},
          {"band_m", p.band_m},
          {"cloud_points", p.section.points_in},
          {"section_points", p.section.points_out},
          {"extent", {{"min", Xy(p.min)}, {"max", Xy(p.max)}}},
          {"stray_points", p.stray_points},
          {"faces", faces},
          {"walls", walls},
          {"openings", openings},
          {"dimensions", dims},
          {"rooms", rooms}};
}

void PrintPlan(const plan::FloorPlan& p) {
  size_t structural = 0;
  for (const plan::WallFace& f : p.faces) structural += f.structural;
  std::printf("section at %.3f m +- %.3f m: %zu of %zu points\n", p.height_m, p.band_m, p.section.points_out,
              p.section.points_in);
  if (p.stray_points > 0) {
    std::printf(
        "%zu stray point(s) (alone in their 0.5 m cell) left outside the drawing's extent\n",
        p.stray_points);
  }
  std::printf(
      "%zu faces (%zu of walls, %zu of furniture), %zu walls seen from both sides, "
      "%zu openings, %zu dimensions, %zu rooms\n",
      p.faces.size(), structural, p.faces.size() - structural, p.walls.size(), p.openings.size(),
      p.dimensions.size(), p.rooms.size());
  for (const plan::Wall& w : p.walls) {
    std::printf("  wall     (%.3f, %.3f) - (%.3f, %.3f)  thickness %.3f m\n", w.a.x(), w.a.y(), w.b.x(), w.b.y(),
                w.thickness_m);
  }
  for (const plan::Opening& o : p.openings) {
    std::printf("  opening  (%.3f, %.3f) - (%.3f, %.3f)  width %.3f m%s\n", o.a.x(), o.a.y(), o.b.x(), o.b.y(),
                o.width_m, o.wall >= 0 ? "" : " (one face seen)");
  }
  for (const plan::Dimension& d : p.dimensions) {
    std::printf("  dimension (%.3f, %.3f) - (%.3f, %.3f)  %.3f m\n", d.a.x(), d.a.y(), d.b.x(), d.b.y(),
                d.distance_m);
  }
  for (size_t r = 0; r < p.rooms.size(); ++r) {
    const plan::Room& room = p.rooms[r];
    std::printf("  %-8s %zu corners  %s  perimeter %.3f m  doors %zu\n", plan::RoomName(r).c_str(),
                room.outline.size(), plan::FormatArea(room.area_m2).c_str(), room.perimeter_m, room.openings.size());
  }
}

// The cloud's positions: a cloud file, or a session's (scenario's) cloud as
// `reconstruct` / `evaluate` build it (cli_recording.h).
int LoadInput(const Args& args, std::vector<Eigen::Vector3f>* cloud) {
  const auto is_cloud = [](const std::string& p) {
    return p.size() > 4 && (HasFileSuffix(p, ".ply") || HasFileSuffix(p, ".pcd"));
  };
  const std::string suffix = kProjectSuffix;
  if (!args.Has("scenario") && args.positional().size() == 1 && args.positional()[0].size() > suffix.size() &&
      args.positional()[0].compare(args.positional()[0].size() - suffix.size(), suffix.size(), suffix) == 0) {
    const int refused = RefuseOptions(args, {"calibration", "seed"},
                                      "a project (each session keeps its own calibration)");
    return refused != kExitOk ? refused : ProjectPositions(args, args.positional()[0], cloud);
  }
  if (!args.Has("scenario") && args.positional().size() == 1 && is_cloud(args.positional()[0])) {
    const int refused =
        RefuseOptions(args, {"calibration", "pose-source", "strict", "seed", "sessions"},
                      "a cloud file (it holds placed points)");
    if (refused != kExitOk) return refused;
    const Status s = LoadCloudPositions(args.positional()[0], cloud);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
    return kExitOk;
  }
  int code =
      RefuseOptions(args, {"sessions"}, "a session or a scenario (it picks a project's sessions)");
  if (code != kExitOk) return code;
  RecordingInput in;
  if ((code = LoadRecording(args, &in)) != kExitOk) return code;
  ReconstructionOptions options;
  if (!in.session_dir.empty()) {
    code = SessionReconstructionOptions(args, in.decode.meta, &options);
  } else if (args.Has("calibration")) {  // a scenario's cloud, corrected as evaluate corrects it
    const Status s = LoadCalibrationFile(args.Get("calibration"), &options.calibration);
    if (!s.ok()) PrintError(s.message());
    code = s.ok() ? kExitOk : kExitBadInput;
  }
  if (code != kExitOk) return code;
  ReconstructionResult r;
  if ((code = RecordingPoses(args, in, options.calibration, /*smooth=*/false, &r)) != kExitOk) return code;
  cloud->reserve(r.points.size());
  for (const CloudPoint& p : r.points) cloud->emplace_back(p.x, p.y, p.z);
  return kExitOk;
}

}  // namespace

int RunPlan(int argc, char** argv) {
  Args args({"json", "help", "strict"}, {"height", "band", "opening", "scale", "svg", "dxf", "section-line",
                                         "section-svg", "section-dxf", "scenario", "seed", "calibration", "pose-source", "sessions"});
  std::string error;
  if (!args.Parse(argc, argv, 2, &error)) {
    PrintError(SeeHelp(error, "plan"));
    return kExitBadInput;
  }
  if (args.Flag("help")) {
    std::cout << kPlanUsage;
    return kExitOk;
  }
  plan::FloorPlanOptions options;
  plan::SvgOptions svg;
  if (!ParseNumber(args, "height", &options.section.height_m) || !ParseNumber(args, "band", &options.section.band_m) ||
      !ParseNumber(args, "opening", &options.opening_width_m) || !ParseNumber(args, "scale", &svg.scale)) {
    return kExitBadInput;
  }
  if (options.max_opening_width_m < options.opening_width_m) options.max_opening_width_m = 5 * options.opening_width_m;
  if (!options.IsValid(&error) || !svg.IsValid(&error)) {
    PrintError(error);
    return kExitBadInput;
  }
  plan::VerticalSectionOptions vertical;
  vertical.band_m = options.section.band_m;
  if (args.Has("section-line") != (args.Has("section-svg") || args.Has("section-dxf"))) {
    PrintError("--section-line x0,y0,x1,y1 goes with --section-svg F.svg and/or --section-dxf F.dxf");
    return kExitBadInput;
  }
  if (args.Has("section-line") && (!ParseLine(args.Get("section-line"), &vertical) || !vertical.IsValid(&error))) {
    PrintError("--section-line expects x0,y0,x1,y1 in metres, two distinct points, got '" +
               args.Get("section-line") + "'" + (error.empty() ? "" : ": " + error));
    return kExitBadInput;
  }
  // The drawings never replace what is drawn, nor each other.
  std::vector<CommandInput> inputs = {{"the --calibration file", args.Get("calibration")},
                                      {"the --scenario file", args.Get("scenario")}};
  // A session folder holds no drawing; a cloud or project file is not one.
  for (const std::string& input : args.positional()) {
    inputs.push_back({"the input " + input, input, std::filesystem::is_directory(input)});
  }
  int code = RefuseOutputOverInput({{"--svg", args.Get("svg")},
                                    {"--dxf", args.Get("dxf")},
                                    {"--section-svg", args.Get("section-svg")},
                                    {"--section-dxf", args.Get("section-dxf")}},
                                   inputs);
  if (code != kExitOk) return code;
  std::vector<Eigen::Vector3f> cloud;
  code = LoadInput(args, &cloud);
  if (code != kExitOk) return code;
  // A cut through a floor or ceiling slab draws the slab's whole extent as
  // points, which the fit turns into diagonal "walls" (hundreds of them at 2.69 m
  // under the office floor's 2.7 m ceiling).
  if (double level = 0.0; plan::LevelSurfaceNearCut(cloud, options.section, 0.03, &level)) {
    std::fprintf(stderr,
                 "sweepscan-cli: warning: the cut at %.3f m +- %.3f m is within 3 cm of a level "
                 "surface at %.2f m (a floor or a ceiling): its points are drawn as walls; cut at "
                 "least 0.1 m from it (--height)\n",
                 options.section.height_m, options.section.band_m, level);
  }
  plan::FloorPlan floor_plan;
  Status s = plan::BuildFloorPlan(cloud, options, &floor_plan);
  if (!s.ok()) {
    PrintError(s.message());
    return kExitBadInput;
  }
  char title[160];
  std::snprintf(title, sizeof(title), "sweepscan plan: section at %.2f m +- %.2f m, 1:%g", options.section.height_m,
                options.section.band_m, svg.scale);
  svg.title = title;
  if (args.Has("svg") && !(s = plan::WritePlanSvg(args.Get("svg"), floor_plan, svg)).ok()) {
    PrintError(s.message());
    return kExitFailure;
  }
  if (args.Has("dxf") && !(s = plan::WritePlanDxf(args.Get("dxf"), floor_plan, plan::DxfOptions())).ok()) {
    PrintError(s.message());
    return kExitFailure;
  }
  size_t section_points = 0;
  if (args.Has("section-line")) {
    std::vector<Eigen::Vector2d> s_z;
    if (!(s = plan::VerticalSection(cloud, vertical, &s_z)).ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
    section_points = s_z.size();
    plan::SvgOptions section_svg = svg;
    section_svg.title = "sweepscan vertical section " + args.Get("section-line") + " (s, z in m)";
    const std::vector<Eigen::Vector2d> drawn = plan::DecimateGrid(s_z, 0.01);
    if (args.Has("section-svg") && !(s = plan::WriteSectionSvg(args.Get("section-svg"), drawn, section_svg)).ok()) {
      PrintError(s.message());
      return kExitFailure;
    }
    if (args.Has("section-dxf") &&
        !(s = plan::WriteSectionDxf(args.Get("section-dxf"), drawn, plan::DxfOptions())).ok()) {
      PrintError(s.message());
      return kExitFailure;
    }
  }
  const std::string no_rooms = plan::NoRoomsReason(floor_plan);
  if (args.Flag("json")) {
    nlohmann::json report = PlanJson(floor_plan);
    if (args.Has("section-line")) report["vertical_section_points"] = section_points;
    if (!no_rooms.empty()) report["no_rooms_reason"] = no_rooms;
    std::cout << report.dump(2) << "\n";
  } else {
    PrintPlan(floor_plan);
    if (args.Has("section-line")) std::printf("vertical section: %zu points\n", section_points);
    if (!no_rooms.empty()) std::fprintf(stderr, "sweepscan-cli: note: %s\n", no_rooms.c_str());
  }
  return kExitOk;
}

}  // namespace sweepscan::app
