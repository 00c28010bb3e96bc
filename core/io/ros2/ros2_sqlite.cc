#include "core/io/ros2/ros2_sqlite.h"

#include <sqlite3.h>

#include <algorithm>
#include <map>
#include <utility>

#include "core/common/checked_file.h"

namespace sweepscan::io {

namespace {

struct Topic {
  std::string name, type, format;
  RosMessageKind kind = RosMessageKind::kOther;
  bool decode = false;
  uint64_t count = 0;
  int64_t first_ns = 0, last_ns = 0;
};

// One read-only connection and the bag's topics.
class Bag {
 public:
  explicit Bag(std::string path) : path_(std::move(path)) {}
  ~Bag() { sqlite3_close(db_); }
  Bag(const Bag&) = delete;
  Bag& operator=(const Bag&) = delete;

  Status Open();
  Status Prepare(const char* sql, sqlite3_stmt** stmt);
  Status Error(const std::string& what) const {
    return Status::Error(path_ + ": " + what + ": " + sqlite3_errmsg(db_));
  }
  // Counts, first and last timestamps per topic (GROUP BY over messages).
  Status CountMessages();
  void Fill(RosBagSummary* s) const;

  const std::string& path() const { return path_; }
  std::map<int64_t, Topic>& topics() { return topics_; }

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
  std::map<int64_t, Topic> topics_;  // by topics.id
};

// Finalizes a statement when it goes out of scope.
struct Statement {
  ~Statement() { sqlite3_finalize(stmt); }
  sqlite3_stmt* stmt = nullptr;
};

std::string Text(sqlite3_stmt* stmt, int column) {
  const unsigned char* t = sqlite3_column_text(stmt, column);
  return t == nullptr ? std::string() : std::string(reinterpret_cast<const char*>(t));
}

Status Bag::Prepare(const char* sql, sqlite3_stmt** stmt) {
  if (sqlite3_prepare_v2(db_, sql, -1, stmt, nullptr) != SQLITE_OK) {
    return Error(std::string("not a rosbag2 sqlite3 bag (") + sql + ")");
  }
  return Status::Ok();
}

Status Bag::Open() {
  Status s = CheckRegularFile(path_);
  if (!s.ok()) return s;
  if (sqlite3_open_v2(path_.c_str(), &db_, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    return Error("cannot open as sqlite3 database");
  }
  Statement q;
  s = Prepare("SELECT id, name, type, serialization_format FROM topics", &q.stmt);
  if (!s.ok()) return s;
  int rc;
  while ((rc = sqlite3_step(q.stmt)) == SQLITE_ROW) {
    Topic t;
    t.name = Text(q.stmt, 1);
    t.type = Text(q.stmt, 2);
    t.format = Text(q.stmt, 3);
    t.kind = RosMessageKindFromType(t.type);
    topics_[sqlite3_column_int64(q.stmt, 0)] = std::move(t);
  }
  if (rc != SQLITE_DONE) return Error("reading the topics table");
  return Status::Ok();
}

Status Bag::CountMessages() {
  Statement q;
  Status s = Prepare(
      "SELECT topic_id, COUNT(*), MIN(timestamp), MAX(timestamp) FROM messages GROUP BY topic_id",
      &q.stmt);
  if (!s.ok()) return s;
  int rc;
  while ((rc = sqlite3_step(q.stmt)) == SQLITE_ROW) {
    const int64_t id = sqlite3_column_int64(q.stmt, 0);
    auto it = topics_.find(id);
    if (it == topics_.end()) {
      return Status::Error(path_ + ": " + std::to_string(sqlite3_column_int64(q.stmt, 1)) +
                           " messages have topic_id " + std::to_string(id) +
                           ", which is not in the topics table");
    }
    it->second.count = static_cast<uint64_t>(sqlite3_column_int64(q.stmt, 1));
    it->second.first_ns = sqlite3_column_int64(q.stmt, 2);
    it->second.last_ns = sqlite3_column_int64(q.stmt, 3);
  }
  if (rc != SQLITE_DONE) return Error("counting messages");
  return Status::Ok();
}

void Bag::Fill(RosBagSummary* s) const {
  s->format = "rosbag2-sqlite3";
  s->compression = "none";
  uint64_t size = 0;
  s->file_bytes = CheckRegularFile(path_, &size).ok() ? size : 0;
  s->message_count = 0;
  s->start_ns = s->end_ns = 0;
  std::map<std::string, RosTopicInfo> by_name;  // sorted by name
  for (const auto& [id, t] : topics_) {
    RosTopicInfo& info = by_name[t.name];
    const bool first = info.topic.empty();
    if (first) {
      info.topic = t.name;
      info.type = t.type;
      info.serialization = t.format;
    }
    if (t.count > 0) {
      info.first_ns = info.message_count == 0 ? t.first_ns : std::min(info.first_ns, t.first_ns);
      info.last_ns = info.message_count == 0 ? t.last_ns : std::max(info.last_ns, t.last_ns);
      s->start_ns = s->message_count == 0 ? t.first_ns : std::min(s->start_ns, t.first_ns);
      s->end_ns = s->message_count == 0 ? t.last_ns : std::max(s->end_ns, t.last_ns);
    }
    info.message_count += t.count;
    s->message_count += t.count;
  }
  s->topics.clear();
  for (auto& [name, info] : by_name) s->topics.push_back(std::move(info));
}

}  // namespace

Status SummarizeRos2Sqlite(const std::string& path, RosBagSummary* s) {
  Bag bag(path);
  Status st = bag.Open();
  if (st.ok()) st = bag.CountMessages();
  if (st.ok()) bag.Fill(s);
  return st;
}

Status ReadRos2Sqlite(const std::string& path, const RosReadOptions& opt, RosMessageSink* sink,
                      RosBagSummary* summary, RosReadStats* stats, Ros2ReadReport* report) {
  RosReadStats local_stats;
  if (stats == nullptr) stats = &local_stats;
  Bag bag(path);
  Status st = bag.Open();
  if (st.ok()) st = bag.CountMessages();
  if (!st.ok()) return st;
  if (summary != nullptr) bag.Fill(summary);
  uint64_t total = 0;
  for (auto& [id, t] : bag.topics()) {
    const bool wanted = opt.topics.empty() || opt.topics.count(t.name) > 0;
    t.decode = wanted && t.kind != RosMessageKind::kOther && t.format == "cdr";
    if (report != nullptr && wanted && t.kind != RosMessageKind::kOther && t.format != "cdr") {
      report->warnings.push_back(path + ": topic " + t.name + " (" + t.type +
                                 ") is in serialization format '" + t.format +
                                 "', not cdr: its messages are skipped");
    }
    total += t.count;
  }
  // Sort only the small columns; fetch each blob by its primary key.
  Statement order, blob;
  st = bag.Prepare("SELECT id, topic_id, timestamp FROM messages ORDER BY timestamp, id",
                   &order.stmt);
  if (st.ok()) st = bag.Prepare("SELECT data FROM messages WHERE id = ?", &blob.stmt);
  if (!st.ok()) return st;
  uint64_t done = 0;
  int rc;
  while ((rc = sqlite3_step(order.stmt)) == SQLITE_ROW) {
    const int64_t id = sqlite3_column_int64(order.stmt, 0);
    const int64_t topic_id = sqlite3_column_int64(order.stmt, 1);
    auto it = bag.topics().find(topic_id);
    if (it == bag.topics().end()) {
      return Status::Error(path + ": message " + std::to_string(id) + " has topic_id " +
                           std::to_string(topic_id) + ", which is not in the topics table");
    }
    Topic& t = it->second;
    if (!t.decode) {
      ++stats->messages_skipped;
    } else {
      sqlite3_reset(blob.stmt);
      sqlite3_bind_int64(blob.stmt, 1, id);
      if (sqlite3_step(blob.stmt) != SQLITE_ROW) {
        return bag.Error("reading message " + std::to_string(id));
      }
      const auto* data = static_cast<const uint8_t*>(sqlite3_column_blob(blob.stmt, 0));
      const size_t n = static_cast<size_t>(sqlite3_column_bytes(blob.stmt, 0));
      stats->bytes_read += n;
      RosMessageInfo info;
      info.topic = &t.name;
      info.type = &t.type;
      info.log_time_ns = sqlite3_column_int64(order.stmt, 2);
      // data is null for an empty blob: decoding then fails with "needs 4 bytes".
      static const uint8_t kEmpty = 0;
      if (!DispatchCdrMessage(t.kind, info, data != nullptr ? data : &kEmpty, n, sink, stats)) {
        return Status::Error(path + ": cancelled");
      }
    }
    ++done;
    if (opt.progress && (done % 256 == 0 || done == total) &&
        !opt.progress(total ? static_cast<double>(done) / total : 1.0)) {
      return Status::Error(path + ": cancelled");
    }
  }
  if (rc != SQLITE_DONE) return bag.Error("reading messages");
  return Status::Ok();
}

}  // namespace sweepscan::io
