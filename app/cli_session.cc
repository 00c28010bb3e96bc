// sweepscan-cli session commands: info, export (CSV and rosbag; cloud files
// are cli_reconstruct.cc's) and repair. A session is the folder the
// workstation (or `simulate`) records: raw link frames plus meta.json
// (docs/session-format.md). Everything here re-decodes the raw
// bytes, so a better decoder or calibration always applies to old sessions.
#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "app/cli_args.h"
#include "app/cli_common.h"
#include "app/cli_outputs.h"
#include "app/cli_recording.h"
#include "core/calibration/calibration.h"
#include "core/cloud/cloud_io.h"
#include "core/cloud/reconstruct.h"
#include "core/common/checked_file.h"
#include "core/io/ros/ros_bag.h"
#include "hardware/link/telemetry_decoder.h"

namespace sweepscan::app {

const char* const kInfoUsage =
    "usage: sweepscan-cli info SESSION|BAG [--strict] [--json]\n"
    "\n"
    "Describes a recorded session: robot geometry and calibration from meta.json,\n"
    "how many link frames were recorded (and whether a torn tail was dropped),\n"
    "damage (records skipped because frames.bin is corrupt there: how many, how\n"
    "many seconds, where), what the devices sent (scans, IMU and wheel records,\n"
    "decoder errors), the robot-time span, and the link outages of the recording\n"
    "(when, why, how long, what the robot resent, what was lost, clock epochs).\n"
    "--strict: exit 2 if damaged.\n"
    "Given a ROS bag, describes the bag instead (sweepscan-cli help import).\n";

const char* const kRepairUsage =
    "usage: sweepscan-cli repair SESSION --out NEW [--json]\n"
    "\n"
    "Writes a clean copy of a damaged session: every intact record of frames.bin\n"
    "(damaged stretches and a torn tail are left out), meta.json and the other\n"
    "files of the folder. The damaged session is not touched. NEW must not exist\n"
    "or be an empty folder.\n";

const char* const kExportUsage =
    "usage: sweepscan-cli export SESSION --out DIR [--strict] [--json]\n"
    "       sweepscan-cli export SESSION --out FILE.las|FILE.ply|FILE.pcd [--calibration FILE]\n"
    "                            [--pose-source S] [--no-ekf] [--no-deskew] [--loop-closure]\n"
    "                            [--strict] [--json]\n"
    "       sweepscan-cli export SESSION --format rosbag --out FILE.bag [--calibration FILE]\n"
    "                            [--no-ekf] [--frame F]\n"
    "\n"
    "--out ending in .las, .ply or .pcd: the session's cloud, reconstructed exactly as\n"
    "`reconstruct` does with the same options (see sweepscan-cli help reconstruct);\n"
    ".las is LAS 1.4 (docs/las-format.md), written in chunks with bounded memory.\n"
    "\n"
    "--format rosbag: the session's cloud (as reconstruct makes it) as one\n"
    "sensor_msgs/PointCloud2 on /sweepscan/cloud (x y z intensity time) and its\n"
    "poses as a nav_msgs/Path on /sweepscan/path, in frame F (default odom), in a\n"
    "ROS 1 bag that rosbag and RViz read (docs/ros-bags.md, \"Back to ROS\").\n"
    "\n"
    "Default (--format csv): the session's decoded sensor records as CSV for other tools:\n"
    "  DIR/lidar.csv   robot_time_s,scan,beam,range_m,theta_rad   (range 0: no return;\n"
    "                  a last column intensity when the lidar gave them, e.g. an imported bag)\n"
    "  DIR/imu.csv     robot_time_s,gyro_z_rad_s,roll_rad,pitch_rad,yaw_rad\n"
    "  DIR/wheels.csv  robot_time_s,left_mps,right_mps\n";

namespace {

nlohmann::json DamageJson(const FramesLoadReport& f) {
  nlohmann::json places = nlohmann::json::array();
  for (const FramesDamage& d : f.damage) {
    places.push_back({{"first_record", d.first_record},
                      {"records", d.records},
                      {"byte_offset", d.offset},
                      {"bytes", d.bytes},
                      {"reason", d.reason},
                      {"seconds_lost", d.SecondsLost()},
                      {"at_s", d.has_before ? static_cast<double>(d.time_before_ns - f.first_time_ns) * 1e-9
                                            : 0.0}});
  }
  return {{"damaged", f.damaged()},
          {"records_skipped", f.corrupt_records_skipped},
          {"bytes_skipped", f.damaged_bytes()},
          {"seconds_lost", f.seconds_lost()},
          {"places", places}};
}

bool ParseCommon(Args* args, int argc, char** argv, const char* usage, int* code) {
  std::string error;
  if (!args->Parse(argc, argv, 2, &error)) {
    PrintError(SeeHelp(error, argv[1]));
    *code = kExitBadInput;
    return false;
  }
  if (args->Flag("help")) {
    std::cout << usage;
    *code = kExitOk;
    return false;
  }
  if (args->positional().size() != 1) {
    PrintError(SeeHelp(
        args->positional().empty() ? "missing SESSION folder" : "expected one SESSION folder",
        argv[1]));
    *code = kExitBadInput;
    return false;
  }
  return true;
}

// The recording's link outages (docs/session-format.md, "Recorder events").
nlohmann::json GapsJson(const std::vector<hardware::SessionLinkGap>& gaps) {
  nlohmann::json out = nlohmann::json::array();
  for (const hardware::SessionLinkGap& g : gaps) {
    out.push_back({{"lost_at_s", g.lost_at_s},
                   {"reason", g.reason},
                   {"restored", g.restored},
                   {"outage_s", g.outage_s},
                   {"attempts", g.attempts},
                   {"resumed", g.resumed},
                   {"resent_bytes", g.late_bytes},
                   {"new_clock_epoch", g.new_clock_epoch},
                   {"clock_epoch", g.epoch},
                   {"robot_time_shift_s", g.robot_time_shift_s},
                   {"clock_tie_uncertainty_s", g.tie_uncertainty_s},
                   {"data_lost_s",
                    {{"lidar", g.data_lost_s[0]}, {"imu", g.data_lost_s[1]},
                     {"motor_board", g.data_lost_s[2]}}}});
  }
  return out;
}

// What `info` reports of the records: counted as they stream by, so a
// 10-hour session is described in the memory of its motion records.
struct Counted {
  hardware::SessionDecodeInfo info;
  size_t scans = 0;
  size_t samples = 0;
  size_t imu = 0;
  size_t wheels = 0;
};

int CountOrFail(const Args& args, const std::string& dir, Counted* c) {
  SensorLog motion;
  hardware::SessionStreamSinks sinks;
  sinks.motion = &motion;
  sinks.scan = [c, &motion](LidarScan&& scan) {
    ++c->scans;
    c->samples += scan.samples.size();
    c->imu += motion.imu.size();
    c->wheels += motion.wheels.size();
    motion.imu.clear();
    motion.wheels.clear();
    return true;
  };
  const Status s = hardware::DecodeSessionStreaming(dir, SessionFramesOptions(args), sinks, &c->info);
  if (!s.ok()) {
    PrintSessionError(args, dir, s);
    return kExitBadInput;
  }
  c->imu += motion.imu.size();
  c->wheels += motion.wheels.size();
  return kExitOk;
}

nlohmann::json InfoJson(const std::string& dir, const Counted& d) {
  const SessionMeta& m = d.info.meta;
  const size_t samples = d.samples;
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
      {"damage", DamageJson(d.info.frames)},
      {"gaps", GapsJson(d.info.gaps)},
      {"robot_time_s", {ToSeconds(d.info.first_robot_time), ToSeconds(d.info.last_robot_time)}},
      {"duration_s", ToSeconds(d.info.last_robot_time - d.info.first_robot_time)},
      {"scans", d.scans},
      {"lidar_samples", samples},
      {"imu_records", d.imu},
      {"wheel_records", d.wheels},
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
  // A ROS bag (a file or a ROS 2 bag folder) rather than a session folder.
  for (int i = 2; i < argc; ++i) {
    if (argv[i][0] != '-' && io::LooksLikeRosBag(argv[i])) return RunBagInfo(argc, argv);
  }
  Args args({"json", "help", "strict"}, {});
  int code;
  if (!ParseCommon(&args, argc, argv, kInfoUsage, &code)) return code;
  Counted d;
  if ((code = CountOrFail(args, args.positional()[0], &d)) != kExitOk) return code;
  const nlohmann::json j = InfoJson(args.positional()[0], d);
  if (args.Flag("json")) {
    std::cout << j.dump(2) << "\n";
    return kExitOk;
  }
  std::printf("session %s (format %u, created %s)\n", args.positional()[0].c_str(),
              d.info.meta.format_version, d.info.meta.created_utc.c_str());
  std::printf("link %s, agent %s\n", d.info.meta.link.c_str(), d.info.meta.agent.c_str());
  std::printf("%s\n", d.info.ToString().c_str());
  if (d.info.frames.damaged()) {
    std::printf("DAMAGED: %s\n", d.info.frames.DamageSummary().c_str());
    std::printf("  (`sweepscan-cli repair %s --out NEW` writes a clean copy)\n", args.positional()[0].c_str());
  } else {
    std::printf("no damage\n");
  }
  if (d.info.gaps.empty()) std::printf("no link outages\n");
  std::printf("%.1f s of robot time: %zu scans (%zu samples), %zu IMU records, %zu wheel records\n",
              j["duration_s"].get<double>(), d.scans, d.samples, d.imu, d.wheels);
  std::printf("calibration in use: alpha %.5f, beta %.5f, gamma %.5f rad\n", d.info.meta.calibration.alpha,
              d.info.meta.calibration.beta, d.info.meta.calibration.gamma);
  return kExitOk;
}

// The session and the calibration file are inputs: nothing is written over
// them or into the session folder (an export's --out S/frames.bin replaced
// the recording).
int RefuseOutputIntoSession(const Args& args) {
  const std::string& session = args.positional()[0];
  return RefuseOutputOverInput(
      {{"--out", args.Get("out")}},
      {{"the session folder " + session + ", which holds the recording", session, true},
       {"the --calibration file", args.Get("calibration")}});
}

int RunReconstruct(int argc, char** argv) {
  Args args({"json", "help", "no-ekf", "no-deskew", "strict", "loop-closure"}, {"out", "calibration", "pose-source"});
  int code;
  if (!ParseCommon(&args, argc, argv, kReconstructUsage, &code)) return code;
  if ((code = RefuseOutputIntoSession(args)) != kExitOk) return code;
  if (!args.Has("out") || !IsCloudFile(args.Get("out"))) {
    // Said before the session is read, not after.
    PrintError(args.Has("out")
                   ? "--out " + args.Get("out") + ": not a cloud file (.las, .ply or .pcd)"
                   : "reconstruct needs --out CLOUD.las|CLOUD.ply|CLOUD.pcd (see "
                     "sweepscan-cli help reconstruct)");
    return kExitBadInput;
  }
  return ReconstructToFile(args, "reconstruct");
}

int RunExport(int argc, char** argv) {
  Args args({"json", "help", "strict", "no-ekf", "no-deskew", "loop-closure"},
            {"out", "format", "calibration", "frame", "pose-source"});
  int code;
  if (!ParseCommon(&args, argc, argv, kExportUsage, &code)) return code;
  if ((code = RefuseOutputIntoSession(args)) != kExitOk) return code;
  // --out FILE.las|.ply|.pcd: the cloud, exactly as `reconstruct` makes it.
  if (args.Has("out") && IsCloudFile(args.Get("out"))) {
    if (args.Has("format") || args.Has("frame")) {
      PrintError("--format and --frame are for csv and rosbag exports; --out " + args.Get("out") +
                 " exports the cloud in the format its suffix names");
      return kExitBadInput;
    }
    return ReconstructToFile(args, "export");
  }
  if (args.Has("pose-source") || args.Flag("no-deskew") || args.Flag("loop-closure")) {
    PrintError("--pose-source, --no-deskew and --loop-closure are for cloud exports (--out FILE.las|FILE.ply|FILE.pcd)");
    return kExitBadInput;
  }
  const std::string format = args.Has("format") ? args.Get("format") : "csv";
  if (format != "csv" && format != "rosbag") {
    PrintError("--format must be csv or rosbag, got '" + format + "'");
    return kExitBadInput;
  }
  if (!args.Has("out")) {
    PrintError(format == "csv" ? "export needs --out DIR" : "export --format rosbag needs --out FILE.bag");
    return kExitBadInput;
  }
  if (format == "csv" &&
      (code = RefuseOptions(args, {"calibration", "no-ekf", "frame"},
                            "a CSV export (it writes the sensor records as recorded)")) !=
          kExitOk) {
    return code;
  }
  Decoded d;
  if ((code = DecodeOrFail(args, args.positional()[0], &d)) != kExitOk) return code;
  if (format == "rosbag") return ExportRosbag(args, d.log, d.info.meta);
  const std::string dir = args.Get("out");
  const bool created = ::mkdir(dir.c_str(), 0755) == 0;
  if (!created && errno != EEXIST) {
    PrintError(dir + ": cannot create folder: " + std::strerror(errno));
    return kExitFailure;
  }
  struct stat st;
  if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    PrintError(dir + ": exists and is not a folder");
    return kExitFailure;
  }
  // Each file through the checked writer: complete under its name, or absent.
  // `written`: the files this export made that were not there before (an
  // earlier export's it replaced cannot be given back, and stay).
  std::vector<std::string> written;
  auto write = [&](const std::string& name, const std::string& header, auto&& rows) -> Status {
    struct stat before;
    const bool existed = ::stat((dir + "/" + name).c_str(), &before) == 0;
    CheckedFileWriter out;
    Status s = out.Open(dir + "/" + name);
    if (!s.ok()) return s;
    std::string text = header + "\n";
    auto flush = [&]() {
      if (s.ok()) s = out.Write(text);
      text.clear();
    };
    rows(&text, flush);
    flush();
    if (!s.ok()) return s;
    s = out.Commit();
    if (s.ok() && !existed) written.push_back(dir + "/" + name);
    return s;
  };
  auto line = [](std::string* text, const char* format, auto... values) {
    char buf[256];
    const int n = std::snprintf(buf, sizeof(buf), format, values...);
    text->append(buf, static_cast<size_t>(std::max(0, std::min(n, static_cast<int>(sizeof(buf)) - 1))));
  };
  constexpr size_t kChunk = 1 << 20;
  size_t samples = 0;
  // Intensities only where the lidar gave them (an imported bag's; the X4 has none).
  bool intensities = false;
  for (const auto& scan : d.log.scans) {
    for (const auto& m : scan.samples) intensities = intensities || m.intensity != 0.0f;
  }
  const char* lidar_header =
      intensities ? "robot_time_s,scan,beam,range_m,theta_rad,intensity" : "robot_time_s,scan,beam,range_m,theta_rad";
  Status s = write("lidar.csv", lidar_header, [&](std::string* t, auto&& flush) {
    for (const auto& scan : d.log.scans) {
      for (const auto& m : scan.samples) {
        if (intensities) {
          line(t, "%.9f,%u,%u,%.4f,%.6f,%g\n", ToSeconds(m.time), scan.index, m.beam, m.range_m, m.theta,
               m.intensity);
        } else {
          line(t, "%.9f,%u,%u,%.4f,%.6f\n", ToSeconds(m.time), scan.index, m.beam, m.range_m, m.theta);
        }
        ++samples;
        if (t->size() > kChunk) flush();
      }
    }
  });
  if (s.ok()) {
    s = write("imu.csv", "robot_time_s,gyro_z_rad_s,roll_rad,pitch_rad,yaw_rad", [&](std::string* t, auto&& flush) {
      for (const auto& m : d.log.imu) {
        line(t, "%.9f,%.7f,%.7f,%.7f,%.7f\n", ToSeconds(m.time), m.gyro_z, m.roll, m.pitch, m.yaw);
        if (t->size() > kChunk) flush();
      }
    });
  }
  if (s.ok()) {
    s = write("wheels.csv", "robot_time_s,left_mps,right_mps", [&](std::string* t, auto&& flush) {
      for (const auto& m : d.log.wheels) {
        line(t, "%.9f,%.6f,%.6f\n", ToSeconds(m.time), m.left_mps, m.right_mps);
        if (t->size() > kChunk) flush();
      }
    });
  }
  if (!s.ok()) {  // a full disk: no new lidar.csv without its imu.csv, no empty folder
    for (const std::string& path : written) ::unlink(path.c_str());
    if (created) ::rmdir(dir.c_str());
    PrintError(s.message());
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

int RunRepair(int argc, char** argv) {
  Args args({"json", "help"}, {"out"});
  int code;
  if (!ParseCommon(&args, argc, argv, kRepairUsage, &code)) return code;
  if (!args.Has("out")) {
    PrintError("repair needs --out NEW (a new session folder)");
    return kExitBadInput;
  }
  const std::string in = args.positional()[0];
  const std::string out = args.Get("out");
  // Streamed: each intact record is written as it is read, so a session of
  // hours repairs in the memory of one record (the whole session, ~2 GB for
  // ten hours, was held before). meta.json is checked before anything is
  // created; frames.bin's damage is only known once it has been read.
  struct stat st;
  if (::stat(in.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    PrintError(in + ": not a session folder (does not exist or is not a folder)");
    return kExitBadInput;
  }
  SessionMeta meta;
  Status s = ReadSessionMeta(in + "/" + kSessionMetaFile, &meta);
  if (!s.ok()) {
    PrintError(s.message());
    return kExitBadInput;
  }
  std::vector<std::string> extra_files;  // Other regular files of the folder, copied as they are.
  if (DIR* dp = ::opendir(in.c_str())) {
    while (const dirent* e = ::readdir(dp)) {
      const std::string name = e->d_name;
      if (name == "." || name == ".." || name == kSessionFramesFile || IsTemporaryFileName(name)) continue;
      struct stat fst;
      if (::stat((in + "/" + name).c_str(), &fst) == 0 && S_ISREG(fst.st_mode)) extra_files.push_back(name);
    }
    ::closedir(dp);
  }
  if (const Status free = CheckNewSessionFolder(out); !free.ok()) {
    PrintError(free.message() + " (repair writes a new session folder)");
    return kExitFailure;  // an output in the way, as for every command (README)
  }
  // Written beside NEW and renamed to it once whole: a repair killed
  // midway (or a power loss) leaves a hidden .NEW.repairing-PID, never a
  // NEW without its meta.json or side files that opens as if complete.
  const std::string writing = SessionWritingDir(out, "repairing");
  std::error_code gone;
  std::filesystem::remove_all(writing, gone);  // a killed repair's, whose PID this one has
  if (::mkdir(writing.c_str(), 0755) != 0) {
    PrintError(out + ": cannot create folder: " + std::strerror(errno));
    return kExitFailure;
  }
  const auto remove_writing = [&] { std::filesystem::remove_all(writing, gone); };
  // frames.bin: the header, then every intact record, through the checked
  // writer (docs/session-format.md: length, receive time, bytes, CRC-32C of
  // the three).
  CheckedFileWriter frames;
  s = frames.Open(writing + "/" + kSessionFramesFile);
  std::vector<uint8_t> bytes = SessionFramesHeader();
  if (s.ok()) s = frames.Write(bytes.data(), bytes.size());
  FramesLoadReport f;
  Status read = Status::Ok();
  if (s.ok()) {
    read = VisitFramesFile(
        in + "/" + kSessionFramesFile, hardware::DefaultSessionFramesOptions(),
        [&](const SessionRecordView& r) {
          bytes.clear();
          AppendSessionRecord(r.bytes, r.size, r.receive_time_ns, &bytes);
          s = frames.Write(bytes.data(), bytes.size());
          return s.ok();  // a write that failed stops the read
        },
        &f);
  }
  if (s.ok() && !read.ok()) {  // frames.bin refused: nothing is left behind
    frames.Abort();
    remove_writing();
    PrintError(read.message());
    return kExitBadInput;
  }
  if (s.ok()) s = frames.Commit();
  for (const std::string& name : extra_files) {
    if (!s.ok()) break;
    s = CopyFileChecked(in + "/" + name, writing + "/" + name);
  }
  if (s.ok()) s = RenameSessionIntoPlace(writing, out);
  if (!s.ok()) {  // a full disk: no half copy is left to pass for a repair
    frames.Abort();
    remove_writing();
    PrintError(SaidOfSession(s, writing, out).message());
    return kExitFailure;
  }
  const nlohmann::json report = {{"session", in},
                                 {"out", out},
                                 {"records_kept", f.records},
                                 {"damage", DamageJson(f)},
                                 {"torn_tail_bytes_dropped", f.truncated_tail ? f.tail_bytes_dropped : 0},
                                 {"files_copied", extra_files}};
  if (args.Flag("json")) {
    std::cout << report.dump(2) << "\n";
  } else {
    std::printf("repaired %s -> %s: %llu records kept", in.c_str(), out.c_str(),
                static_cast<unsigned long long>(f.records));
    if (f.damaged()) std::printf("; left out %s", f.DamageSummary().c_str());
    if (f.truncated_tail) std::printf("; torn tail of %llu bytes dropped", static_cast<unsigned long long>(f.tail_bytes_dropped));
    std::printf("\n");
  }
  return kExitOk;
}

}  // namespace sweepscan::app
