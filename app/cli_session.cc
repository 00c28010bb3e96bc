// sweepscan-cli session commands: info, reconstruct, export. A session is
// the folder the workstation (or `simulate`) records: raw link frames plus
// meta.json (docs/session-format.md). Everything here re-decodes the raw
// bytes, so a better decoder or calibration always applies to old sessions.
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sys/stat.h>

#include "app/cli_args.h"
#include "app/cli_common.h"
#include "core/calibration/calibration.h"
#include "core/cloud/cloud_io.h"
#include "core/cloud/reconstruct.h"
#include "hardware/link/telemetry_decoder.h"

namespace sweepscan::app {

const char* const kInfoUsage =
    "usage: sweepscan-cli info SESSION [--json]\n"
    "\n"
    "Describes a recorded session: robot geometry and calibration from meta.json,\n"
    "how many link frames were recorded (and whether a torn tail was dropped),\n"
    "what the devices sent (scans, IMU and wheel records, decoder errors), and\n"
    "the robot-time span.\n";

const char* const kReconstructUsage =
    "usage: sweepscan-cli reconstruct SESSION --out CLOUD.ply|CLOUD.pcd [options]\n"
    "\n"
    "Decodes the session's raw frames and builds the cloud.\n"
    "\n"
    "Options:\n"
    "  --calibration FILE     mounting error to undo (calibration JSON); default: meta.json's\n"
    "  --pose-source S        ekf (default) or odometry\n"
    "  --no-ekf               same as --pose-source odometry\n"
    "  --no-deskew            place each whole scan at its first sample's pose\n"
    "  --json                 print the report as JSON\n";

const char* const kExportUsage =
    "usage: sweepscan-cli export SESSION --out DIR [--json]\n"
    "\n"
    "Writes the session's decoded sensor records as CSV for other tools:\n"
    "  DIR/lidar.csv   robot_time_s,scan,beam,range_m,theta_rad   (range 0: no return)\n"
    "  DIR/imu.csv     robot_time_s,gyro_z_rad_s,roll_rad,pitch_rad,yaw_rad\n"
    "  DIR/wheels.csv  robot_time_s,left_mps,right_mps\n";

namespace {

struct Decoded {
  SensorLog log;
  hardware::SessionDecodeInfo info;
};

int DecodeOrFail(const std::string& dir, Decoded* d) {
  const Status s = hardware::DecodeSession(dir, &d->log, &d->info);
  if (!s.ok()) {
    PrintError(s.message());
    return kExitBadInput;
  }
  return kExitOk;
}

bool ParseCommon(Args* args, int argc, char** argv, const char* usage, int* code) {
  std::string error;
  if (!args->Parse(argc, argv, 2, &error)) {
    PrintError(error);
    *code = kExitBadInput;
    return false;
  }
  if (args->Flag("help")) {
    std::cout << usage;
    *code = kExitOk;
    return false;
  }
  if (args->positional().size() != 1) {
    PrintError(args->positional().empty() ? "missing SESSION folder" : "expected one SESSION folder");
    std::cerr << usage;
    *code = kExitBadInput;
    return false;
  }
  return true;
}

nlohmann::json InfoJson(const std::string& dir, const Decoded& d) {
  const SessionMeta& m = d.info.meta;
  size_t samples = 0;
  for (const auto& s : d.log.scans) samples += s.samples.size();
  const auto& t = d.info.telemetry;
  return {
      {"session", dir},
      {"format_version", m.format_version},
      {"created_utc", m.created_utc},
      {"link", m.link},
      {"agent", m.agent},
      {"notes", m.notes},
      {"robot",
       {{"lidar_height_m", m.geometry.lidar_height_m},
        {"lidar_offset_x_m", m.geometry.lidar_offset_x_m},
        {"imu_offset_x_m", m.geometry.imu_offset_x_m},
        {"wheel_distance_m", m.geometry.wheel_distance_m}}},
      {"calibration_rad",
       {{"alpha", m.calibration.alpha}, {"beta", m.calibration.beta}, {"gamma", m.calibration.gamma}}},
      {"frames",
       {{"records", d.info.frames.records},
        {"bytes", d.info.frames.record_bytes},
        {"truncated_tail", d.info.frames.truncated_tail},
        {"tail_reason", d.info.frames.tail_reason},
        {"refused", d.info.frames_refused}}},
      {"robot_time_s", {ToSeconds(d.info.first_robot_time), ToSeconds(d.info.last_robot_time)}},
      {"duration_s", ToSeconds(d.info.last_robot_time - d.info.first_robot_time)},
      {"scans", d.log.scans.size()},
      {"lidar_samples", samples},
      {"imu_records", d.log.imu.size()},
      {"wheel_records", d.log.wheels.size()},
      {"decoder_errors",
       {{"lidar_checksum", t.x4.checksum_errors},
        {"lidar_skipped_bytes", t.x4.bytes_skipped},
        {"imu_checksum", t.hi219.checksum_errors},
        {"imu_skipped_bytes", t.hi219.bytes_skipped},
        {"motor_checksum", t.motor.checksum_errors},
        {"motor_skipped_bytes", t.motor.bytes_skipped}}},
  };
}

}  // namespace

int RunInfo(int argc, char** argv) {
  Args args({"json", "help"}, {});
  int code;
  if (!ParseCommon(&args, argc, argv, kInfoUsage, &code)) return code;
  Decoded d;
  if ((code = DecodeOrFail(args.positional()[0], &d)) != kExitOk) return code;
  const nlohmann::json j = InfoJson(args.positional()[0], d);
  if (args.Flag("json")) {
    std::cout << j.dump(2) << "\n";
    return kExitOk;
  }
  std::printf("session %s (format %u, created %s)\n", args.positional()[0].c_str(),
              d.info.meta.format_version, d.info.meta.created_utc.c_str());
  std::printf("link %s, agent %s\n", d.info.meta.link.c_str(), d.info.meta.agent.c_str());
  std::printf("%s\n", d.info.ToString().c_str());
  std::printf("%.1f s of robot time: %zu scans (%zu samples), %zu IMU records, %zu wheel records\n",
              j["duration_s"].get<double>(), d.log.scans.size(), j["lidar_samples"].get<size_t>(),
              d.log.imu.size(), d.log.wheels.size());
  std::printf("calibration in use: alpha %.5f, beta %.5f, gamma %.5f rad\n", d.info.meta.calibration.alpha,
              d.info.meta.calibration.beta, d.info.meta.calibration.gamma);
  return kExitOk;
}

int RunReconstruct(int argc, char** argv) {
  Args args({"json", "help", "no-ekf", "no-deskew"}, {"out", "calibration", "pose-source"});
  int code;
  if (!ParseCommon(&args, argc, argv, kReconstructUsage, &code)) return code;
  if (!args.Has("out")) {
    PrintError("reconstruct needs --out CLOUD.ply (see sweepscan-cli help reconstruct)");
    return kExitBadInput;
  }
  ReconstructionOptions options;
  if (args.Has("pose-source")) {
    if (!ParsePoseSource(args.Get("pose-source"), &options.pose.source) ||
        options.pose.source == PoseSource::kTruth) {
      PrintError("--pose-source must be ekf or odometry for a session, got '" + args.Get("pose-source") + "'");
      return kExitBadInput;
    }
  }
  if (args.Flag("no-ekf")) options.pose.source = PoseSource::kOdometry;
  options.assembly.deskew = !args.Flag("no-deskew");
  Decoded d;
  if ((code = DecodeOrFail(args.positional()[0], &d)) != kExitOk) return code;
  options.calibration = d.info.meta.calibration;
  options.pose.initial_pose = SessionStartPose(d.info.meta);
  if (args.Has("calibration")) {
    const Status s = LoadCalibrationFile(args.Get("calibration"), &options.calibration);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
  }
  ReconstructionResult result;
  Status s = Reconstruct(d.log, d.info.meta.geometry, options, nullptr, &result);
  if (!s.ok()) {
    PrintError(args.positional()[0] + ": " + s.message());
    return kExitFailure;
  }
  s = SaveCloud(args.Get("out"), result.points);
  if (!s.ok()) {
    PrintError(s.message());
    return kExitFailure;
  }
  const nlohmann::json report = {
      {"session", args.positional()[0]},
      {"out", args.Get("out")},
      {"pose_source", PoseSourceName(options.pose.source)},
      {"deskew", options.assembly.deskew},
      {"calibration_rad",
       {{"alpha", options.calibration.alpha}, {"beta", options.calibration.beta}, {"gamma", options.calibration.gamma}}},
      {"scans", d.log.scans.size()},
      {"samples", result.stats.samples_in},
      {"points", result.stats.points_out},
      {"invalid_samples", result.stats.invalid_range},
      {"samples_without_pose", result.stats.no_pose},
      {"ekf_rejected", result.ekf_counters.rejected},
  };
  if (args.Flag("json")) {
    std::cout << report.dump(2) << "\n";
  } else {
    std::printf("%zu scans, %zu samples -> %zu points in %s (poses: %s, deskew %s)\n", d.log.scans.size(),
                result.stats.samples_in, result.stats.points_out, args.Get("out").c_str(),
                PoseSourceName(options.pose.source), options.assembly.deskew ? "on" : "off");
  }
  return kExitOk;
}

int RunExport(int argc, char** argv) {
  Args args({"json", "help"}, {"out"});
  int code;
  if (!ParseCommon(&args, argc, argv, kExportUsage, &code)) return code;
  if (!args.Has("out")) {
    PrintError("export needs --out DIR");
    return kExitBadInput;
  }
  Decoded d;
  if ((code = DecodeOrFail(args.positional()[0], &d)) != kExitOk) return code;
  const std::string dir = args.Get("out");
  ::mkdir(dir.c_str(), 0755);
  struct stat st;
  if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    PrintError(dir + ": cannot create folder");
    return kExitFailure;
  }
  // Written to temporary names, renamed when complete.
  auto write = [&](const std::string& name, const std::string& header, auto&& rows) -> bool {
    const std::string path = dir + "/" + name, tmp = path + ".tmp";
    FILE* f = std::fopen(tmp.c_str(), "w");
    if (f == nullptr) return false;
    std::fprintf(f, "%s\n", header.c_str());
    rows(f);
    const bool ok = std::fclose(f) == 0 && std::rename(tmp.c_str(), path.c_str()) == 0;
    if (!ok) std::remove(tmp.c_str());
    return ok;
  };
  size_t samples = 0;
  const bool ok =
      write("lidar.csv", "robot_time_s,scan,beam,range_m,theta_rad",
            [&](FILE* f) {
              for (const auto& scan : d.log.scans) {
                for (const auto& s : scan.samples) {
                  std::fprintf(f, "%.9f,%u,%u,%.4f,%.6f\n", ToSeconds(s.time), scan.index, s.beam,
                               s.range_m, s.theta);
                  ++samples;
                }
              }
            }) &&
      write("imu.csv", "robot_time_s,gyro_z_rad_s,roll_rad,pitch_rad,yaw_rad",
            [&](FILE* f) {
              for (const auto& m : d.log.imu) {
                std::fprintf(f, "%.9f,%.7f,%.7f,%.7f,%.7f\n", ToSeconds(m.time), m.gyro_z, m.roll, m.pitch, m.yaw);
              }
            }) &&
      write("wheels.csv", "robot_time_s,left_mps,right_mps", [&](FILE* f) {
        for (const auto& m : d.log.wheels) {
          std::fprintf(f, "%.9f,%.6f,%.6f\n", ToSeconds(m.time), m.left_mps, m.right_mps);
        }
      });
  if (!ok) {
    PrintError(dir + ": cannot write the CSV files");
    return kExitFailure;
  }
  const nlohmann::json report = {{"out", dir},
                                 {"lidar_samples", samples},
                                 {"imu_records", d.log.imu.size()},
                                 {"wheel_records", d.log.wheels.size()}};
  if (args.Flag("json")) {
    std::cout << report.dump(2) << "\n";
  } else {
    std::printf("wrote %zu lidar samples, %zu IMU and %zu wheel records to %s/\n", samples, d.log.imu.size(),
                d.log.wheels.size(), dir.c_str());
  }
  return kExitOk;
}

}  // namespace sweepscan::app
