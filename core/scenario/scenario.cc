#include "core/scenario/scenario.h"

#include <cmath>

#include "core/common/json_reader.h"

namespace sweepscan {

using nlohmann::json;
using sim::SimConfig;

namespace {

Eigen::Vector3d Vec3(const JsonObject& o, const std::string& key) {
  const json& a = o.Array(key);
  if (a.size() != 3) o.Fail(key, "expected 3 numbers, got " + std::to_string(a.size()));
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) {
    if (!a[i].is_number())
      o.Fail(key + "[" + std::to_string(i) + "]", "expected a number, got " + JsonTypeName(a[i]));
    v[i] = a[i].get<double>();
  }
  return v;
}

sim::Box ReadBox(const JsonObject& o) {
  o.AllowOnly({"label", "center", "size", "yaw_rad", "pitch_rad", "inside", "dropout"});
  sim::Box b;
  b.label = o.String("label", "");
  b.center = Vec3(o, "center");
  b.size = Vec3(o, "size");
  for (int i = 0; i < 3; ++i) {
    if (!(b.size[i] > 0.0)) {
      o.Fail("size[" + std::to_string(i) + "]", "must be > 0, got " + std::to_string(b.size[i]));
    }
  }
  b.yaw = o.Number("yaw_rad", 0.0);
  b.pitch = o.Number("pitch_rad", 0.0);
  b.inside = o.Bool("inside", false);
  b.dropout = o.InRange("dropout", 0.0, 1.0, 0.0);
  return b;
}

void ReadScene(const JsonObject& o, SimConfig* c) {
  o.AllowOnly({"preset", "boxes"});
  if (!o.Has("preset") && !o.Has("boxes"))
    o.Fail("preset", "missing (give a preset, boxes, or both)");
  if (o.Has("preset")) {
    const std::string preset = o.String("preset");
    if (preset == "lab") {
      c->scene = sim::LabScene();
    } else if (preset == "lab-diamond") {
      c->scene = sim::LabScene(sim::LabTarget::kDiamond);
    } else if (preset == "stairwell") {
      c->scene = sim::StairwellScene();
    } else if (preset == "office-floor") {
      c->scene = sim::OfficeFloorScene();
    } else if (preset == "empty") {
      c->scene = sim::Scene();
    } else {
      o.Fail("preset", "unknown preset '" + preset + "' (lab, lab-diamond, stairwell, office-floor, empty)");
    }
  }
  if (o.Has("boxes")) {
    const json& boxes = o.Array("boxes");
    for (size_t i = 0; i < boxes.size(); ++i) {
      c->scene.Add(ReadBox(JsonObject(boxes[i], o.Path("boxes") + "[" + std::to_string(i) + "]")));
    }
  }
  if (c->scene.boxes().empty()) o.Fail("boxes", "the scene has no boxes");
}

// o.segments: straight/turning segments or circles (docs/scenario-format.md).
void ReadSegments(const JsonObject& o, std::vector<sim::DriveSegment>* path) {
  const json& segs = o.Array("segments");
  if (segs.empty()) o.Fail("segments", "needs at least one segment");
  for (size_t i = 0; i < segs.size(); ++i) {
    const JsonObject s(segs[i], o.Path("segments") + "[" + std::to_string(i) + "]");
    if (s.Has("circle_radius_m")) {
      s.AllowOnly({"circle_radius_m", "v_mps", "turns", "direction"});
      const std::string dir = s.String("direction", "left");
      if (dir != "left" && dir != "right") s.Fail("direction", "must be 'left' or 'right'");
      path->push_back(CircleSegment(s.Positive("circle_radius_m"), s.Positive("v_mps"),
                                    s.Positive("turns"), dir == "left"));
    } else {
      s.AllowOnly({"v_mps", "w_radps", "duration_s"});
      path->push_back({s.Number("v_mps"), s.Number("w_radps"), s.Positive("duration_s")});
    }
    const sim::DriveSegment& d = path->back();
    if (std::abs(d.v) > 2.0 || std::abs(d.w) > 5.0) {
      s.Fail("v_mps", "speed beyond the robot's limits (|v| <= 2 m/s, |w| <= 5 rad/s)");
    }
  }
  // A week at most: 1e308 s made a session of a header alone, 2^32 s a
  // recording that grew by 12 MB a second until the disk was full.
  constexpr double kMaxPathS = 7 * 86400.0;
  double total_s = 0.0;
  for (const sim::DriveSegment& d : *path) total_s += d.duration_s;
  if (!(total_s <= kMaxPathS)) {
    o.Fail("segments",
           "the path lasts " + std::to_string(total_s) + " s; at most a week (604800 s) is driven");
  }
}

void ReadPath(const JsonObject& o, SimConfig* c) {
  o.AllowOnly({"start", "segments"});
  const JsonObject start = o.Object("start");
  start.AllowOnly({"x_m", "y_m", "yaw_rad"});
  c->start = {start.Number("x_m"), start.Number("y_m"), start.Number("yaw_rad")};
  // Within the 8 000 m a cloud's float positions keep to the millimetre.
  if (std::abs(c->start.x) > 8000.0 || std::abs(c->start.y) > 8000.0) {
    start.Fail("x_m", "the start must be within 8000 m of the world's origin in x and y");
  }
  ReadSegments(o, &c->path);
}

// One reader per section of the file (docs/scenario-format.md); each throws
// JsonError with the JSON path of the first problem.
void ReadRobot(const JsonObject& r, SimConfig* config) {
  SimConfig& c = *config;
  r.AllowOnly({"lidar_height_m", "lidar_offset_x_m", "imu_offset_x_m", "wheel_distance_m"});
  c.geometry.lidar_height_m = r.Positive("lidar_height_m", c.geometry.lidar_height_m);
  c.geometry.lidar_offset_x_m = r.Number("lidar_offset_x_m", c.geometry.lidar_offset_x_m);
  c.geometry.imu_offset_x_m = r.Number("imu_offset_x_m", c.geometry.imu_offset_x_m);
  c.geometry.wheel_distance_m = r.Positive("wheel_distance_m", c.geometry.wheel_distance_m);
}

void ReadMountingError(const JsonObject& m, SimConfig* config) {
  SimConfig& c = *config;
  m.AllowOnly({"alpha", "beta", "gamma"});
  c.mounting_error = {m.InRange("alpha", -0.5, 0.5, 0.0), m.InRange("beta", -0.5, 0.5, 0.0),
                      m.InRange("gamma", -0.5, 0.5, 0.0)};
}

void ReadLidar(const JsonObject& l, SimConfig* config) {
  SimConfig& c = *config;
  l.AllowOnly({"scan_rate_hz", "sample_rate_hz", "min_range_m", "max_range_m", "range_noise_m",
               "range_noise_fraction", "range_quantum_m", "dropout_probability",
               "grazing_dropout_start_deg", "grazing_dropout_end_deg", "angle_sign",
               "angle_offset_rad", "model_angle_correction", "range_offset_m", "time_offset_s",
               "range_scale_error", "mixed_return_share", "mixed_blend_share", "mixed_footprint_rad",
               "mixed_min_jump_m"});
  sim::LidarSpec& s = c.lidar;
  s.scan_rate_hz = l.InRange("scan_rate_hz", 1.0, 50.0, s.scan_rate_hz);
  s.sample_rate_hz = l.InRange("sample_rate_hz", 100.0, 100000.0, s.sample_rate_hz);
  s.min_range_m = l.NonNegative("min_range_m", s.min_range_m);
  s.max_range_m = l.Positive("max_range_m", s.max_range_m);
  s.range_noise_m = l.NonNegative("range_noise_m", s.range_noise_m);
  s.range_noise_fraction = l.NonNegative("range_noise_fraction", s.range_noise_fraction);
  s.range_quantum_m = l.NonNegative("range_quantum_m", s.range_quantum_m);
  s.dropout_probability = l.InRange("dropout_probability", 0.0, 1.0, s.dropout_probability);
  s.grazing_dropout_start_deg =
      l.InRange("grazing_dropout_start_deg", 0.0, 90.0, s.grazing_dropout_start_deg);
  s.grazing_dropout_end_deg =
      l.InRange("grazing_dropout_end_deg", 0.0, 90.0, s.grazing_dropout_end_deg);
  if (l.Has("angle_sign")) {
    const int64_t sign = l.Integer("angle_sign");
    if (sign != 1 && sign != -1) l.Fail("angle_sign", "must be 1 or -1");
    s.angle_convention.sign = static_cast<int>(sign);
  }
  s.angle_convention.offset_rad = l.Number("angle_offset_rad", s.angle_convention.offset_rad);
  s.model_angle_correction = l.Bool("model_angle_correction", s.model_angle_correction);
  s.range_offset_m = l.InRange("range_offset_m", -0.1, 0.1, s.range_offset_m);
  s.time_offset_s = l.InRange("time_offset_s", -0.1, 0.1, s.time_offset_s);
  s.range_scale_error = l.InRange("range_scale_error", -0.05, 0.05, s.range_scale_error);
  s.mixed_return_share = l.InRange("mixed_return_share", 0.0, 1.0, s.mixed_return_share);
  s.mixed_blend_share = l.InRange("mixed_blend_share", 0.0, 1.0, s.mixed_blend_share);
  s.mixed_footprint_rad = l.InRange("mixed_footprint_rad", 0.0, 0.1, s.mixed_footprint_rad);
  s.mixed_min_jump_m = l.InRange("mixed_min_jump_m", 1e-4, 10.0, s.mixed_min_jump_m);
  if (s.max_range_m <= s.min_range_m) l.Fail("max_range_m", "must exceed min_range_m");
  if (s.grazing_dropout_end_deg <= s.grazing_dropout_start_deg) {
    l.Fail("grazing_dropout_end_deg", "must exceed grazing_dropout_start_deg");
  }
}

void ReadImu(const JsonObject& m, SimConfig* config) {
  SimConfig& c = *config;
  m.AllowOnly({"rate_hz", "gyro_noise_rad_s", "gyro_bias_rad_s", "tilt_noise_rad", "yaw_noise_rad",
               "yaw_reference_offset_rad"});
  sim::ImuSpec& s = c.imu;
  s.rate_hz = m.InRange("rate_hz", 1.0, 2000.0, s.rate_hz);
  s.gyro_noise_rad_s = m.NonNegative("gyro_noise_rad_s", s.gyro_noise_rad_s);
  s.gyro_bias_rad_s = m.Number("gyro_bias_rad_s", s.gyro_bias_rad_s);
  s.tilt_noise_rad = m.NonNegative("tilt_noise_rad", s.tilt_noise_rad);
  s.yaw_noise_rad = m.NonNegative("yaw_noise_rad", s.yaw_noise_rad);
  s.yaw_reference_offset_rad = m.Number("yaw_reference_offset_rad", s.yaw_reference_offset_rad);
}

void ReadOdometry(const JsonObject& m, SimConfig* config) {
  SimConfig& c = *config;
  m.AllowOnly({"rate_hz", "scale_error_left", "scale_error_right", "speed_noise_mps"});
  sim::OdometrySpec& s = c.odometry;
  s.rate_hz = m.InRange("rate_hz", 1.0, 1000.0, s.rate_hz);
  s.scale_error_left = m.InRange("scale_error_left", -0.5, 0.5, s.scale_error_left);
  s.scale_error_right = m.InRange("scale_error_right", -0.5, 0.5, s.scale_error_right);
  s.speed_noise_mps = m.NonNegative("speed_noise_mps", s.speed_noise_mps);
}

void ReadSlips(const json& slips, SimConfig* config) {
  SimConfig& c = *config;
  for (size_t i = 0; i < slips.size(); ++i) {
    const JsonObject s(slips[i], "slips[" + std::to_string(i) + "]");
    s.AllowOnly({"start_s", "duration_s", "wheel", "extra"});
    sim::SlipEvent e;
    e.start_s = s.NonNegative("start_s", 0.0);
    e.duration_s = s.Positive("duration_s");
    const std::string wheel = s.String("wheel");
    if (wheel != "left" && wheel != "right") s.Fail("wheel", "must be 'left' or 'right'");
    e.left = wheel == "left";
    e.extra = s.InRange("extra", -0.9, 10.0, 0.0);
    if (!s.Has("extra")) s.Fail("extra", "missing");
    c.slips.push_back(e);
  }
}

}  // namespace

sim::DriveSegment CircleSegment(double radius_m, double speed_mps, double turns, bool left) {
  const double w = (left ? 1.0 : -1.0) * speed_mps / radius_m;
  return {speed_mps, w, turns * 2.0 * M_PI * radius_m / speed_mps};
}

Status ScenarioFromJson(const json& j, const std::string& source, SimConfig* config) {
  SimConfig c;
  try {
    const JsonObject root(j, "");
    root.AllowOnly({"format", "version", "name", "seed", "scene", "robot", "mounting_error_rad",
                    "lidar", "imu", "odometry", "slips", "path"});
    if (root.String("format") != "sweepscan-scenario") {
      root.Fail("format", "must be \"sweepscan-scenario\" (is this a scenario file?)");
    }
    const int64_t version = root.Integer("version");
    if (version != kScenarioFormatVersion) {
      root.Fail("version", "unsupported version " + std::to_string(version) +
                               " (this build reads " + std::to_string(kScenarioFormatVersion) +
                               ")");
    }
    c.name = root.String("name", "");
    if (root.Has("seed")) {
      const int64_t seed = root.Integer("seed");
      if (seed < 0) root.Fail("seed", "must be >= 0");
      c.seed = static_cast<uint64_t>(seed);
    }
    ReadScene(root.Object("scene"), &c);

    if (root.Has("robot")) ReadRobot(root.Object("robot"), &c);
    if (root.Has("mounting_error_rad")) ReadMountingError(root.Object("mounting_error_rad"), &c);
    if (root.Has("lidar")) ReadLidar(root.Object("lidar"), &c);
    if (root.Has("imu")) ReadImu(root.Object("imu"), &c);
    if (root.Has("odometry")) ReadOdometry(root.Object("odometry"), &c);
    if (root.Has("slips")) ReadSlips(root.Array("slips"), &c);
    ReadPath(root.Object("path"), &c);
  } catch (const JsonError& e) {
    return Status::Error(source + ": " + e.what());
  }
  std::string error;
  if (!c.IsValid(&error)) return Status::Error(source + ": " + error);
  *config = std::move(c);
  return Status::Ok();
}

Status LoadDriveScript(const std::string& path, std::vector<sim::DriveSegment>* segments) {
  json j;
  Status s = ReadJsonFile(path, &j);
  if (!s.ok()) return s;
  if (j.is_object() && j.contains("format")) {  // A scenario: its path's segments.
    SimConfig scenario;
    s = ScenarioFromJson(j, path, &scenario);
    if (!s.ok()) return s;
    *segments = scenario.path;
    return Status::Ok();
  }
  std::vector<sim::DriveSegment> read;
  try {
    const JsonObject root(j, "");
    root.AllowOnly({"segments"});
    ReadSegments(root, &read);
  } catch (const JsonError& e) {
    return Status::Error(path + ": " + e.what());
  }
  *segments = std::move(read);
  return Status::Ok();
}

Status LoadScenario(const std::string& path, SimConfig* config) {
  json j;
  Status s = ReadJsonFile(path, &j);
  if (!s.ok()) return s;
  return ScenarioFromJson(j, path, config);
}

json ScenarioToJson(const SimConfig& c) {
  json boxes = json::array();
  for (const sim::Box& b : c.scene.boxes()) {
    boxes.push_back({{"label", b.label},
                     {"center", {b.center.x(), b.center.y(), b.center.z()}},
                     {"size", {b.size.x(), b.size.y(), b.size.z()}},
                     {"yaw_rad", b.yaw},
                     {"pitch_rad", b.pitch},
                     {"inside", b.inside},
                     {"dropout", b.dropout}});
  }
  json segments = json::array();
  for (const sim::DriveSegment& s : c.path) {
    segments.push_back({{"v_mps", s.v}, {"w_radps", s.w}, {"duration_s", s.duration_s}});
  }
  json slips = json::array();
  for (const sim::SlipEvent& s : c.slips) {
    slips.push_back({{"start_s", s.start_s},
                     {"duration_s", s.duration_s},
                     {"wheel", s.left ? "left" : "right"},
                     {"extra", s.extra}});
  }
  const sim::LidarSpec& l = c.lidar;
  return {
      {"format", "sweepscan-scenario"},
      {"version", kScenarioFormatVersion},
      {"name", c.name},
      {"seed", c.seed},
      {"scene", {{"boxes", boxes}}},
      {"robot",
       {{"lidar_height_m", c.geometry.lidar_height_m},
        {"lidar_offset_x_m", c.geometry.lidar_offset_x_m},
        {"imu_offset_x_m", c.geometry.imu_offset_x_m},
        {"wheel_distance_m", c.geometry.wheel_distance_m}}},
      {"mounting_error_rad",
       {{"alpha", c.mounting_error.alpha},
        {"beta", c.mounting_error.beta},
        {"gamma", c.mounting_error.gamma}}},
      {"lidar",
       {{"scan_rate_hz", l.scan_rate_hz},
        {"sample_rate_hz", l.sample_rate_hz},
        {"min_range_m", l.min_range_m},
        {"max_range_m", l.max_range_m},
        {"range_noise_m", l.range_noise_m},
        {"range_noise_fraction", l.range_noise_fraction},
        {"range_quantum_m", l.range_quantum_m},
        {"dropout_probability", l.dropout_probability},
        {"grazing_dropout_start_deg", l.grazing_dropout_start_deg},
        {"grazing_dropout_end_deg", l.grazing_dropout_end_deg},
        {"angle_sign", l.angle_convention.sign},
        {"angle_offset_rad", l.angle_convention.offset_rad},
        {"model_angle_correction", l.model_angle_correction},
        {"range_offset_m", l.range_offset_m},
        {"time_offset_s", l.time_offset_s},
        {"range_scale_error", l.range_scale_error},
        {"mixed_return_share", l.mixed_return_share},
        {"mixed_blend_share", l.mixed_blend_share},
        {"mixed_footprint_rad", l.mixed_footprint_rad},
        {"mixed_min_jump_m", l.mixed_min_jump_m}}},
      {"imu",
       {{"rate_hz", c.imu.rate_hz},
        {"gyro_noise_rad_s", c.imu.gyro_noise_rad_s},
        {"gyro_bias_rad_s", c.imu.gyro_bias_rad_s},
        {"tilt_noise_rad", c.imu.tilt_noise_rad},
        {"yaw_noise_rad", c.imu.yaw_noise_rad},
        {"yaw_reference_offset_rad", c.imu.yaw_reference_offset_rad}}},
      {"odometry",
       {{"rate_hz", c.odometry.rate_hz},
        {"scale_error_left", c.odometry.scale_error_left},
        {"scale_error_right", c.odometry.scale_error_right},
        {"speed_noise_mps", c.odometry.speed_noise_mps}}},
      {"slips", slips},
      {"path",
       {{"start", {{"x_m", c.start.x}, {"y_m", c.start.y}, {"yaw_rad", c.start.yaw}}},
        {"segments", segments}}},
  };
}

}  // namespace sweepscan
