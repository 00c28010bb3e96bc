// The rosbag2 sqlite3 reader against a .db3 written by Python's sqlite3
// (make_ros2_db3.py, messages inserted shuffled) from CDR bytes of
// @foxglove/rosmsg2-serialization; and FindRos2Bag / ReadRos2Bag over the
// rosbag2 folders in tests/data/ros2/.
#include "core/io/ros2/ros2_sqlite.h"

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <set>

#include "core/io/ros2/ros2_bag.h"
#include "tests/core/io/ros2/ros2_test_bags.h"
#include "tests/testing/run_command.h"

namespace sweepscan::io {
namespace {

using testing::kBaseNs;
using testing::kLatencyNs;
using testing::RecordingSink;
using testing::Ros2Data;

constexpr uint64_t kDecodable = testing::kMessages - testing::kChatters;

// A scratch folder under the test temp dir, removed with its files.
class Scratch {
 public:
  explicit Scratch(const std::string& name) : dir_(::testing::TempDir() + "/" + name) {
    Remove();
    mkdir(dir_.c_str(), 0755);
  }
  ~Scratch() { Remove(); }
  std::string Write(const std::string& name, const std::string& text) const {
    std::ofstream(dir_ + "/" + name, std::ios::binary) << text;
    return dir_ + "/" + name;
  }
  std::string Copy(const std::string& from, const std::string& name) const {
    std::ifstream in(from, std::ios::binary);
    std::ofstream out(dir_ + "/" + name, std::ios::binary);
    out << in.rdbuf();
    return dir_ + "/" + name;
  }
  const std::string& dir() const { return dir_; }

 private:
  void Remove() const { sweepscan::testing::ShellOrFail("rm -rf '" + dir_ + "'"); }
  std::string dir_;
};

void Exec(const std::string& db, const std::string& sql) {
  sqlite3* h = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
  char* error = nullptr;
  EXPECT_EQ(sqlite3_exec(h, sql.c_str(), nullptr, nullptr, &error), SQLITE_OK) << error;
  sqlite3_free(error);
  sqlite3_close(h);
}

const std::string kDb = "sqlite_bag/sqlite_bag_0.db3";

TEST(Ros2SqliteTest, ReadsEveryMessageByTimestampFieldForField) {
  RecordingSink sink;
  RosReadStats stats;
  RosBagSummary summary;
  Ros2ReadReport report;
  Status s = ReadRos2Sqlite(Ros2Data(kDb), RosReadOptions(), &sink, &summary, &stats, &report);
  ASSERT_TRUE(s.ok()) << s.message();
  testing::ExpectAllKnownMessages(sink);  // includes: in log-time order
  EXPECT_EQ(stats.messages_read, kDecodable);
  EXPECT_EQ(stats.messages_skipped, uint64_t{testing::kChatters});
  EXPECT_EQ(stats.messages_undecodable, 0u);
  EXPECT_GT(stats.bytes_read, 0u);
  EXPECT_TRUE(report.warnings.empty());
  EXPECT_EQ(summary.message_count, uint64_t{testing::kMessages});
}

TEST(Ros2SqliteTest, Summary) {
  RosBagSummary s;
  Status st = SummarizeRos2Sqlite(Ros2Data(kDb), &s);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_EQ(s.format, "rosbag2-sqlite3");
  EXPECT_EQ(s.compression, "none");
  EXPECT_EQ(s.file_bytes, testing::ReadBytes(Ros2Data(kDb)).size());
  EXPECT_EQ(s.message_count, uint64_t{testing::kMessages});
  EXPECT_EQ(s.start_ns, testing::kTfStaticLogNs);
  EXPECT_EQ(s.end_ns, testing::ScanStampNs(19) + kLatencyNs);
  ASSERT_EQ(s.topics.size(), 6u);
  EXPECT_EQ(s.topics[1].topic, "/imu");
  EXPECT_EQ(s.topics[1].type, "sensor_msgs/msg/Imu");
  EXPECT_EQ(s.topics[1].serialization, "cdr");
  EXPECT_EQ(s.topics[1].message_count, 10u);
  EXPECT_EQ(s.topics[1].first_ns, testing::ImuStampNs(0) + kLatencyNs);
  EXPECT_EQ(s.topics[1].last_ns, testing::ImuStampNs(9) + kLatencyNs);
  EXPECT_EQ(s.topics[4].topic, "/tf");
  EXPECT_EQ(s.topics[4].kind(), RosMessageKind::kTf);
}

TEST(Ros2SqliteTest, TopicFilterAndCancel) {
  RecordingSink sink;
  RosReadStats stats;
  RosReadOptions opt;
  opt.topics = {"/imu"};
  ASSERT_TRUE(ReadRos2Sqlite(Ros2Data(kDb), opt, &sink, nullptr, &stats).ok());
  ASSERT_EQ(sink.imus.size(), 10u);
  testing::ExpectImu(sink.imus[3], testing::ExpectedImu(3));
  EXPECT_EQ(sink.imus[3].orientation_covariance[0], -1.0);
  EXPECT_EQ(stats.messages_read, 10u);
  EXPECT_EQ(stats.messages_skipped, uint64_t{testing::kMessages} - 10);

  RecordingSink stopper;
  stopper.stop_after = 3;
  Status s = ReadRos2Sqlite(Ros2Data(kDb), RosReadOptions(), &stopper, nullptr, nullptr);
  EXPECT_EQ(s.message(), Ros2Data(kDb) + ": cancelled");
  EXPECT_EQ(stopper.order.size(), 3u);
}

// A bag of millions of messages is counted (GROUP BY) and sorted (ORDER BY)
// by one sqlite statement each, seconds before its first row: the progress
// callback is asked during them too, and stops them.
TEST(Ros2SqliteTest, CountingAndSortingAreCancellable) {
  Scratch scratch("ros2_sqlite_cancel");
  const std::string db = scratch.Copy(Ros2Data(kDb), "big.db3");
  Exec(db,
       "WITH RECURSIVE n(i) AS (SELECT 1 UNION ALL SELECT i + 1 FROM n WHERE i < 200000) "
       "INSERT INTO messages (topic_id, timestamp, data) SELECT (SELECT id FROM topics WHERE "
       "name = '/chatter'), (SELECT MIN(timestamp) FROM messages), x'00' FROM n");
  int asked = 0;
  RosBagSummary s;
  Status st = SummarizeRos2Sqlite(db, &s, nullptr, [&](double f) {
    EXPECT_EQ(f, 0.0);
    ++asked;
    return true;
  });
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_EQ(s.message_count, uint64_t{testing::kMessages} + 200000);
  EXPECT_GT(asked, 0);  // during the count, which has no row to report before it ends
  st = SummarizeRos2Sqlite(db, &s, nullptr, [](double) { return false; });
  EXPECT_EQ(st.message(), db + ": cancelled");

  // Reading: stopped in the count or the sort, before any message.
  RecordingSink sink;
  RosReadOptions opt;
  opt.progress = [](double) { return false; };
  st = ReadRos2Sqlite(db, opt, &sink, nullptr, nullptr);
  EXPECT_EQ(st.message(), db + ": cancelled");
  EXPECT_TRUE(sink.order.empty());
  // Stopped at the first report after 256 messages: the fraction then is
  // the read's, not 0 (the sort's callbacks ask at the last fraction).
  double last = -1.0;
  bool went_back = false;
  opt.progress = [&](double f) {
    went_back = went_back || f < last;
    last = f;
    return f < 0.5;
  };
  st = ReadRos2Sqlite(db, opt, &sink, nullptr, nullptr);
  EXPECT_EQ(st.message(), db + ": cancelled");
  EXPECT_FALSE(went_back);
  EXPECT_GE(last, 0.5);
}

TEST(Ros2SqliteTest, BadDatabasesAreNamed) {
  Scratch scratch("ros2_sqlite_bad");
  RosBagSummary s;
  const std::string text = scratch.Write("text.db3", "this is not a database, just some text\n");
  Status st = SummarizeRos2Sqlite(text, &s);
  EXPECT_EQ(st.message().rfind(text + ": not a rosbag2 sqlite3 bag (", 0), 0u) << st.message();
  EXPECT_NE(st.message().find("file is not a database"), std::string::npos) << st.message();

  const std::string empty = scratch.dir() + "/empty.db3";
  Exec(empty, "CREATE TABLE other(x INTEGER)");
  st = SummarizeRos2Sqlite(empty, &s);
  EXPECT_NE(st.message().find("no such table: topics"), std::string::npos) << st.message();

  EXPECT_EQ(SummarizeRos2Sqlite(scratch.dir() + "/none.db3", &s).message(),
            scratch.dir() + "/none.db3: cannot open for reading: No such file or directory");

  // A message whose topic_id is not in topics.
  const std::string orphan = scratch.Copy(Ros2Data(kDb), "orphan.db3");
  Exec(orphan, "UPDATE messages SET topic_id = 42 WHERE id = 7");
  RecordingSink sink;
  st = ReadRos2Sqlite(orphan, RosReadOptions(), &sink, nullptr, nullptr);
  EXPECT_EQ(st.message(),
            orphan + ": 1 messages have topic_id 42, which is not in the topics table");

  // Bad CDR bytes: counted, the sink told, reading goes on.
  const std::string bad = scratch.Copy(Ros2Data(kDb), "bad_cdr.db3");
  Exec(bad,
       "UPDATE messages SET data = X'000100000000' WHERE id = (SELECT MIN(m.id) FROM messages m "
       "JOIN topics t ON m.topic_id = t.id WHERE t.name = '/scan');"
       "UPDATE messages SET data = X'' WHERE id = (SELECT MIN(m.id) FROM messages m "
       "JOIN topics t ON m.topic_id = t.id WHERE t.name = '/odom')");
  RosReadStats stats;
  st = ReadRos2Sqlite(bad, RosReadOptions(), &sink, nullptr, &stats);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_EQ(stats.messages_undecodable, 2u);
  EXPECT_EQ(stats.messages_read, kDecodable - 2);
  ASSERT_EQ(sink.undecodable.size(), 2u);
  EXPECT_EQ(sink.undecodable[0],
            "/scan: LaserScan: header.stamp.sec: needs 4 bytes, 2 left at byte 4");
  EXPECT_EQ(sink.undecodable[1],
            "/odom: Odometry: encapsulation header: needs 4 bytes, the message has 0");
}

// A .db3 cut short (a recording that lost power, a partial copy): sqlite
// calls it "database disk image is malformed" before reading a row. What
// it can still read is delivered, and a warning says the file is damaged
// and how many messages were read; a file too short to hold its topics
// table is refused as damaged or truncated, not as "not a rosbag2 bag".
TEST(Ros2SqliteTest, ATruncatedDatabaseGivesWhatItStillHolds) {
  Scratch scratch("ros2_sqlite_truncated");
  // Bigger than one page of rows: the test bag's messages 64 times over,
  // each copy 10 s after the one before (sqlite itself writes them).
  const std::string big = scratch.Copy(Ros2Data(kDb), "big.db3");
  for (int k = 0; k < 6; ++k) {
    Exec(big, "INSERT INTO messages(topic_id, timestamp, data) SELECT topic_id, timestamp + " +
                  std::to_string(int64_t{10000000000} << k) + ", data FROM messages");
  }
  RecordingSink all;
  RosReadStats all_stats;
  ASSERT_TRUE(ReadRos2Sqlite(big, RosReadOptions(), &all, nullptr, &all_stats).ok());
  ASSERT_EQ(all_stats.messages_read, kDecodable * 64);
  std::ifstream in(big, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), {});
  ASSERT_GT(bytes.size(), 100000u);

  const std::string cut = scratch.Write("cut.db3", bytes.substr(0, bytes.size() * 6 / 10));
  RecordingSink sink;
  RosReadStats stats;
  Ros2ReadReport report;
  RosBagSummary summary;
  Status s = ReadRos2Sqlite(cut, RosReadOptions(), &sink, &summary, &stats, &report);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_GT(stats.messages_read, all_stats.messages_read / 3);
  EXPECT_LT(stats.messages_read, all_stats.messages_read);
  // Each message read is one of the bag's, once.
  std::multiset<int64_t> known, seen;
  for (const auto& m : all.order) known.insert(m.log_time_ns);
  for (const auto& m : sink.order) {
    EXPECT_EQ(seen.count(m.log_time_ns), 0u) << m.log_time_ns;
    EXPECT_EQ(known.count(m.log_time_ns), 1u) << m.log_time_ns;
    seen.insert(m.log_time_ns);
  }
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_EQ(report.warnings[0].rfind(cut + ": the database is damaged or truncated (sqlite: ", 0),
            0u)
      << report.warnings[0];
  EXPECT_NE(report.warnings[0].find(" messages could be read, the rest is lost"), std::string::npos)
      << report.warnings[0];
  RosBagSummary quick;
  Ros2ReadReport quick_report;
  s = SummarizeRos2Sqlite(cut, &quick, &quick_report);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_GE(quick.message_count, stats.messages_read);
  ASSERT_EQ(quick_report.warnings.size(), 1u);
  EXPECT_NE(quick_report.warnings[0].find("damaged or truncated"), std::string::npos);

  // Only the first page (the schema): nothing to read.
  const std::string stub = scratch.Write("stub.db3", bytes.substr(0, 4096));
  s = ReadRos2Sqlite(stub, RosReadOptions(), &sink, nullptr, nullptr, nullptr);
  EXPECT_EQ(s.message().rfind(stub + ": the database is damaged or truncated (", 0), 0u)
      << s.message();
}

TEST(Ros2BagTest, FindsFoldersAndFiles) {
  std::string storage;
  std::vector<std::string> files;
  Status s = FindRos2Bag(Ros2Data("sqlite_bag"), &storage, &files);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(storage, "sqlite3");
  EXPECT_EQ(files, std::vector<std::string>{Ros2Data("sqlite_bag/sqlite_bag_0.db3")});

  s = FindRos2Bag(Ros2Data("mcap_bag/"), &storage, &files);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(storage, "mcap");
  EXPECT_EQ(files, (std::vector<std::string>{Ros2Data("mcap_bag/mcap_bag_0.mcap"),
                                             Ros2Data("mcap_bag/mcap_bag_1.mcap")}));

  ASSERT_TRUE(FindRos2Bag(Ros2Data("ros2_zstd.mcap"), &storage, &files).ok());
  EXPECT_EQ(storage, "mcap");
  ASSERT_TRUE(FindRos2Bag(Ros2Data(kDb), &storage, &files).ok());
  EXPECT_EQ(storage, "sqlite3");

  Scratch scratch("ros2_bag_find");
  // Recognised by content when the name does not say.
  scratch.Copy(Ros2Data("ros2_unchunked.mcap"), "recording.bin");
  ASSERT_TRUE(FindRos2Bag(scratch.dir() + "/recording.bin", &storage, &files).ok());
  EXPECT_EQ(storage, "mcap");
  // A folder without metadata.yaml but with exactly one bag file.
  scratch.Copy(Ros2Data(kDb), "only.db3");
  ASSERT_TRUE(FindRos2Bag(scratch.dir(), &storage, &files).ok());
  EXPECT_EQ(storage, "sqlite3");
  EXPECT_EQ(files, std::vector<std::string>{scratch.dir() + "/only.db3"});
  scratch.Copy(Ros2Data("ros2_zstd.mcap"), "second.mcap");
  EXPECT_EQ(FindRos2Bag(scratch.dir(), &storage, &files).message(),
            scratch.dir() +
                ": no metadata.yaml, and 2 .db3/.mcap files (only.db3, second.mcap): without "
                "metadata.yaml, several files are read as one split bag only when all are "
                "NAME_0.db3, NAME_1.db3, ... of one storage");
  EXPECT_EQ(FindRos2Bag(scratch.Write("notes.txt", "hello"), &storage, &files).message(),
            scratch.dir() +
                "/notes.txt: not a ROS 2 bag (neither a rosbag2 folder, a .db3 "
                "sqlite3 file nor an .mcap file)");
}

TEST(Ros2BagTest, MetadataThatIsRefused) {
  Scratch scratch("ros2_bag_metadata");
  scratch.Copy(Ros2Data(kDb), "b_0.db3");
  const std::string yaml = scratch.dir() + "/metadata.yaml";
  std::string storage;
  std::vector<std::string> files;
  auto find = [&](const std::string& text) {
    scratch.Write("metadata.yaml", text);
    return FindRos2Bag(scratch.dir(), &storage, &files);
  };
  EXPECT_EQ(find("rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n"
                 "  compression_format: zstd\n  compression_mode: FILE\n"
                 "  relative_file_paths:\n    - b_0.db3.zstd\n")
                .message(),
            yaml +
                ": compression_mode \"FILE\" is not supported (decompress the bag with "
                "`ros2 bag convert` first)");
  EXPECT_EQ(find("rosbag2_bagfile_information:\n  storage_identifier: rosbag_v2\n"
                 "  relative_file_paths:\n    - b_0.db3\n")
                .message(),
            yaml + ": storage_identifier \"rosbag_v2\" is not supported (sqlite3 and mcap are)");
  EXPECT_EQ(find("rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n"
                 "  relative_file_paths:\n    - b_0.db3\n    - b_1.db3\n")
                .message(),
            yaml + ": lists \"b_1.db3\", which is not a file in " + scratch.dir());
  // A damaged file's bytes are quoted and cut, not echoed: a terminal
  // escape, a control byte, a byte that is not UTF-8, 300 bytes of a name.
  EXPECT_EQ(find("rosbag2_bagfile_information:\n  storage_identifier: \x1b[2J\x01\xff\n"
                 "  relative_file_paths:\n    - b_0.db3\n")
                .message(),
            yaml +
                ": storage_identifier \"\\u001b[2J\\u0001\\ufffd\" is not supported (sqlite3 and "
                "mcap are)");
  EXPECT_EQ(find("rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n"
                 "  relative_file_paths:\n    - " +
                 std::string(300, 'x') + "\n")
                .message(),
            yaml + ": lists \"" + std::string(80, 'x') + "\"..., which is not a file in " +
                scratch.dir());
  EXPECT_EQ(find("something_else: 1\n").message(), yaml + ": no rosbag2_bagfile_information");
  // Accepted: flow lists, quotes, the folder name in front (early rosbag2).
  ASSERT_TRUE(find("rosbag2_bagfile_information:\n  version: 4\n  storage_identifier: \"sqlite3\"\n"
                   "  relative_file_paths: [ros2_bag_metadata/b_0.db3]\n  compression_mode: \"\"\n")
                  .ok());
  EXPECT_EQ(files, std::vector<std::string>{scratch.dir() + "/b_0.db3"});
}

// A split recording that crashed: rosbag2 writes metadata.yaml when it
// closes, so only NAME_0.mcap, NAME_1.mcap, ... are there. They are read
// in numeric order as one bag (not in name order: _10 after _9), with a
// warning that metadata.yaml is missing.
TEST(Ros2BagTest, ASplitBagWithoutMetadataIsReadInNumericOrder) {
  Scratch scratch("split_without_metadata");
  scratch.Copy(Ros2Data("mcap_bag/mcap_bag_0.mcap"), "drive_9.mcap");
  scratch.Copy(Ros2Data("mcap_bag/mcap_bag_1.mcap"), "drive_10.mcap");
  RecordingSink sink;
  RosReadStats stats;
  Ros2ReadReport report;
  RosBagSummary summary;
  const Status s = ReadRos2Bag(scratch.dir(), RosReadOptions(), &sink, &summary, &stats, &report);
  ASSERT_TRUE(s.ok()) << s.message();
  testing::ExpectAllKnownMessages(sink);
  EXPECT_EQ(stats.messages_read, kDecodable);
  EXPECT_EQ(summary.message_count, uint64_t{testing::kMessages});
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_EQ(report.warnings[0],
            scratch.dir() +
                ": no metadata.yaml (a recording that did not close?): its 2 files "
                "drive_9.mcap .. drive_10.mcap are read in that order as one bag; "
                "missing: drive_0.mcap, drive_1.mcap, drive_2.mcap, drive_3.mcap, "
                "drive_4.mcap, drive_5.mcap, drive_6.mcap, drive_7.mcap, drive_8.mcap");
  RosBagSummary quick;
  ASSERT_TRUE(SummarizeRos2Bag(scratch.dir(), &quick).ok());
  EXPECT_EQ(quick.message_count, uint64_t{testing::kMessages});
}

TEST(Ros2BagTest, ReadsSplitMcapBagAndSqliteBag) {
  for (const char* bag : {"mcap_bag", "sqlite_bag"}) {
    SCOPED_TRACE(bag);
    RecordingSink sink;
    RosReadStats stats;
    RosBagSummary summary;
    Ros2ReadReport report;
    RosReadOptions opt;
    std::vector<double> progress;
    opt.progress = [&](double f) {
      progress.push_back(f);
      return true;
    };
    Status s = ReadRos2Bag(Ros2Data(bag), opt, &sink, &summary, &stats, &report);
    ASSERT_TRUE(s.ok()) << s.message();
    testing::ExpectAllKnownMessages(sink);
    EXPECT_EQ(stats.messages_read, kDecodable);
    EXPECT_TRUE(report.warnings.empty());
    EXPECT_EQ(summary.message_count, uint64_t{testing::kMessages});
    EXPECT_EQ(summary.start_ns, testing::kTfStaticLogNs);
    ASSERT_EQ(summary.topics.size(), 6u);
    EXPECT_EQ(summary.topics[3].message_count, 20u);
    ASSERT_FALSE(progress.empty());
    for (size_t i = 1; i < progress.size(); ++i) EXPECT_LE(progress[i - 1], progress[i]);
    EXPECT_DOUBLE_EQ(progress.back(), 1.0);

    RosBagSummary quick;
    s = SummarizeRos2Bag(Ros2Data(bag), &quick);
    ASSERT_TRUE(s.ok()) << s.message();
    EXPECT_EQ(quick.message_count, uint64_t{testing::kMessages});
    EXPECT_EQ(quick.format, std::string(bag) == "mcap_bag" ? "mcap" : "rosbag2-sqlite3");
    EXPECT_EQ(quick.compression, std::string(bag) == "mcap_bag" ? "zstd" : "none");
    EXPECT_EQ(quick.topics[3].message_count, 20u);
  }
}

}  // namespace
}  // namespace sweepscan::io
