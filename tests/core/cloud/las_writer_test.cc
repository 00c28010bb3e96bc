// LAS 1.4 export. First our own strict parse of the bytes at the offsets of
// the ASPRS LAS 1.4 R15 specification (§2.4 header, §2.5 VLR headers, §2.6
// point format 6, §3.2 WKT, §4.3 Extra Bytes), GPS times of known instants,
// streaming and refusals; then a simulated session exported by the CLI and
// read back by two independent readers in node (tests/tools/read_las.mjs:
// @loaders.gl/las and copc.js), compared with the PLY export of the same
// session. Needs node and tests/tools/node_modules (scripts/install-test-tools.sh).
#include "core/cloud/las_writer.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/cloud/cloud_io.h"
#include "core/session/session.h"
#include "tests/testing/remove_at_exit.h"
#include "tests/testing/run_command.h"

namespace sweepscan {
namespace {

using sweepscan::testing::CommandRun;
using sweepscan::testing::RunCommand;

std::string Dir() {
  static const std::string dir = [] {
    const std::string d = ::testing::TempDir() + "/sweepscan_las_" + std::to_string(::getpid());
    EXPECT_EQ(RunCommand("rm -rf '" + d + "' && mkdir -p '" + d + "'").code, 0);
    return sweepscan::testing::RemoveAtExit(d);
  }();
  return dir;
}
void MakeFolder(const std::string& dir) { EXPECT_EQ(RunCommand("mkdir -p '" + dir + "'").code, 0); }
std::string Tmp(const std::string& name) { return Dir() + "/" + name; }
std::string Ls(const std::string& dir) { return RunCommand("ls -A '" + dir + "'").out; }

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

template <typename T>
T Get(const std::string& b, size_t at) {
  T v{};
  if (at + sizeof(T) <= b.size()) std::memcpy(&v, b.data() + at, sizeof(T));
  return v;
}

// A 12 x 7 x 3 m room away from the origin, sampled at 10 kHz from t = 12.5 s.
std::vector<CloudPoint> RoomPoints(size_t n) {
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> x(-3.0f, 9.0f), y(0.2f, 7.2f), z(-0.1f, 2.9f), r(0.1f, 8.0f);
  std::vector<CloudPoint> pts(n);
  for (size_t i = 0; i < n; ++i) {
    CloudPoint& p = pts[i];
    p.x = x(rng);
    p.y = y(rng);
    p.z = z(rng);
    p.range_m = r(rng);
    p.time_ns = 12'500'000'000 + static_cast<int64_t>(i) * 100'000;
    p.scan = static_cast<uint32_t>(i / 500);
    p.beam = static_cast<uint16_t>(i % 500);
    p.pose_source = static_cast<uint8_t>(i % 4);
    p.flags = i % 7 == 0 ? 1 : 0;
  }
  return pts;
}

LasWriterOptions OptionsFor(const std::vector<CloudPoint>& pts, const std::string& created_utc = "2026-11-22T10:15:00Z") {
  LasExtent extent;
  extent.Add(pts.data(), pts.size());
  LasWriterOptions o;
  o.extent = extent;
  SetLasTimeFromSession(created_utc, extent, &o);
  o.system_identifier = "sweepscan YDLIDAR X4";
  o.generating_software = "sweepscan 0.1.0";
  return o;
}

Status Write(const std::string& path, const std::vector<CloudPoint>& pts, const LasWriterOptions& o,
             size_t chunk = 4096, LasWriteStats* stats = nullptr) {
  LasWriter w;
  Status s = w.Open(path, o);
  for (size_t i = 0; s.ok() && i < pts.size(); i += chunk) s = w.Append(pts.data() + i, std::min(chunk, pts.size() - i));
  if (s.ok()) s = w.Finish();
  if (stats != nullptr) *stats = w.stats();
  return s;
}

// 2026-11-22T10:15:00Z: Unix 1795342500 s; GPS = Unix - 315964800 + 18.
constexpr double kAdjustedGps20261122 = 1795342500.0 - 315964800.0 + 18.0 - 1e9;

TEST(LasWriterTest, HeaderVlrsAndRecordsAreWhereTheSpecSaysThem) {
  const std::vector<CloudPoint> pts = RoomPoints(60001);  // Crosses the ~1 MiB buffer twice.
  const std::string path = Tmp("room.las");
  ASSERT_TRUE(Write(path, pts, OptionsFor(pts), 1000).ok());
  const std::string b = ReadBytes(path);
  const std::string wkt = kSweepscanSessionWkt;
  const size_t vlr2 = 375 + 54 + wkt.size() + 1;
  const size_t data = vlr2 + 54 + 4 * 192;
  ASSERT_EQ(b.size(), data + pts.size() * 41);

  // §2.4 Public Header Block.
  EXPECT_EQ(b.substr(0, 4), "LASF");
  EXPECT_EQ(Get<uint16_t>(b, 4), 0);                   // File Source ID
  EXPECT_EQ(Get<uint16_t>(b, 6), 0x11);                // Adjusted GPS time | WKT
  EXPECT_EQ(b.substr(8, 16), std::string(16, '\0'));   // Project ID
  EXPECT_EQ(Get<uint8_t>(b, 24), 1);
  EXPECT_EQ(Get<uint8_t>(b, 25), 4);
  EXPECT_EQ(b.substr(26, 32), "sweepscan YDLIDAR X4" + std::string(12, '\0'));
  EXPECT_EQ(b.substr(58, 32), "sweepscan 0.1.0" + std::string(17, '\0'));
  EXPECT_EQ(Get<uint16_t>(b, 90), 326);  // 22 November 2026
  EXPECT_EQ(Get<uint16_t>(b, 92), 2026);
  EXPECT_EQ(Get<uint16_t>(b, 94), 375);
  EXPECT_EQ(Get<uint32_t>(b, 96), data);
  EXPECT_EQ(Get<uint32_t>(b, 100), 2u);
  EXPECT_EQ(Get<uint8_t>(b, 104), 6);
  EXPECT_EQ(Get<uint16_t>(b, 105), 41);
  EXPECT_EQ(b.substr(107, 24), std::string(24, '\0'));  // Legacy counts: 0 for PDRF 6.
  for (int k = 0; k < 3; ++k) EXPECT_EQ(Get<double>(b, 131 + 8 * k), 0.0001);
  // Offsets: the box's centre rounded to a whole metre; the box is about
  // x [-3, 9], y [0.2, 7.2], z [-0.1, 2.9].
  EXPECT_EQ(Get<double>(b, 155), 3.0);
  EXPECT_EQ(Get<double>(b, 163), 4.0);
  EXPECT_EQ(Get<double>(b, 171), 1.0);
  EXPECT_EQ(Get<uint64_t>(b, 227), 0u);  // Waveform data
  EXPECT_EQ(Get<uint64_t>(b, 235), 0u);  // First EVLR
  EXPECT_EQ(Get<uint32_t>(b, 243), 0u);
  EXPECT_EQ(Get<uint64_t>(b, 247), pts.size());
  EXPECT_EQ(Get<uint64_t>(b, 255), pts.size());  // All return 1.
  for (int r = 1; r < 15; ++r) EXPECT_EQ(Get<uint64_t>(b, 255 + 8 * r), 0u);

  // §2.5 / §3.2: the WKT VLR, null-terminated.
  EXPECT_EQ(Get<uint16_t>(b, 375), 0);
  EXPECT_EQ(b.substr(377, 16), std::string("LASF_Projection") + '\0');
  EXPECT_EQ(Get<uint16_t>(b, 393), 2112);
  EXPECT_EQ(Get<uint16_t>(b, 395), wkt.size() + 1);
  EXPECT_EQ(b.substr(397, 32), "OGC Coordinate System WKT" + std::string(7, '\0'));
  EXPECT_EQ(b.substr(429, wkt.size() + 1), wkt + '\0');
  // §4.3: the Extra Bytes VLR, four 192-byte descriptors.
  EXPECT_EQ(Get<uint16_t>(b, vlr2), 0);
  EXPECT_EQ(b.substr(vlr2 + 2, 16), "LASF_Spec" + std::string(7, '\0'));
  EXPECT_EQ(Get<uint16_t>(b, vlr2 + 18), 4);
  EXPECT_EQ(Get<uint16_t>(b, vlr2 + 20), 4 * 192);
  const struct {
    uint8_t type;
    const char* name;
  } kFields[] = {{9, "range"}, {5, "scan"}, {3, "beam"}, {1, "flags"}};
  for (int f = 0; f < 4; ++f) {
    const size_t d = vlr2 + 54 + 192 * f;
    EXPECT_EQ(Get<uint16_t>(b, d), 0);
    EXPECT_EQ(Get<uint8_t>(b, d + 2), kFields[f].type);
    EXPECT_EQ(Get<uint8_t>(b, d + 3), 0);  // options: no no_data/min/max/scale/offset
    EXPECT_EQ(b.substr(d + 4, 32), kFields[f].name + std::string(32 - std::strlen(kFields[f].name), '\0'));
    EXPECT_EQ(b.substr(d + 36, 124), std::string(124, '\0'));
    EXPECT_NE(b[d + 160], '\0');  // a description
  }

  // §2.6 PDRF 6 + extra bytes: every record.
  const double scale = 0.0001, offset[3] = {3.0, 4.0, 1.0};
  int32_t lo[3] = {INT32_MAX, INT32_MAX, INT32_MAX}, hi[3] = {INT32_MIN, INT32_MIN, INT32_MIN};
  double worst_xyz = 0.0, worst_gps = 0.0;
  size_t bad_fields = 0;
  for (size_t i = 0; i < pts.size(); ++i) {
    const size_t r = data + 41 * i;
    const CloudPoint& p = pts[i];
    const float in[3] = {p.x, p.y, p.z};
    for (int k = 0; k < 3; ++k) {
      const int32_t rec = Get<int32_t>(b, r + 4 * k);
      lo[k] = std::min(lo[k], rec);
      hi[k] = std::max(hi[k], rec);
      worst_xyz = std::max(worst_xyz, std::abs(rec * scale + offset[k] - in[k]));
    }
    const double gps = kAdjustedGps20261122 + static_cast<double>(p.time_ns - 12'500'000'000) * 1e-9;
    worst_gps = std::max(worst_gps, std::abs(Get<double>(b, r + 22) - gps));
    bad_fields += Get<uint16_t>(b, r + 12) != 0 || Get<uint8_t>(b, r + 14) != 0x11 || Get<uint8_t>(b, r + 15) != 0 ||
                  Get<uint8_t>(b, r + 16) != 0 || Get<uint8_t>(b, r + 17) != p.pose_source ||
                  Get<int16_t>(b, r + 18) != 0 || Get<uint16_t>(b, r + 20) != 1 ||
                  Get<float>(b, r + 30) != p.range_m || Get<uint32_t>(b, r + 34) != p.scan ||
                  Get<uint16_t>(b, r + 38) != p.beam || Get<uint8_t>(b, r + 40) != p.flags;
  }
  EXPECT_LE(worst_xyz, scale / 2 + 1e-9);
  EXPECT_LT(worst_gps, 1e-6);
  EXPECT_EQ(bad_fields, 0u);
  // Header bounds: exactly what the integers written decode to.
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(Get<double>(b, 179 + 16 * k), hi[k] * scale + offset[k]) << k;
    EXPECT_EQ(Get<double>(b, 187 + 16 * k), lo[k] * scale + offset[k]) << k;
  }
}

TEST(LasWriterTest, GpsTimeOfKnownInstants) {
  double gps;
  int year, day;
  ASSERT_TRUE(AdjustedGpsTimeFromIso8601("1980-01-06T00:00:00Z", &gps, &year, &day).ok());
  EXPECT_EQ(gps, -1e9);  // The GPS epoch.
  EXPECT_EQ(day, 6);
  // Published: 2017-01-01T00:00:00 UTC is GPS second 1167264018 (18 leap seconds).
  ASSERT_TRUE(AdjustedGpsTimeFromIso8601("2017-01-01T00:00:00Z", &gps, &year, &day).ok());
  EXPECT_EQ(gps, 1167264018.0 - 1e9);
  ASSERT_TRUE(AdjustedGpsTimeFromIso8601("2016-12-31T23:59:59Z", &gps, &year, &day).ok());
  EXPECT_EQ(gps, 1167264016.0 - 1e9);  // 17 leap seconds before the last one.
  EXPECT_EQ(year, 2016);
  EXPECT_EQ(day, 366);
  ASSERT_TRUE(AdjustedGpsTimeFromIso8601("2026-11-22T10:15:00Z", &gps, &year, &day).ok());
  EXPECT_EQ(gps, kAdjustedGps20261122);
  EXPECT_EQ(year, 2026);
  EXPECT_EQ(day, 326);
  ASSERT_TRUE(AdjustedGpsTimeFromIso8601("2026-11-22T11:45:00.25+01:30", &gps, &year, &day).ok());
  EXPECT_EQ(gps, kAdjustedGps20261122 + 0.25);
  for (const char* bad : {"", "yesterday", "2026-13-01T00:00:00Z", "2026-02-29T00:00:00Z", "2026-11-22T10:15:00",
                          "2026-11-22T24:00:00Z", "2026-11-22T10:15:00Zjunk", "1979-12-31T23:59:59Z"}) {
    EXPECT_FALSE(AdjustedGpsTimeFromIso8601(bad, &gps, &year, &day).ok()) << bad;
  }
}

TEST(LasWriterTest, WithoutAUsableCreatedUtcTimesAreRobotSeconds) {
  const std::vector<CloudPoint> pts = RoomPoints(100);
  for (const char* created : {"", "not a date"}) {
    LasWriterOptions o = OptionsFor(pts);
    const Status s = SetLasTimeFromSession(created, o.extent, &o);
    EXPECT_FALSE(s.ok());
    EXPECT_NE(s.message().find("robot seconds"), std::string::npos) << s.message();
    EXPECT_FALSE(o.adjusted_gps_time);
    EXPECT_GE(o.creation_year, 2024);  // Today's date instead.
    const std::string path = Tmp("robot_time.las");
    ASSERT_TRUE(Write(path, pts, o).ok());
    const std::string b = ReadBytes(path);
    EXPECT_EQ(Get<uint16_t>(b, 6), 0x10);  // Bit 0 clear: not Adjusted Standard GPS time.
    const size_t data = Get<uint32_t>(b, 96);
    for (size_t i = 0; i < pts.size(); ++i) EXPECT_EQ(Get<double>(b, data + 41 * i + 22), pts[i].time_ns * 1e-9);
  }
}

TEST(LasWriterTest, AnyChunkingWritesTheSameBytes) {
  const std::vector<CloudPoint> pts = RoomPoints(30000);
  const LasWriterOptions o = OptionsFor(pts);
  ASSERT_TRUE(Write(Tmp("whole.las"), pts, o, pts.size()).ok());
  const std::string whole = ReadBytes(Tmp("whole.las"));
  for (const size_t chunk : {size_t{1}, size_t{7}, size_t{25600}, size_t{25601}}) {
    ASSERT_TRUE(Write(Tmp("chunked.las"), pts, o, chunk).ok());
    EXPECT_EQ(ReadBytes(Tmp("chunked.las")), whole) << chunk;
  }
}

// The app's export: a cloud store's snapshot (sealed, packed chunks and the
// open one) written in two passes is the file the writer makes of the same
// points in one, and loaders.gl and copc.js read its every point; without a usable created_utc it
// is still written, and says why its times are robot seconds; cancelled, it leaves nothing.
TEST(LasWriterTest, ASnapshotIsWrittenAsItsPointsAre) {
  PointChunks cloud(4096);
  for (const CloudPoint& p : RoomPoints(30000)) cloud.Append(p);  // 7 sealed chunks and an open one
  const CloudSnapshotRef snapshot = cloud.Snapshot();
  ASSERT_EQ(snapshot.sealed.size(), 7u);
  ASSERT_FALSE(snapshot.open.empty());
  const std::vector<CloudPoint> pts = snapshot.Flatten();  // positions as the store keeps them
  LasWriterOptions base;
  base.system_identifier = "sweepscan YDLIDAR X4";
  base.generating_software = "sweepscan 0.1.0";
  std::string note = "x";
  LasWriteStats stats;
  ASSERT_TRUE(
      SaveLas(Tmp("snapshot.las"), snapshot, "2026-11-22T10:15:00Z", base, nullptr, &stats, &note)
          .ok());
  EXPECT_EQ(note, "");
  EXPECT_EQ(stats.points, pts.size());
  ASSERT_TRUE(Write(Tmp("points.las"), pts, OptionsFor(pts)).ok());
  EXPECT_EQ(ReadBytes(Tmp("snapshot.las")), ReadBytes(Tmp("points.las")));
  // And read by the independent readers: every point, where the store had it.
  const CommandRun r =
      RunCommand(std::string(SWEEPSCAN_NODE) + " " + SWEEPSCAN_SOURCE_DIR +
                 "/tests/tools/read_las.mjs " + Tmp("snapshot.las") + " 5 4999 2>&1");
  ASSERT_EQ(r.code, 0) << r.out
                       << "\n(tests/tools/node_modules missing? run scripts/install-test-tools.sh)";
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["loaders_gl"]["decoded"].get<size_t>(), pts.size());
  EXPECT_EQ(j["copc"]["header"]["pointCount"].get<size_t>(), pts.size());
  ASSERT_GT(j["points"].size(), 10u);
  for (const nlohmann::json& p : j["points"]) {
    const CloudPoint& q = pts[p["index"].get<size_t>()];
    const float xyz[3] = {q.x, q.y, q.z};
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(p["position"][k].get<double>(), xyz[k], 0.00005 + 1e-9);
  }

  ASSERT_TRUE(SaveLas(Tmp("undated.las"), snapshot, "", base, nullptr, nullptr, &note).ok());
  EXPECT_NE(note.find("robot seconds"), std::string::npos) << note;
  EXPECT_EQ(Get<uint16_t>(ReadBytes(Tmp("undated.las")), 6), 0x10);

  std::atomic<bool> cancel{true};
  const Status s = SaveLas(Tmp("cancelled.las"), snapshot, "2026-11-22T10:15:00Z", base, &cancel);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("cancelled"), std::string::npos) << s.message();
  EXPECT_EQ(Ls(Dir()).find("cancelled"), std::string::npos) << Ls(Dir());
}

TEST(LasWriterTest, ScaleAndOffsetFollowTheExtent) {
  auto extent = [](double lo, double hi) {
    LasExtent e;
    const CloudPoint p[2] = {{static_cast<float>(lo), -2.0f, 0.2f}, {static_cast<float>(hi), 5.0f, 2.7f}};
    e.Add(p, 2);
    return e;
  };
  LasQuantisation q;
  ASSERT_TRUE(ChooseLasQuantisation(extent(-3.0, 9.0), &q).ok());
  EXPECT_EQ(q.scale, 0.0001);
  EXPECT_EQ(q.offset[0], 3.0);
  EXPECT_EQ(q.offset[1], 2.0);  // centre 1.5 rounds away from zero
  EXPECT_EQ(q.offset[2], 1.0);  // centre 1.45
  ASSERT_TRUE(ChooseLasQuantisation(extent(-200000.0, 210000.0), &q).ok());
  EXPECT_EQ(q.scale, 0.0001);  // 205 km from the offset: still 0.1 mm
  ASSERT_TRUE(ChooseLasQuantisation(extent(-500000.0, 500000.0), &q).ok());
  EXPECT_EQ(q.scale, 0.001);
  Status s = ChooseLasQuantisation(extent(-3.0e6, 3.0e6), &q);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("too large"), std::string::npos) << s.message();

  // 1 mm at +-500 km: the points still decode within half a step.
  const std::vector<CloudPoint> far = {{-500000.0f, -2.0f, 0.2f}, {499999.97f, 5.0f, 2.7f}, {1234.567f, 0.0f, 1.0f}};
  LasWriteStats stats;
  ASSERT_TRUE(Write(Tmp("far.las"), far, OptionsFor(far), 4096, &stats).ok());
  const std::string b = ReadBytes(Tmp("far.las"));
  EXPECT_EQ(Get<double>(b, 131), 0.001);
  const size_t data = Get<uint32_t>(b, 96);
  for (size_t i = 0; i < far.size(); ++i) {
    EXPECT_LE(std::abs(Get<int32_t>(b, data + 41 * i) * 0.001 + Get<double>(b, 155) - far[i].x), 0.0005 + 1e-9);
  }
  // Too large even at 1 mm: refused before any file exists.
  const std::vector<CloudPoint> huge = {{-3.0e6f, 0.0f, 0.0f}, {3.0e6f, 0.0f, 0.0f}};
  const std::string dir = Tmp("huge");
  MakeFolder(dir);
  s = Write(dir + "/huge.las", huge, OptionsFor(huge));
  EXPECT_NE(s.message().find("huge.las: the cloud's extent is too large for LAS"), std::string::npos) << s.message();
  EXPECT_EQ(Ls(dir), "");
}

TEST(LasWriterTest, APointOutsideTheExtentIsRefusedAndLeavesNoFile) {
  const std::vector<CloudPoint> pts = RoomPoints(1000);
  const std::string dir = Tmp("outside");
  MakeFolder(dir);
  LasWriter w;
  ASSERT_TRUE(w.Open(dir + "/x.las", OptionsFor(pts)).ok());
  ASSERT_TRUE(w.Append(pts.data(), 500).ok());
  const CloudPoint stray{20.0f, 1.0f, 1.0f};
  const Status s = w.Append(&stray, 1);
  EXPECT_NE(s.message().find("x.las: point 500 (20.0000, 1.0000, 1.0000) lies outside the extent"), std::string::npos)
      << s.message();
  EXPECT_FALSE(w.Append(pts.data(), 1).ok());  // Sticky.
  EXPECT_FALSE(w.Finish().ok());
  EXPECT_EQ(Ls(dir), "");  // Neither x.las nor its temporary.
}

TEST(LasWriterTest, NonFinitePointsAreSkippedAndCounted) {
  std::vector<CloudPoint> pts = RoomPoints(100);
  pts[10].x = std::nanf("");
  pts[20].z = INFINITY;
  LasExtent e;
  e.Add(pts.data(), pts.size());
  EXPECT_EQ(e.points, 98u);
  EXPECT_EQ(e.non_finite, 2u);
  LasWriteStats stats;
  ASSERT_TRUE(Write(Tmp("nan.las"), pts, OptionsFor(pts), 4096, &stats).ok());
  EXPECT_EQ(stats.points, 98u);
  EXPECT_EQ(stats.non_finite, 2u);
  const std::string b = ReadBytes(Tmp("nan.las"));
  EXPECT_EQ(Get<uint64_t>(b, 247), 98u);
  EXPECT_EQ(b.size(), Get<uint32_t>(b, 96) + 98u * 41);
}

TEST(LasWriterTest, UnwritablePlacesNameTheOsError) {
  const std::vector<CloudPoint> pts = RoomPoints(10);
  Status s = Write("/nonexistent-folder/x.las", pts, OptionsFor(pts));
  EXPECT_NE(s.message().find("/nonexistent-folder/x.las"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("No such file or directory"), std::string::npos) << s.message();
  s = Write(Dir(), pts, OptionsFor(pts));
  EXPECT_NE(s.message().find("is a folder"), std::string::npos) << s.message();
}

TEST(LasWriterTest, AnEmptyCloudIsAValidFile) {
  const std::vector<CloudPoint> none;
  ASSERT_TRUE(Write(Tmp("empty.las"), none, OptionsFor(none)).ok());
  const std::string b = ReadBytes(Tmp("empty.las"));
  EXPECT_EQ(b.size(), Get<uint32_t>(b, 96));
  EXPECT_EQ(Get<uint64_t>(b, 247), 0u);
  for (int k = 0; k < 6; ++k) EXPECT_EQ(Get<double>(b, 179 + 8 * k), 0.0);
}

// --- The CLI on a simulated session, read back by independent readers. ---

CommandRun Cli(const std::string& args) { return RunCommand(std::string(SWEEPSCAN_CLI) + " " + args); }

const std::string& LabSession() {
  static const std::string session = [] {
    const CommandRun r = Cli("simulate --scenario " + std::string(SWEEPSCAN_SOURCE_DIR) +
                             "/resources/scenarios/lab.json --out " + Tmp("lab.ply") + " --overwrite");
    EXPECT_EQ(r.code, 0) << r.out;
    return Tmp("lab.sweepscan");
  }();
  return session;
}

TEST(LasExportTest, SessionExportIsReadByIndependentReadersAsItsPly) {
  CommandRun r = Cli("export " + LabSession() + " --out " + Tmp("session.las") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json report = nlohmann::json::parse(r.out);
  ASSERT_EQ(Cli("export " + LabSession() + " --out " + Tmp("session.ply")).code, 0);
  std::vector<CloudPoint> ply;
  ASSERT_TRUE(LoadCloud(Tmp("session.ply"), &ply).ok());
  ASSERT_GT(ply.size(), 200000u);
  // `reconstruct --out X.las` writes the same file.
  ASSERT_EQ(Cli("reconstruct " + LabSession() + " --out " + Tmp("reconstructed.las")).code, 0);
  EXPECT_EQ(ReadBytes(Tmp("reconstructed.las")), ReadBytes(Tmp("session.las")));

  r = RunCommand(std::string(SWEEPSCAN_NODE) + " " + SWEEPSCAN_SOURCE_DIR + "/tests/tools/read_las.mjs " +
                 Tmp("session.las") + " 50 997 2>&1");
  ASSERT_EQ(r.code, 0) << r.out << "\n(tests/tools/node_modules missing? run scripts/install-test-tools.sh)";
  const nlohmann::json j = nlohmann::json::parse(r.out);
  const nlohmann::json& gl = j["loaders_gl"];
  const nlohmann::json& cp = j["copc"];

  // The truth: the PLY export's points and meta.json's created_utc.
  LasExtent extent;
  extent.Add(ply.data(), ply.size());
  SessionMeta meta;
  ASSERT_TRUE(ReadSessionMeta(LabSession() + "/meta.json", &meta).ok());
  double gps0;
  int year, day;
  ASSERT_TRUE(AdjustedGpsTimeFromIso8601(meta.created_utc, &gps0, &year, &day).ok());
  const double half = 0.0001 / 2 + 1e-9;

  EXPECT_EQ(gl["version"], "1.4");
  EXPECT_EQ(gl["point_format"], 6);
  EXPECT_EQ(gl["record_length"], 41);
  EXPECT_EQ(gl["count"].get<size_t>(), ply.size());
  EXPECT_EQ(gl["decoded"].get<size_t>(), ply.size());
  EXPECT_EQ(report["las"]["points"].get<size_t>(), ply.size());
  EXPECT_EQ(gl["intensity_max"], 0);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(gl["scale"][k].get<double>(), 0.0001);
    // The offset is the centre of the box the export chose before the first
    // point (streamed: the trajectory widened by the lidar's reach), which
    // holds the cloud and reaches at most 10.5 m beyond it.
    const nlohmann::json& box = report["las"]["box_m"];
    EXPECT_EQ(gl["offset"][k].get<double>(), std::round(0.5 * (box[0][k].get<double>() + box[1][k].get<double>()))) << k;
    EXPECT_LE(box[0][k].get<double>(), extent.min[k]) << k;
    EXPECT_GE(box[1][k].get<double>(), extent.max[k]) << k;
    EXPECT_GT(box[0][k].get<double>(), extent.min[k] - 10.5) << k;
    EXPECT_LT(box[1][k].get<double>(), extent.max[k] + 10.5) << k;
    EXPECT_NEAR(gl["mins"][k].get<double>(), extent.min[k], half) << k;
    EXPECT_NEAR(gl["maxs"][k].get<double>(), extent.max[k], half) << k;
    // The header's bounds are exactly the bounds of what loaders.gl decoded.
    EXPECT_EQ(gl["mins"][k].get<double>(), gl["bounding_box"][0][k].get<double>()) << k;
    EXPECT_EQ(gl["maxs"][k].get<double>(), gl["bounding_box"][1][k].get<double>()) << k;
    EXPECT_EQ(cp["header"]["min"][k], gl["mins"][k]);
    EXPECT_EQ(cp["header"]["max"][k], gl["maxs"][k]);
  }
  const nlohmann::json& h = cp["header"];
  EXPECT_EQ(h["pointCount"].get<size_t>(), ply.size());
  EXPECT_EQ(h["globalEncoding"], 0x11);
  EXPECT_EQ(h["systemIdentifier"], "sweepscan simulation");
  EXPECT_EQ(h["generatingSoftware"], "sweepscan 0.1.0");
  EXPECT_EQ(h["fileCreationYear"], year);
  EXPECT_EQ(h["fileCreationDayOfYear"], day);
  EXPECT_EQ(cp["wkt"], std::string(kSweepscanSessionWkt) + '\0');
  ASSERT_EQ(cp["extra_bytes"].size(), 4u);
  EXPECT_EQ(cp["extra_bytes"][0]["name"], "range");
  EXPECT_EQ(cp["view_points"].get<size_t>(), ply.size());

  const nlohmann::json& points = j["points"];
  ASSERT_GT(points.size(), 300u);  // 50 first, 50 last, every 997th.
  EXPECT_EQ(points.back()["index"].get<size_t>(), ply.size() - 1);
  for (const nlohmann::json& p : points) {
    const size_t i = p["index"].get<size_t>();
    const CloudPoint& q = ply[i];
    const nlohmann::json& c = p["copc"];
    const float xyz[3] = {q.x, q.y, q.z};
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(p["position"][k].get<double>(), xyz[k], half) << i;
      EXPECT_NEAR(c[std::string(1, "XYZ"[k])].get<double>(), xyz[k], half) << i;
    }
    EXPECT_NEAR(c["GpsTime"].get<double>(), gps0 + static_cast<double>(q.time_ns - extent.min_time_ns) * 1e-9, 1e-6)
        << i;
    EXPECT_EQ(c["range"].get<float>(), q.range_m) << i;
    EXPECT_EQ(c["scan"].get<uint32_t>(), q.scan) << i;
    EXPECT_EQ(c["beam"].get<uint16_t>(), q.beam) << i;
    EXPECT_EQ(c["flags"].get<int>(), q.flags) << i;
    EXPECT_EQ(c["UserData"].get<int>(), q.pose_source) << i;
    EXPECT_EQ(c["PointSourceId"], 1);
    EXPECT_EQ(c["ReturnNumber"], 1);
    EXPECT_EQ(c["NumberOfReturns"], 1);
    EXPECT_EQ(c["Classification"], 0);
  }
}

TEST(LasExportTest, ExportKeepsItsOtherFormsAndRefusesMixedOptions) {
  // --format and --frame belong to csv/rosbag; --no-deskew and --pose-source to clouds.
  CommandRun r = Cli("export " + LabSession() + " --out " + Tmp("x.las") + " --format rosbag");
  EXPECT_EQ(r.code, 2) << r.out;
  r = Cli("export " + LabSession() + " --out " + Tmp("csv") + " --no-deskew");
  EXPECT_EQ(r.code, 2) << r.out;
  r = Cli("export " + LabSession() + " --out " + Tmp("csv") + " --json");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(Ls(Tmp("csv")), "imu.csv\nlidar.csv\nwheels.csv\n");
  // The same options as reconstruct; the suffix in any case (.LAS).
  r = Cli("export " + LabSession() + " --out " + Tmp("nd.LAS") + " --no-deskew --pose-source odometry --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_FALSE(nlohmann::json::parse(r.out)["deskew"].get<bool>());
  EXPECT_EQ(nlohmann::json::parse(r.out)["pose_source"], "odometry");
  EXPECT_EQ(ReadBytes(Tmp("nd.LAS")).substr(0, 4), "LASF");
  // A full disk: exit 1, the OS's reason, no file and no temporary left.
  const std::string dir = Tmp("full");
  MakeFolder(dir);
  r = RunCommand("sh -c \"trap '' XFSZ; ulimit -f 512; exec " + std::string(SWEEPSCAN_CLI) + " export " +
                 LabSession() + " --out " + dir + "/x.las\"");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find(dir + "/x.las: write failed: File too large"), std::string::npos) << r.out;
  EXPECT_EQ(Ls(dir), "");
}

}  // namespace
}  // namespace sweepscan
