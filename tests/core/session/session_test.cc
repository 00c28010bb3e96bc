#include "core/session/session.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "core/common/crc32c.h"
#include "core/common/json_reader.h"
#include "tests/testing/run_command.h"

namespace sweepscan {
namespace {

using Bytes = std::vector<uint8_t>;
using SteadyClock = std::chrono::steady_clock;

// A fresh folder under the system temp dir, removed at the end.
class TempDir {
 public:
  TempDir() {
    char tmpl[] = "/tmp/sweepscan_session_test_XXXXXX";
    path_ = ::mkdtemp(tmpl);
  }
  ~TempDir() { sweepscan::testing::ShellOrFail("rm -rf '" + path_ + "'"); }
  const std::string& path() const { return path_; }
  std::string Sub(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

Bytes ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}
void WriteAll(const std::string& path, const Bytes& b) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}
void WriteText(const std::string& path, const std::string& s) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << s;
}

SessionMeta TestMeta() {
  SessionMeta m;
  m.created_utc = "2026-11-22T10:00:00Z";
  m.geometry.lidar_height_m = 0.42;
  m.geometry.wheel_distance_m = 0.16;
  m.lidar_angle_convention.sign = -1;
  m.lidar_angle_convention.offset_rad = 0.1;
  m.calibration = {0.01, -0.02, 0.03};
  m.link = "tcp:127.0.0.1:5600";
  m.agent = "sweepscan-sim 0.1";
  m.settings = {{"ekf", {{"gyro_sigma", 0.01}}}};
  m.notes = "lab, first pass";
  return m;
}

// Record i: i % 97 + 1 bytes of a pattern, time 1000 * i.
Bytes RecordBytes(int i) {
  Bytes b(static_cast<size_t>(i % 97 + 1));
  for (size_t k = 0; k < b.size(); ++k) b[k] = static_cast<uint8_t>(i * 13 + k);
  return b;
}

// Writes n records; returns the byte offset of each record in frames.bin.
std::vector<size_t> WriteSession(const std::string& dir, int n) {
  std::unique_ptr<SessionWriter> w;
  const Status s = SessionWriter::Create(dir, TestMeta(), SessionWriterOptions(), &w);
  EXPECT_TRUE(s.ok()) << s.message();
  std::vector<size_t> offsets;
  size_t pos = kSessionFramesHeaderSize;
  for (int i = 0; i < n; ++i) {
    offsets.push_back(pos);
    const Bytes b = RecordBytes(i);
    EXPECT_TRUE(w->Append(b, 1000 * i).ok());
    pos += kSessionRecordOverhead + b.size();
  }
  EXPECT_TRUE(w->Close().ok());
  return offsets;
}

// A simulated session's world is its scenario's; a real one starts at the
// origin; malformed settings fall back to the origin, never throw.
TEST(SessionTest, StartPoseFromTheScenarioSettings) {
  SessionMeta meta;
  Pose2d p = SessionStartPose(meta);
  EXPECT_EQ(p.x, 0.0);
  EXPECT_EQ(p.yaw, 0.0);
  meta.settings["scenario"]["path"]["start"] = {{"x_m", 4.17}, {"y_m", 1.7}, {"yaw_rad", -1.5}};
  p = SessionStartPose(meta);
  EXPECT_DOUBLE_EQ(p.x, 4.17);
  EXPECT_DOUBLE_EQ(p.y, 1.7);
  EXPECT_DOUBLE_EQ(p.yaw, -1.5);
  meta.settings["scenario"]["path"]["start"] = "nowhere";
  p = SessionStartPose(meta);
  EXPECT_EQ(p.x, 0.0);
  meta.settings["scenario"] = 3;
  EXPECT_EQ(SessionStartPose(meta).y, 0.0);
}

// The LAS System Identifier: a simulation whether the CLI ran it in process
// ("simulated ...") or the app's simulator recorded it over loopback TCP
// (its scenario in the settings, as a robot's link): the app's exports had
// said "sweepscan YDLIDAR X4" of simulated data.
TEST(SessionTest, SystemIdentifierNamesSimulationsWhateverTheirLink) {
  SessionMeta meta;
  meta.link = "/dev/ttyUSB0";
  EXPECT_EQ(SessionSystemIdentifier(meta), "sweepscan YDLIDAR X4");
  meta.link = "tcp:192.168.4.1:7700";
  EXPECT_EQ(SessionSystemIdentifier(meta), "sweepscan YDLIDAR X4");
  meta.settings["scenario"] = 3;  // not a scenario
  EXPECT_EQ(SessionSystemIdentifier(meta), "sweepscan YDLIDAR X4");
  meta.link = "tcp:127.0.0.1:40123";
  meta.settings["scenario"] = {{"name", "lab"}};
  EXPECT_EQ(SessionSystemIdentifier(meta), "sweepscan simulation");
  meta.settings = nlohmann::json::object();
  meta.link = "simulated (in-process, scenario lab)";
  EXPECT_EQ(SessionSystemIdentifier(meta), "sweepscan simulation");
  meta.content = kSessionContentMeasurements;
  EXPECT_EQ(SessionSystemIdentifier(meta), "OTHER");
}

TEST(SessionTest, WriteAndReloadEqual) {
  TempDir tmp;
  const std::string dir = tmp.Sub("lab.sweepscan");
  WriteSession(dir, 500);
  Session s;
  const Status st = LoadSession(dir, FramesLoadOptions(), &s);
  ASSERT_TRUE(st.ok()) << st.message();
  ASSERT_EQ(s.records.size(), 500u);
  for (int i = 0; i < 500; ++i) {
    EXPECT_EQ(s.records[i].bytes, RecordBytes(i));
    EXPECT_EQ(s.records[i].receive_time_ns, 1000 * i);
  }
  EXPECT_FALSE(s.frames.truncated_tail);
  EXPECT_EQ(s.frames.format_version, 1u);
  const SessionMeta m = TestMeta();
  EXPECT_EQ(s.meta.geometry.lidar_height_m, m.geometry.lidar_height_m);
  EXPECT_EQ(s.meta.geometry.wheel_distance_m, m.geometry.wheel_distance_m);
  EXPECT_EQ(s.meta.lidar_angle_convention.sign, -1);
  EXPECT_EQ(s.meta.lidar_angle_convention.offset_rad, 0.1);
  EXPECT_EQ(s.meta.calibration.gamma, 0.03);
  EXPECT_EQ(s.meta.link, m.link);
  EXPECT_EQ(s.meta.agent, m.agent);
  EXPECT_EQ(s.meta.settings, m.settings);
  EXPECT_EQ(s.meta.notes, m.notes);
  EXPECT_EQ(s.meta.created_utc, m.created_utc);
}

// A recorder rewrites meta.json from the meta it started from (a
// reconnection names the agent); that meta's created_utc was empty, and
// the time Create() wrote must stay (the LAS export's GPS time needs it).
TEST(SessionTest, UpdateMetaKeepsWhenTheRecordingBegan) {
  TempDir tmp;
  const std::string dir = tmp.Sub("again.sweepscan");
  SessionMeta meta = TestMeta();
  meta.created_utc.clear();
  std::unique_ptr<SessionWriter> w;
  ASSERT_TRUE(SessionWriter::Create(dir, meta, SessionWriterOptions(), &w).ok());
  SessionMeta written;
  ASSERT_TRUE(ReadSessionMeta(dir + "/meta.json", &written).ok());
  ASSERT_EQ(written.created_utc.size(), 20u) << written.created_utc;  // 2026-11-28T16:00:00Z
  meta.agent = "robot-2";
  ASSERT_TRUE(w->UpdateMeta(meta).ok());
  ASSERT_TRUE(w->Close().ok());
  SessionMeta updated;
  ASSERT_TRUE(ReadSessionMeta(dir + "/meta.json", &updated).ok());
  EXPECT_EQ(updated.agent, "robot-2");
  EXPECT_EQ(updated.created_utc, written.created_utc);
  // So does a writer that reopened the session.
  ASSERT_TRUE(SessionWriter::Open(dir, SessionWriterOptions(), &w).ok());
  meta.agent = "robot-3";
  ASSERT_TRUE(w->UpdateMeta(meta).ok());
  ASSERT_TRUE(w->Close().ok());
  ASSERT_TRUE(ReadSessionMeta(dir + "/meta.json", &updated).ok());
  EXPECT_EQ(updated.created_utc, written.created_utc);
}

TEST(SessionTest, FileHeaderAndRecordLayoutByHand) {
  TempDir tmp;
  const std::string dir = tmp.Sub("a.sweepscan");
  std::unique_ptr<SessionWriter> w;
  ASSERT_TRUE(SessionWriter::Create(dir, TestMeta(), SessionWriterOptions(), &w).ok());
  ASSERT_TRUE(w->Append(Bytes{0xAB, 0xCD}, 0x0102030405060708).ok());
  ASSERT_TRUE(w->Close().ok());
  const Bytes f = ReadAll(dir + "/frames.bin");
  const Bytes expected_start = {0x89, 'S', 'W', 'F', 0x0D, 0x0A, 0x1A, 0x0A,  // magic
                                1,    0,   0,   0,   0,    0,    0,    0,     // version, reserved
                                2,    0,   0,   0,                            // length
                                8,    7,   6,   5,   4,    3,    2,    1,     // time
                                0xAB, 0xCD};
  ASSERT_EQ(f.size(), expected_start.size() + 4);
  EXPECT_EQ(Bytes(f.begin(), f.end() - 4), expected_start);
  const uint32_t crc = Crc32cBitwise(f.data() + 16, 14);
  EXPECT_EQ(Bytes(f.end() - 4, f.end()),
            (Bytes{uint8_t(crc), uint8_t(crc >> 8), uint8_t(crc >> 16), uint8_t(crc >> 24)}));
}

TEST(SessionTest, TruncationAtEveryOffsetOfTheLastRecordsKeepsTheCompleteOnes) {
  TempDir tmp;
  const std::string dir = tmp.Sub("t.sweepscan");
  const int n = 30;
  const std::vector<size_t> offsets = WriteSession(dir, n);
  const Bytes file = ReadAll(dir + "/frames.bin");
  // Every cut from the start of record n-3 to the end of the file.
  for (size_t cut = offsets[n - 3]; cut <= file.size(); ++cut) {
    std::vector<SessionRecord> records;
    FramesLoadReport report;
    const Status s = LoadFramesFromMemory(file.data(), cut, "frames.bin", FramesLoadOptions(),
                                          &records, &report);
    ASSERT_TRUE(s.ok()) << cut << ": " << s.message();
    size_t complete = 0;
    while (complete < offsets.size() && offsets[complete] + kSessionRecordOverhead +
                                                RecordBytes(static_cast<int>(complete)).size() <=
                                            cut) {
      ++complete;
    }
    ASSERT_EQ(records.size(), complete) << cut;
    for (size_t i = 0; i < complete; ++i) EXPECT_EQ(records[i].bytes, RecordBytes(int(i)));
    const bool at_boundary =
        cut == file.size() || std::find(offsets.begin(), offsets.end(), cut) != offsets.end();
    EXPECT_EQ(report.truncated_tail, !at_boundary) << cut;
    if (!at_boundary) {
      EXPECT_NE(report.tail_reason.find("record " + std::to_string(complete)), std::string::npos)
          << report.tail_reason;
    }
    EXPECT_EQ(report.valid_bytes + report.tail_bytes_dropped, cut);
  }
}

TEST(SessionTest, CorruptRecordInTheMiddleIsRefusedWithRecordAndOffset) {
  TempDir tmp;
  const std::string dir = tmp.Sub("c.sweepscan");
  const std::vector<size_t> offsets = WriteSession(dir, 40);
  Bytes file = ReadAll(dir + "/frames.bin");
  file[offsets[17] + 14] ^= 0x40;  // A payload byte of record 17.
  WriteAll(dir + "/frames.bin", file);
  Session s;
  Status st = LoadSession(dir, FramesLoadOptions(), &s);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("frames.bin: record 17 at byte " + std::to_string(offsets[17]) +
                              ": CRC mismatch"),
            std::string::npos)
      << st.message();
  // Optionally skipped and counted.
  FramesLoadOptions skip;
  skip.skip_corrupt_records = true;
  st = LoadSession(dir, skip, &s);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_EQ(s.records.size(), 39u);
  EXPECT_EQ(s.frames.corrupt_records_skipped, 1u);
  EXPECT_EQ(s.records[17].bytes, RecordBytes(18));

  // An absurd length is refused by default, and skipped when skipping: the
  // next intact record is found by its CRC.
  file = ReadAll(dir + "/frames.bin");
  file[offsets[5] + 3] = 0x7F;
  WriteAll(dir + "/frames.bin", file);
  st = LoadSession(dir, FramesLoadOptions(), &s);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("record 5 at byte " + std::to_string(offsets[5]) + ": absurd length"),
            std::string::npos)
      << st.message();
  st = LoadSession(dir, skip, &s);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_EQ(s.records.size(), 38u);
  EXPECT_EQ(s.frames.corrupt_records_skipped, 2u);
  EXPECT_EQ(s.records[5].bytes, RecordBytes(6));
}

// Issue 16: one flipped byte in the middle of frames.bin made every command
// refuse the whole session. Skipping loses only the damaged record, and the
// report says how many records, how many seconds and where.
TEST(SessionTest, DamageIsSkippedAndDescribedRecordsSecondsAndPlace) {
  TempDir tmp;
  const std::string dir = tmp.Sub("d.sweepscan");
  const std::vector<size_t> offsets = WriteSession(dir, 100);  // Record i at 1000 i ns.
  Bytes file = ReadAll(dir + "/frames.bin");
  file[offsets[40] + 13] ^= 0x01;  // Payload of record 40.
  file[offsets[70] + 1] ^= 0x80;   // Length field of record 70: 32 KiB more than it is.
  WriteAll(dir + "/frames.bin", file);
  FramesLoadOptions skip;
  skip.skip_corrupt_records = true;
  Session s;
  const Status st = LoadSession(dir, skip, &s);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_EQ(s.records.size(), 98u);
  const FramesLoadReport& f = s.frames;
  ASSERT_EQ(f.damage.size(), 2u);
  EXPECT_EQ(f.damage[0].first_record, 40u);
  EXPECT_EQ(f.damage[0].records, 1u);
  EXPECT_EQ(f.damage[0].offset, offsets[40]);
  EXPECT_EQ(f.damage[0].bytes, offsets[41] - offsets[40]);
  EXPECT_EQ(f.damage[0].time_before_ns, 39000);
  EXPECT_EQ(f.damage[0].time_after_ns, 41000);
  EXPECT_DOUBLE_EQ(f.damage[0].SecondsLost(), 2e-6);
  EXPECT_EQ(f.damage[1].offset, offsets[70]);
  EXPECT_EQ(f.damage[1].bytes, offsets[71] - offsets[70]);
  EXPECT_EQ(f.corrupt_records_skipped, 2u);
  EXPECT_EQ(s.records[40].bytes, RecordBytes(41));
  EXPECT_EQ(s.records[69].bytes, RecordBytes(71));
  const std::string summary = f.DamageSummary();
  EXPECT_NE(summary.find("2 damaged records skipped"), std::string::npos) << summary;
  EXPECT_NE(summary.find("record 40 at byte " + std::to_string(offsets[40])), std::string::npos)
      << summary;
  EXPECT_FALSE(LoadSession(dir, FramesLoadOptions(), &s).ok());  // Strict: refused.
}

TEST(SessionTest, FramesFileThatIsAFolderIsAClearError) {
  TempDir tmp;
  const std::string dir = tmp.Sub("x.sweepscan");
  WriteSession(dir, 3);
  ASSERT_EQ(::unlink((dir + "/frames.bin").c_str()), 0);
  ASSERT_EQ(::mkdir((dir + "/frames.bin").c_str(), 0755), 0);
  Session s;
  const Status st = LoadSession(dir, FramesLoadOptions(), &s);  // Used to throw ios_base::failure.
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("frames.bin: is a folder"), std::string::npos) << st.message();
  ASSERT_EQ(::rmdir((dir + "/frames.bin").c_str()), 0);
  ASSERT_EQ(::mkdir((dir + "/meta.json.d").c_str(), 0755), 0);
  ASSERT_EQ(::unlink((dir + "/meta.json").c_str()), 0);
  ASSERT_EQ(::rename((dir + "/meta.json.d").c_str(), (dir + "/meta.json").c_str()), 0);
  const Status meta = LoadSession(dir, FramesLoadOptions(), &s);
  EXPECT_NE(meta.message().find("meta.json: is a folder"), std::string::npos) << meta.message();
}

TEST(SessionTest, EveryByteFlipIsDetectedOrHarmless) {
  TempDir tmp;
  const std::string dir = tmp.Sub("f.sweepscan");
  WriteSession(dir, 6);
  const Bytes file = ReadAll(dir + "/frames.bin");
  for (size_t i = 0; i < file.size(); ++i) {
    Bytes b = file;
    b[i] ^= 0x01;
    std::vector<SessionRecord> records;
    FramesLoadReport report;
    const Status s =
        LoadFramesFromMemory(b.data(), b.size(), "x", FramesLoadOptions(), &records, &report);
    // Never silently wrong: either an error, or (for the reserved header
    // bytes) the same records, or a dropped tail, which one flip can make
    // only of the last record: damage with intact records after it is an
    // error, never a "torn tail" that would drop them (and that a writer
    // reopening the session would cut).
    if (!s.ok()) continue;
    const size_t kept = report.truncated_tail ? 5u : 6u;
    ASSERT_EQ(records.size(), kept) << i;
    for (size_t k = 0; k < kept; ++k)
      EXPECT_EQ(records[k].bytes, RecordBytes(static_cast<int>(k))) << i;
  }
}

// A damaged length field that lands on an intact record further on: the
// records between were intact and are kept (only the damaged one is lost),
// and the count of what was lost is right. Records of 10, 48, 10, 10 and 10
// bytes; bit 6 of the first one's length flips 10 to 74, which leads from
// byte 16 exactly to the third record.
TEST(SessionTest, ADamagedLengthLandingOnALaterRecordLosesOnlyItsOwnRecord) {
  TempDir tmp;
  const std::string dir = tmp.Sub("len.sweepscan");
  std::unique_ptr<SessionWriter> w;
  ASSERT_TRUE(SessionWriter::Create(dir, TestMeta(), SessionWriterOptions(), &w).ok());
  const size_t sizes[] = {10, 48, 10, 10, 10};
  for (size_t i = 0; i < 5; ++i) {
    ASSERT_TRUE(
        w->Append(Bytes(sizes[i], static_cast<uint8_t>(i + 1)), 1000 * static_cast<int64_t>(i))
            .ok());
  }
  ASSERT_TRUE(w->Close().ok());
  Bytes file = ReadAll(dir + "/frames.bin");
  ASSERT_EQ(file[16], 10);
  file[16] ^= 0x40;  // 74: 16 + 16 + 74 = 106, the third record's start
  FramesLoadOptions skip;
  skip.skip_corrupt_records = true;
  std::vector<SessionRecord> records;
  FramesLoadReport report;
  ASSERT_TRUE(LoadFramesFromMemory(file.data(), file.size(), "x", skip, &records, &report).ok());
  ASSERT_EQ(records.size(), 4u);
  EXPECT_EQ(records[0].bytes, Bytes(48, 2));
  EXPECT_EQ(report.corrupt_records_skipped, 1u);

  // A length that runs past the end with intact records after it: damage,
  // refused in strict mode (it used to pass as a crash's torn tail).
  file = ReadAll(dir + "/frames.bin");
  const uint32_t past = 100000;
  std::memcpy(file.data() + 16 + 26 + 64, &past, 4);  // the third record's length
  Status s =
      LoadFramesFromMemory(file.data(), file.size(), "x", FramesLoadOptions(), &records, &report);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("runs past the end of the file, but an intact record follows"),
            std::string::npos)
      << s.message();
  ASSERT_TRUE(LoadFramesFromMemory(file.data(), file.size(), "x", skip, &records, &report).ok());
  EXPECT_EQ(records.size(), 4u);
}

TEST(SessionTest, ForeignFileAndWrongVersionAreRefused) {
  std::vector<SessionRecord> records;
  FramesLoadReport report;
  const std::string text = "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n";
  Status s = LoadFramesFromMemory(reinterpret_cast<const uint8_t*>(text.data()), text.size(),
                                  "cloud.ply", FramesLoadOptions(), &records, &report);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("cloud.ply: not a sweepscan frames file"), std::string::npos);
  s = LoadFramesFromMemory(reinterpret_cast<const uint8_t*>("abc"), 3, "short", FramesLoadOptions(),
                           &records, &report);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("too short"), std::string::npos);
  Bytes header(kSessionFramesMagic, kSessionFramesMagic + 8);
  for (uint8_t b : {2, 0, 0, 0, 0, 0, 0, 0}) header.push_back(b);
  s = LoadFramesFromMemory(header.data(), header.size(), "new.bin", FramesLoadOptions(), &records,
                           &report);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("unsupported frames format version 2"), std::string::npos);
  s = LoadFramesFromMemory(nullptr, 0, "empty", FramesLoadOptions(), &records, &report);
  EXPECT_FALSE(s.ok());
  Session session;
  s = LoadSession("/nonexistent/x.sweepscan", FramesLoadOptions(), &session);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("not a session folder"), std::string::npos);
}

TEST(SessionMetaTest, StrictReadingNamesFileAndPath) {
  TempDir tmp;
  const std::string dir = tmp.Sub("m.sweepscan");
  WriteSession(dir, 1);
  const std::string meta_path = dir + "/meta.json";
  nlohmann::json good;
  ASSERT_TRUE(ReadJsonFile(meta_path, &good).ok());
  auto expect_error = [&](const nlohmann::json& j, const std::string& what) {
    WriteText(meta_path, j.dump());
    Session s;
    const Status st = LoadSession(dir, FramesLoadOptions(), &s);
    ASSERT_FALSE(st.ok()) << what;
    EXPECT_NE(st.message().find(meta_path + ": " + what), std::string::npos) << st.message();
  };
  nlohmann::json j = good;
  j["robot"].erase("wheel_distance_m");
  expect_error(j, "robot.wheel_distance_m: missing");
  j = good;
  j["robot"]["lidar_height_m"] = "0.4";
  expect_error(j, "robot.lidar_height_m: expected a number, got a string");
  j = good;
  j["calibration"]["beta_rad"] = 12.0;
  expect_error(j, "calibration.beta_rad: must be within");
  j = good;
  j["calibration"].erase("gamma_rad");
  expect_error(j, "calibration.gamma_rad: missing");
  j = good;
  j["lidar_angle_convention"]["sign"] = 0;
  expect_error(j, "lidar_angle_convention.sign: must be 1 or -1");
  j = good;
  j["colour"] = "red";
  expect_error(j, "colour: unknown key");
  j = good;
  j["format_version"] = 2;
  expect_error(j, "format_version: unsupported version 2");
  j = good;
  j["settings"] = 3;
  expect_error(j, "settings: expected an object");
  j = good;
  j["format"] = "something-else";
  expect_error(j, "format: expected \"sweepscan-session\"");
  WriteText(meta_path, "{\"format\": ");
  Session s;
  const Status st = LoadSession(dir, FramesLoadOptions(), &s);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find(meta_path + ":1:"), std::string::npos) << st.message();
  ::unlink(meta_path.c_str());
  EXPECT_NE(LoadSession(dir, FramesLoadOptions(), &s).message().find("cannot open"),
            std::string::npos);
}

TEST(SessionWriterTest, RefusesToOverwriteUnlessAsked) {
  TempDir tmp;
  const std::string dir = tmp.Sub("o.sweepscan");
  WriteSession(dir, 3);
  std::unique_ptr<SessionWriter> w;
  Status s = SessionWriter::Create(dir, TestMeta(), SessionWriterOptions(), &w);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("refusing to overwrite"), std::string::npos) << s.message();
  Session session;
  ASSERT_TRUE(LoadSession(dir, FramesLoadOptions(), &session).ok());
  EXPECT_EQ(session.records.size(), 3u);  // Untouched.
  SessionWriterOptions options;
  options.overwrite = true;
  s = SessionWriter::Create(dir, TestMeta(), options, &w);
  ASSERT_TRUE(s.ok()) << s.message();
  ASSERT_TRUE(w->Append(Bytes{1}, 5).ok());
  ASSERT_TRUE(w->Close().ok());
  ASSERT_TRUE(LoadSession(dir, FramesLoadOptions(), &session).ok());
  EXPECT_EQ(session.records.size(), 1u);
  // Bad geometry and oversized records are refused.
  SessionMeta bad = TestMeta();
  bad.geometry.wheel_distance_m = 0;
  EXPECT_FALSE(SessionWriter::Create(tmp.Sub("b.sweepscan"), bad, SessionWriterOptions(), &w).ok());
  ASSERT_TRUE(
      SessionWriter::Create(tmp.Sub("c.sweepscan"), TestMeta(), SessionWriterOptions(), &w).ok());
  EXPECT_FALSE(w->Append(Bytes(kSessionMaxRecordBytes + 1), 0).ok());
  EXPECT_TRUE(w->Append(Bytes(10), 0).ok());
}

TEST(SessionWriterTest, OpenCutsATornTailAndAppends) {
  TempDir tmp;
  const std::string dir = tmp.Sub("r.sweepscan");
  WriteSession(dir, 10);
  Bytes file = ReadAll(dir + "/frames.bin");
  file.resize(file.size() - 5);  // Torn last record.
  WriteAll(dir + "/frames.bin", file);
  std::unique_ptr<SessionWriter> w;
  FramesLoadReport report;
  Status s = SessionWriter::Open(dir, SessionWriterOptions(), &w, &report);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_TRUE(report.truncated_tail);
  EXPECT_EQ(report.records, 9u);
  for (int i = 9; i < 12; ++i) ASSERT_TRUE(w->Append(RecordBytes(i), 1000 * i).ok());
  ASSERT_TRUE(w->Close().ok());
  Session session;
  s = LoadSession(dir, FramesLoadOptions(), &session);
  ASSERT_TRUE(s.ok()) << s.message();
  ASSERT_EQ(session.records.size(), 12u);
  EXPECT_FALSE(session.frames.truncated_tail);
  for (int i = 0; i < 12; ++i) EXPECT_EQ(session.records[i].bytes, RecordBytes(i));
}

// A power loss can leave the file's size on disk ahead of its last blocks'
// data, which read as zeros: the records end in zeros to the end of the
// file, whole records of zeros or the last one half written. That is a
// torn tail, in strict mode too, and the writer cuts it and appends. (It
// was refused as a CRC mismatch: `info --strict` and the recorder's Open.)
TEST(SessionWriterTest, AZeroFilledTailAfterAPowerLossIsATornTail) {
  for (const size_t cut : {size_t{0}, size_t{7}}) {
    TempDir tmp;
    const std::string dir = tmp.Sub("z.sweepscan");
    WriteSession(dir, 10);
    Bytes file = ReadAll(dir + "/frames.bin");
    const size_t records_end = file.size();
    std::fill(file.end() - static_cast<std::ptrdiff_t>(cut), file.end(),
              0);  // the last record half zeros
    file.resize(records_end + 4096, 0);
    WriteAll(dir + "/frames.bin", file);
    FramesLoadOptions strict;
    strict.skip_corrupt_records = false;
    Session session;
    Status s = LoadSession(dir, strict, &session);
    ASSERT_TRUE(s.ok()) << cut << ": " << s.message();
    EXPECT_TRUE(session.frames.truncated_tail);
    EXPECT_EQ(session.frames.corrupt_records_skipped, 0u);
    ASSERT_EQ(session.records.size(), cut == 0 ? 10u : 9u);
    EXPECT_NE(session.frames.tail_reason.find("zero bytes to the end of the file"),
              std::string::npos)
        << session.frames.tail_reason;
    std::unique_ptr<SessionWriter> w;
    FramesLoadReport report;
    s = SessionWriter::Open(dir, SessionWriterOptions(), &w, &report);
    ASSERT_TRUE(s.ok()) << s.message();
    ASSERT_TRUE(w->Append(RecordBytes(20), 20000).ok());
    ASSERT_TRUE(w->Close().ok());
    ASSERT_TRUE(LoadSession(dir, strict, &session).ok());
    EXPECT_FALSE(session.frames.truncated_tail);
    ASSERT_EQ(session.records.size(), cut == 0 ? 11u : 10u);
    EXPECT_EQ(session.records.back().bytes, RecordBytes(20));
  }
  // Zeros in the middle, with records after them, are damage, as before.
  TempDir tmp;
  const std::string dir = tmp.Sub("m.sweepscan");
  WriteSession(dir, 10);
  Bytes file = ReadAll(dir + "/frames.bin");
  std::fill(file.begin() + kSessionFramesHeaderSize + 20,
            file.begin() + kSessionFramesHeaderSize + 40, 0);
  WriteAll(dir + "/frames.bin", file);
  FramesLoadOptions strict;
  strict.skip_corrupt_records = false;
  Session session;
  EXPECT_FALSE(LoadSession(dir, strict, &session).ok());
}

TEST(SessionWriterTest, FlushIfDueFollowsTheInterval) {
  TempDir tmp;
  const std::string dir = tmp.Sub("i.sweepscan");
  SessionWriterOptions options;
  options.flush_interval = std::chrono::milliseconds(500);
  std::unique_ptr<SessionWriter> w;
  ASSERT_TRUE(SessionWriter::Create(dir, TestMeta(), options, &w).ok());
  const auto t0 = SteadyClock::now();
  ASSERT_TRUE(w->FlushIfDue(t0).ok());  // Nothing pending: restarts the interval.
  ASSERT_TRUE(w->Append(Bytes{1, 2, 3}, 1).ok());
  ASSERT_TRUE(w->FlushIfDue(t0 + std::chrono::milliseconds(100)).ok());
  EXPECT_EQ(ReadAll(dir + "/frames.bin").size(), kSessionFramesHeaderSize);  // Still buffered.
  ASSERT_TRUE(w->FlushIfDue(t0 + std::chrono::milliseconds(600)).ok());
  EXPECT_EQ(ReadAll(dir + "/frames.bin").size(), kSessionFramesHeaderSize + 16 + 3);
}

// With sync_on_thread the writing and the syncs are a thread's: every
// record arrives in order, FlushIfDue only hands them over, Flush and
// Close wait for the disk, and a failure on the thread (here the file-size
// limit, EFBIG, as a full disk) is said by the next call, due or not.
TEST(SessionWriterTest, OnItsOwnThreadEveryRecordArrivesAndAFailureIsSaid) {
  TempDir tmp;
  const std::string dir = tmp.Sub("thread.sweepscan");
  SessionWriterOptions options;
  options.sync_on_thread = true;
  options.max_buffered_bytes = 300;  // many hand-overs between the syncs
  std::unique_ptr<SessionWriter> w;
  ASSERT_TRUE(SessionWriter::Create(dir, TestMeta(), options, &w).ok());
  auto t = SteadyClock::now();
  for (int i = 0; i < 2000; ++i) {
    ASSERT_TRUE(w->Append(RecordBytes(i), 1000 * i).ok());
    t += std::chrono::milliseconds(7);
    ASSERT_TRUE(w->FlushIfDue(t).ok());
  }
  ASSERT_TRUE(w->Flush().ok());
  Session s;
  ASSERT_TRUE(LoadSession(dir, FramesLoadOptions(), &s).ok());
  ASSERT_EQ(s.records.size(), 2000u);  // all on disk once Flush returned
  for (int i = 0; i < 2000; ++i) ASSERT_EQ(s.records[i].bytes, RecordBytes(i)) << i;
  ASSERT_TRUE(w->Close().ok());

  const std::string full = tmp.Sub("full.sweepscan");
  ASSERT_TRUE(SessionWriter::Create(full, TestMeta(), options, &w).ok());
  rlimit before{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &before), 0);
  const auto old_handler = signal(SIGXFSZ, SIG_IGN);
  rlimit limit = before;
  limit.rlim_cur = kSessionFramesHeaderSize + 1000;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &limit), 0);
  t = SteadyClock::now();
  Status said = Status::Ok();
  for (int i = 0; i < 400 && said.ok(); ++i) {
    said = w->Append(RecordBytes(i), i);
    t += std::chrono::milliseconds(100);
    if (said.ok()) said = w->FlushIfDue(t);
    if (said.ok()) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  EXPECT_FALSE(said.ok());
  EXPECT_NE(said.message().find("frames.bin: write failed: File too large"), std::string::npos)
      << said.message();
  EXPECT_FALSE(w->FlushIfDue(t).ok());  // not due: said again
  EXPECT_FALSE(w->Close().ok());
  setrlimit(RLIMIT_FSIZE, &before);
  signal(SIGXFSZ, old_handler);
  // What fitted is kept, whole records.
  ASSERT_TRUE(LoadSession(full, FramesLoadOptions(), &s).ok());
  EXPECT_GT(s.records.size(), 0u);
  for (size_t i = 0; i < s.records.size(); ++i) EXPECT_EQ(s.records[i].bytes, RecordBytes(i));
}

// meta.json is replaced atomically: a writer killed at any moment leaves
// either the old or the new document, never a mix or a half.
TEST(SessionWriterTest, MetaIsNeverHalfWritten) {
  TempDir tmp;
  const std::string dir = tmp.Sub("a.sweepscan");
  WriteSession(dir, 1);
  std::mt19937 rng(3);
  for (int round = 0; round < 15; ++round) {
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      std::unique_ptr<SessionWriter> w;
      if (!SessionWriter::Open(dir, SessionWriterOptions(), &w).ok()) ::_exit(2);
      SessionMeta m = TestMeta();
      for (int i = 0;; ++i) {
        m.notes = std::string(200000 + (i % 7) * 1000, static_cast<char>('a' + i % 26));
        w->UpdateMeta(m);
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20 + rng() % 60));
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    Session s;
    const Status st = LoadSession(dir, FramesLoadOptions(), &s);
    ASSERT_TRUE(st.ok()) << round << ": " << st.message();
    // Notes are all one letter: a mix of two versions would show.
    if (!s.meta.notes.empty() && s.meta.notes != TestMeta().notes) {
      EXPECT_EQ(s.meta.notes.find_first_not_of(s.meta.notes[0]), std::string::npos);
    }
  }
}

// A recorder killed with SIGKILL keeps everything older than one second.
TEST(SessionWriterTest, SigkillKeepsEverythingOlderThanOneSecond) {
  TempDir tmp;
  const std::string dir = tmp.Sub("k.sweepscan");
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::close(ready[0]);
    SessionWriterOptions options;  // Default interval (0.5 s); a large buffer so only time flushes.
    options.max_buffered_bytes = 64u << 20;
    std::unique_ptr<SessionWriter> w;
    if (!SessionWriter::Create(dir, TestMeta(), options, &w).ok()) ::_exit(2);
    const char go = 1;
    if (::write(ready[1], &go, 1) != 1) ::_exit(3);
    for (uint32_t i = 0;; ++i) {
      // Record: its index (u32), time = steady clock, shared with the parent.
      const auto now = SteadyClock::now();
      const Bytes b = {uint8_t(i), uint8_t(i >> 8), uint8_t(i >> 16), uint8_t(i >> 24)};
      if (!w->Append(b, now.time_since_epoch().count()).ok()) ::_exit(4);
      if (!w->FlushIfDue(now).ok()) ::_exit(5);
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
  }
  ::close(ready[1]);
  char go = 0;
  ASSERT_EQ(::read(ready[0], &go, 1), 1);
  ::close(ready[0]);
  std::this_thread::sleep_for(std::chrono::milliseconds(2700));
  const auto kill_time = SteadyClock::now();
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "child exited with " << WEXITSTATUS(status);

  Session s;
  const Status st = LoadSession(dir, FramesLoadOptions(), &s);
  ASSERT_TRUE(st.ok()) << st.message();
  ASSERT_GT(s.records.size(), 100u);
  // A contiguous prefix of what was appended ...
  for (size_t i = 0; i < s.records.size(); ++i) {
    ASSERT_EQ(s.records[i].bytes.size(), 4u);
    const uint32_t index = s.records[i].bytes[0] | s.records[i].bytes[1] << 8 |
                           s.records[i].bytes[2] << 16 | uint32_t(s.records[i].bytes[3]) << 24;
    ASSERT_EQ(index, i);
  }
  // ... reaching to within one second of the kill: every record older than
  // that was appended before the last one loaded.
  const int64_t newest = s.records.back().receive_time_ns;
  const int64_t limit = (kill_time - std::chrono::seconds(1)).time_since_epoch().count();
  EXPECT_GE(newest, limit) << "lost " << (limit - newest) * 1e-9 << " s more than allowed";
}

}  // namespace
}  // namespace sweepscan
