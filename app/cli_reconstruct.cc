// sweepscan-cli reconstruct, and export to a cloud file: a session's cloud
// as LAS, PLY or PCD. With the EKF's or the wheels' poses the session is
// streamed (hardware/station/session_stream.h) and memory does not grow with
// it; structure from motion and loop closure hold it whole.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "app/cli_args.h"
#include "app/cli_common.h"
#include "app/cli_recording.h"
#include "app/terminal_progress.h"
#include "core/cloud/cloud_io.h"
#include "core/cloud/las_writer.h"
#include "core/cloud/reconstruct.h"
#include "core/common/file_suffix.h"
#include "core/registration/loop_closure.h"
#include "core/sfm/wheeled.h"
#include "hardware/station/session_stream.h"

namespace sweepscan::app {

const char* const kReconstructUsage =
    "usage: sweepscan-cli reconstruct SESSION --out CLOUD.las|CLOUD.ply|CLOUD.pcd [options]\n"
    "\n"
    "Decodes the session's raw frames and builds the cloud. The suffix chooses the\n"
    "format: LAS 1.4 (point format 6, GPS time from the session's start, range, scan\n"
    "and beam as extra bytes; docs/las-format.md), or PLY / PCD (docs/cloud-format.md).\n"
    "\n"
    "Options:\n"
    "  --calibration FILE     mounting error to undo (calibration JSON); default: meta.json's\n"
    "  --pose-source S        ekf (default), odometry, or sfm: the EKF corrected by the planes the\n"
    "                         scans cross (lidar-only structure from motion, docs/sfm.md; the\n"
    "                         position along the walls stays the EKF's)\n"
    "  --no-ekf               same as --pose-source odometry\n"
    "  --no-deskew            place each whole scan at its first sample's pose\n"
    "  --loop-closure         the drive ends in the room it started in: register what it saw\n"
    "                         at the end to what it saw at the start and spread the correction\n"
    "                         over the loop (docs/registration.md, \"Loop closure\")\n"
    "  --strict               refuse a session with damaged records (default: skip them, with a warning)\n"
    "  --json                 print the report as JSON\n"
    "\n"
    "Memory: with the EKF or odometry poses the session is read twice, record by record, and\n"
    "the points go to the file as they are placed, so memory does not grow with the cloud:\n"
    "the poses and motion records, about 50 MB an hour of drive (a 10-hour drive of 175 M\n"
    "points: 0.6 GB, against 14 GB held whole). --pose-source sfm and\n"
    "--loop-closure need every scan at once: about 24 B a lidar sample plus 32 B a point\n"
    "(a 10-hour drive: 180 M samples, about 10 GB).\n"
    "On a terminal (and without --json) the two passes' progress is shown on stderr.\n";

namespace {

// Where a cloud export goes, in pieces: LAS 1.4 (docs/las-format.md)
// through LasWriter, PLY / PCD through CloudFileWriter. The LAS writer needs
// a box holding every point (its scale and offset) and the earliest point's
// time (its GPS clock, anchored on meta.json's created_utc); it is opened
// at the first points, which a reconstruction gives in time order.
class CloudOutput {
 public:
  CloudOutput(std::string session, std::string path, const SessionMeta& meta)
      : session_(std::move(session)),
        path_(std::move(path)),
        meta_(meta),
        las_(HasFileSuffix(path_, ".las")) {}

  // The box for LAS (ignored for PLY / PCD); before the first Append.
  void SetBox(const double min[3], const double max[3]) {
    for (int k = 0; k < 3; ++k) {
      extent_.min[k] = min[k];
      extent_.max[k] = max[k];
    }
  }
  // Or the whole cloud's extent, earliest time included.
  void SetExtent(const LasExtent& extent) { extent_ = extent; }
  Status Open() { return las_ ? Status::Ok() : cloud_.Open(path_); }
  Status Append(const CloudPoint* points, size_t n) {
    if (!las_) return cloud_.Append(points, n);
    if (!opened_ && n > 0) {
      if (extent_.empty()) {  // streamed: the first points are the earliest
        LasExtent first;
        first.Add(points, n);
        extent_.points = first.points;
        extent_.min_time_ns = first.min_time_ns;
      }
      const Status s = OpenLas();
      if (!s.ok()) return s;
    }
    return las_writer_.Append(points, n);
  }
  // Finishes the file; *las describes a LAS file.
  Status Finish(nlohmann::json* las) {
    if (!las_) return cloud_.Finish();
    Status s = opened_ ? Status::Ok() : OpenLas();  // an empty cloud is an empty file
    if (s.ok()) s = las_writer_.Finish();
    if (!s.ok()) return s;
    const LasWriteStats& w = las_writer_.stats();
    const LasQuantisation& q = w.quantisation;
    *las = {{"version", "1.4"},
            {"point_format", kLasPointFormat},
            {"points", w.points},
            {"non_finite_skipped", w.non_finite},
            {"bytes", w.bytes},
            {"scale_m", q.scale},
            {"offset_m", {q.offset[0], q.offset[1], q.offset[2]}},
            {"min_m", {w.min[0], w.min[1], w.min[2]}},
            {"max_m", {w.max[0], w.max[1], w.max[2]}},
            // The box the scale and offset were chosen for (holds every point).
            {"box_m", {{extent_.min[0], extent_.min[1], extent_.min[2]}, {extent_.max[0], extent_.max[1], extent_.max[2]}}},
            {"gps_time", las_options_.adjusted_gps_time ? "adjusted standard GPS time" : "robot seconds"},
            {"gps_time_of_first_point_s", las_options_.gps_time_at_origin_s}};
    return Status::Ok();
  }

 private:
  Status OpenLas() {
    opened_ = true;
    las_options_.extent = extent_;
    const Status time = SetLasTimeFromSession(meta_.created_utc, extent_, &las_options_);
    if (!time.ok()) {
      std::cerr << "sweepscan-cli: warning: " << session_ << "/" << kSessionMetaFile << ": " << time.message() << "\n";
    }
    las_options_.system_identifier = SessionSystemIdentifier(meta_);
    las_options_.generating_software = "sweepscan 0.1.0";
    return las_writer_.Open(path_, las_options_);
  }

  std::string session_;
  std::string path_;
  const SessionMeta& meta_;
  bool las_;
  bool opened_ = false;
  LasExtent extent_;
  LasWriterOptions las_options_;
  LasWriter las_writer_;
  CloudFileWriter cloud_;
};

// A whole cloud: LAS through CloudOutput with the cloud's own extent, PLY
// and PCD by SaveCloud (their header without the streamed padding line).
Status WriteCloud(const std::string& session, const std::string& path, const std::vector<CloudPoint>& points,
                  const SessionMeta& meta, nlohmann::json* las) {
  if (!HasFileSuffix(path, ".las")) return SaveCloud(path, points);
  CloudOutput out(session, path, meta);
  LasExtent extent;
  extent.Add(points.data(), points.size());
  out.SetExtent(extent);
  Status s = out.Open();
  constexpr size_t kChunk = 1 << 16;
  for (size_t i = 0; s.ok() && i < points.size(); i += kChunk) {
    s = out.Append(points.data() + i, std::min(kChunk, points.size() - i));
  }
  return s.ok() ? out.Finish(las) : s;
}

// --loop-closure (core/registration/loop_closure.h): the loop measured on
// the cloud just built, its poses corrected and the cloud built again from
// them. The report says what was found (or that the drive never left).
int CloseLoop(const std::string& session, const Decoded& d, ReconstructionOptions* options,
              ReconstructionResult* result, nlohmann::json* report) {
  LoopClosure loop;
  LoopClosureOptions lo;
  if (options->pose.source == PoseSource::kOdometry) lo.max_drift_fraction = 0.5;  // the wheels alone
  Status s = FindLoop(result->points, result->poses, lo, &loop);
  if (!s.ok()) {
    PrintError(session + ": " + s.message());
    return kExitFailure;
  }
  if (!loop.found) {
    *report = {{"found", false}, {"summary", "loop closure: the drive never left its start; nothing to close"}};
    return kExitOk;
  }
  const PoseBuffer corrected = CorrectPoses(result->poses, loop);
  const double t0 = ToSeconds(result->poses.earliest());
  const Eigen::Vector3d t = loop.correction.translation();
  const double angle = Eigen::AngleAxisd(loop.correction.rotation()).angle() * 180.0 / M_PI;
  char summary[320];
  std::snprintf(summary, sizeof(summary),
                "loop closure (%s): the end (%.0f-%.0f s) against the start (%.0f-%.0f s): the drift over the loop "
                "was %.1f mm and %.3f deg; rms %.1f mm, overlap %.0f %%",
                loop.method.c_str(), ToSeconds(loop.late_begin) - t0, ToSeconds(loop.late_end) - t0,
                ToSeconds(loop.early_begin) - t0, ToSeconds(loop.early_end) - t0, t.norm() * 1000, angle,
                loop.registration.rms_m * 1000, loop.registration.overlap * 100);
  *report = {{"found", true},
             {"method", loop.method},
             {"early_s", {ToSeconds(loop.early_begin) - t0, ToSeconds(loop.early_end) - t0}},
             {"late_s", {ToSeconds(loop.late_begin) - t0, ToSeconds(loop.late_end) - t0}},
             {"correction_translation_m", {t.x(), t.y(), t.z()}},
             {"correction_rotation_deg", angle},
             {"rms_m", loop.registration.rms_m},
             {"overlap", loop.registration.overlap},
             {"summary", summary}};
  const PoseSource source = options->pose.source;
  options->pose.source = PoseSource::kSfm;  // given poses: the corrected ones
  s = Reconstruct(d.log, d.info.meta.geometry, *options, &corrected, result);
  options->pose.source = source;
  if (!s.ok()) {
    PrintError(session + ": " + s.message());
    return kExitFailure;
  }
  return kExitOk;
}

// The report both ways share (JSON, and the lines printed without --json).
nlohmann::json CloudReport(const Args& args, const ReconstructionOptions& options, size_t scans,
                           const ReconstructionResult& result) {
  return {
      {"session", args.positional()[0]},
      {"out", args.Get("out")},
      {"pose_source", PoseSourceName(options.pose.source)},
      {"deskew", options.assembly.deskew},
      {"calibration_rad",
       {{"alpha", options.calibration.alpha}, {"beta", options.calibration.beta}, {"gamma", options.calibration.gamma}}},
      {"scans", scans},
      {"samples", result.stats.samples_in},
      {"points", result.stats.points_out},
      {"invalid_samples", result.stats.invalid_range},
      {"samples_without_pose", result.stats.no_pose},
      {"ekf_rejected", result.ekf_counters.rejected},
  };
}

void PrintCloudReport(const nlohmann::json& report) {
  std::printf("%zu scans, %zu samples -> %zu points in %s (poses: %s, deskew %s)\n", report["scans"].get<size_t>(),
              report["samples"].get<size_t>(), report["points"].get<size_t>(),
              report["out"].get<std::string>().c_str(), report["pose_source"].get<std::string>().c_str(),
              report["deskew"].get<bool>() ? "on" : "off");
  if (report.contains("las")) {
    const nlohmann::json& las = report["las"];
    std::printf("LAS 1.4, point format 6: scale %g m, offset (%g, %g, %g) m, GPS time: %s\n",
                las["scale_m"].get<double>(), las["offset_m"][0].get<double>(), las["offset_m"][1].get<double>(),
                las["offset_m"][2].get<double>(), las["gps_time"].get<std::string>().c_str());
  }
}

// The EKF's or the wheels' poses: two passes over frames.bin
// (hardware/station/session_stream.h), the points written as they are placed.
int StreamToFile(const Args& args, const std::string& command, ReconstructionOptions options) {
  const std::string& dir = args.positional()[0];
  hardware::SessionCloudStream stream;
  TerminalProgress progress(TerminalProgress::Wanted(args.Flag("json")), command + " " + dir);
  const int code =
      OpenSessionStream(args, dir, /*session_calibration=*/true, &options, &stream, &progress);
  if (code != kExitOk) return code;
  CloudOutput out(dir, args.Get("out"), stream.decode().meta);
  double min[3], max[3];
  stream.PointBounds(min, max);
  out.SetBox(min, max);
  Status s = out.Open();
  if (s.ok()) {
    s = stream.PlacePoints([&out](const CloudPoint* p, size_t n) { return out.Append(p, n); },
                           progress.Stage("placing the points"));
  }
  progress.Clear();
  nlohmann::json las;
  if (s.ok()) s = out.Finish(&las);
  if (!s.ok()) {
    PrintError(s.message());
    return kExitFailure;
  }
  nlohmann::json report = CloudReport(args, options, stream.scans(), stream.result());
  if (!las.is_null()) report["las"] = las;
  report["memory"] = {{"streamed", true}, {"poses_mib", stream.held_bytes() / 1048576.0}};
  if (args.Flag("json")) {
    std::cout << report.dump(2) << "\n";
  } else {
    PrintCloudReport(report);
  }
  return kExitOk;
}

}  // namespace

bool IsCloudFile(const std::string& path) {
  return HasFileSuffix(path, ".las") || HasFileSuffix(path, ".ply") || HasFileSuffix(path, ".pcd");
}

int ReconstructToFile(const Args& args, const std::string& command) {
  int code;
  ReconstructionOptions options;
  if (args.Has("pose-source")) {
    if (!ParsePoseSource(args.Get("pose-source"), &options.pose.source) ||
        options.pose.source == PoseSource::kTruth) {
      PrintError("--pose-source must be ekf, odometry or sfm for a session, got '" + args.Get("pose-source") + "'");
      return kExitBadInput;
    }
  }
  if (args.Flag("no-ekf")) {
    if (options.pose.source == PoseSource::kSfm) {
      PrintError("--no-ekf contradicts --pose-source sfm (it corrects the EKF's poses)");
      return kExitBadInput;
    }
    options.pose.source = PoseSource::kOdometry;
  }
  options.assembly.deskew = !args.Flag("no-deskew");
  // Asked before the session is read (a long one takes minutes), not after.
  if (const Status w = CheckCanWrite(args.Get("out")); !w.ok()) {
    PrintError(w.message());
    return kExitFailure;
  }
  if (options.pose.source != PoseSource::kSfm && !args.Flag("loop-closure"))
    return StreamToFile(args, command, options);
  // sfm and loop closure work on every scan at once.
  Decoded d;
  if ((code = DecodeOrFail(args, args.positional()[0], &d)) != kExitOk) return code;
  if ((code = SessionReconstructionOptions(args, d.info.meta, &options)) != kExitOk) return code;
  ReconstructionResult result;
  // sfm: the EKF's poses corrected by the planes (core/sfm/wheeled.h), then
  // given to the reconstruction like any poses.
  sfm::WheeledSfmResult sfm_result;
  if (options.pose.source == PoseSource::kSfm) {
    const Status s = sfm::WheeledSfmFromLog(d.log, d.info.meta.geometry, options.calibration, options.pose.initial_pose,
                                            PoseSource::kEkf, sfm::SequenceInit(), sfm::WheeledSfmOptions(),
                                            &sfm_result);
    if (!s.ok()) {
      PrintError(args.positional()[0] + ": sfm: " + s.message());
      return kExitFailure;
    }
  }
  Status s = Reconstruct(d.log, d.info.meta.geometry, options,
                         options.pose.source == PoseSource::kSfm ? &sfm_result.poses : nullptr, &result);
  if (!s.ok()) {  // the session's geometry or records cannot make poses
    PrintError(args.positional()[0] + ": " + s.message());
    return kExitBadInput;
  }
  nlohmann::json loop_report;
  if (args.Flag("loop-closure") && (code = CloseLoop(args.positional()[0], d, &options, &result, &loop_report)) != kExitOk) {
    return code;
  }
  nlohmann::json las;
  s = WriteCloud(args.positional()[0], args.Get("out"), result.points, d.info.meta, &las);
  if (!s.ok()) {
    PrintError(s.message());
    return kExitFailure;
  }
  nlohmann::json report = CloudReport(args, options, d.log.scans.size(), result);
  if (!las.is_null()) report["las"] = las;
  if (!loop_report.is_null()) report["loop_closure"] = loop_report;
  if (options.pose.source == PoseSource::kSfm && loop_report.is_null()) {
    const sfm::SequenceResult& seq = sfm_result.sequence;
    report["sfm"] = {{"scans", seq.poses.size()},
                     {"lines", seq.lines_total},
                     {"lines_assigned", seq.lines_assigned},
                     {"planes", seq.planes.size()}};
  }
  report["memory"] = {{"streamed", false}};
  if (args.Flag("json")) {
    std::cout << report.dump(2) << "\n";
    return kExitOk;
  }
  if (!loop_report.is_null()) std::printf("%s\n", loop_report["summary"].get<std::string>().c_str());
  if (options.pose.source == PoseSource::kSfm && loop_report.is_null()) {
    const sfm::SequenceResult& seq = sfm_result.sequence;
    std::printf("sfm: %zu scans placed, %d lines (%d on %zu planes)\n", seq.poses.size(), seq.lines_total,
                seq.lines_assigned, seq.planes.size());
  }
  PrintCloudReport(report);
  return kExitOk;
}

}  // namespace sweepscan::app
