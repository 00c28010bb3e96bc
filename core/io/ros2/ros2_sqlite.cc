#include "core/io/ros2/ros2_sqlite.h"

#include <sqlite3.h>

#include <algorithm>
#include <functional>
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
    if (cancelled_) return Status::Error(path_ + ": cancelled");
    if (Corrupt()) return Damaged(what);
    return Status::Error(path_ + ": " + what + ": " + sqlite3_errmsg(db_));
  }
  Status Damaged(const std::string& what) const {
    return Status::Error(path_ + ": the database is damaged or truncated (" + what +
                         ": sqlite: " + sqlite3_errmsg(db_) + ")");
  }
  // The last error was damage (a file cut short, overwritten pages). A
  // file cut short reads as SQLITE_CORRUPT (sqlite zero-fills a short read
  // and then finds the page malformed; SQLITE_NOTADB is a file that is no
  // database at all, said as such). SQLITE_IOERR is the disk or the OS
  // failing to read: a failed read, not a partial bag to import with a
  // warning.
  bool Corrupt() const { return !cancelled_ && sqlite3_errcode(db_) == SQLITE_CORRUPT; }
  // Counts, first and last timestamps per topic (GROUP BY over messages);
  // on a damaged file, of the messages that can be read (MarkDamaged).
  Status CountMessages();
  void Fill(RosBagSummary* s) const;
  // What the damage cost, said once: "how many" messages could be read.
  void MarkDamaged() {
    if (damage_.empty()) damage_ = sqlite3_errmsg(db_);
  }
  std::string DamageWarning(uint64_t read, const char* what) const {
    return path_ + ": the database is damaged or truncated (sqlite: " + damage_ +
           "): " + std::to_string(read) + " messages " + what + ", the rest is lost";
  }
  bool damaged() const { return !damage_.empty(); }

  // Lets `progress` stop one long statement too (the GROUP BY that counts,
  // the ORDER BY that sorts: seconds on a bag of millions of messages,
  // before their first row): sqlite calls back every ~100 000 of its
  // virtual machine's steps, and false interrupts the statement
  // (SQLITE_INTERRUPT, said as "cancelled"). It is asked at the fraction
  // last reported (set_fraction), so that a bar does not jump back.
  void CancelBy(const std::function<bool(double)>& progress) {
    if (!progress) return;
    progress_ = progress;
    sqlite3_progress_handler(
        db_, 100000,
        [](void* self) -> int {
          auto* bag = static_cast<Bag*>(self);
          if (bag->progress_(bag->fraction_)) return 0;
          bag->cancelled_ = true;
          return 1;
        },
        this);
  }
  void set_fraction(double f) { fraction_ = f; }
  double fraction() const { return fraction_; }
  bool cancelled() const { return cancelled_; }

  const std::string& path() const { return path_; }
  std::map<int64_t, Topic>& topics() { return topics_; }

 private:
  Status ReadTopics();
  std::string path_;
  sqlite3* db_ = nullptr;
  std::map<int64_t, Topic> topics_;  // by topics.id
  std::string damage_;               // sqlite's word for the damage, once seen
  std::function<bool(double)> progress_;
  double fraction_ = 0.0;
  bool cancelled_ = false;
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
    if (Corrupt()) return Damaged(sql);
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
  s = ReadTopics();
  if (s.ok() || !Corrupt()) return s;
  // A file shorter than its header's page count (a recording cut short,
  // a partial copy) is "malformed" to sqlite before any table is read;
  // writable_schema lets it read the pages that are there. The connection
  // is read-only: nothing is written.
  MarkDamaged();
  topics_.clear();
  sqlite3_exec(db_, "PRAGMA writable_schema = ON", nullptr, nullptr, nullptr);
  s = ReadTopics();
  if (!s.ok() && Corrupt()) return Damaged("its topics table cannot be read");
  return s;
}

Status Bag::ReadTopics() {
  Statement q;
  Status s = Prepare("SELECT id, name, type, serialization_format FROM topics", &q.stmt);
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
  if (!s.ok() && !Corrupt()) return s;
  int rc = s.ok() ? SQLITE_OK : SQLITE_CORRUPT;
  while (s.ok() && (rc = sqlite3_step(q.stmt)) == SQLITE_ROW) {
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
  if (rc == SQLITE_DONE) return Status::Ok();
  if (!Corrupt()) return Error("counting messages");
  // Damaged: the rows that can be read, in storage order, up to the damage.
  MarkDamaged();
  for (auto& [id, t] : topics_) t.count = 0;
  Statement scan;
  s = Prepare("SELECT topic_id, timestamp FROM messages", &scan.stmt);
  if (!s.ok()) return s;
  while (sqlite3_step(scan.stmt) == SQLITE_ROW) {
    auto it = topics_.find(sqlite3_column_int64(scan.stmt, 0));
    if (it == topics_.end()) continue;  // a damaged row's, or an orphan (refused when read)
    Topic& t = it->second;
    const int64_t ts = sqlite3_column_int64(scan.stmt, 1);
    t.first_ns = t.count == 0 ? ts : std::min(t.first_ns, ts);
    t.last_ns = t.count == 0 ? ts : std::max(t.last_ns, ts);
    ++t.count;
  }
  if (cancelled_) return Error("counting messages");
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

Status SummarizeRos2Sqlite(const std::string& path, RosBagSummary* s, Ros2ReadReport* report,
                           const std::function<bool(double)>& progress) {
  Bag bag(path);
  Status st = bag.Open();
  if (st.ok()) {
    bag.CancelBy(progress);
    st = bag.CountMessages();
  }
  if (st.ok()) bag.Fill(s);
  if (st.ok() && bag.damaged() && report != nullptr) {
    report->damaged = true;
    report->warnings.push_back(bag.DamageWarning(s->message_count, "could be read"));
  }
  return st;
}

Status ReadRos2Sqlite(const std::string& path, const RosReadOptions& opt, RosMessageSink* sink,
                      RosBagSummary* summary, RosReadStats* stats, Ros2ReadReport* report) {
  RosReadStats local_stats;
  if (stats == nullptr) stats = &local_stats;
  Bag bag(path);
  Status st = bag.Open();
  if (st.ok()) {
    bag.CancelBy(opt.progress);
    st = bag.CountMessages();
  }
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
  st = bag.Prepare("SELECT data FROM messages WHERE id = ?", &blob.stmt);
  if (!st.ok()) return st;
  uint64_t done = 0;
  bool lost = false;  // a message's blob is in the damaged part
  // One message: (id, topic_id, timestamp) in the statement's columns 0..2.
  const auto one = [&](sqlite3_stmt* row) {
    const int64_t id = sqlite3_column_int64(row, 0);
    const int64_t topic_id = sqlite3_column_int64(row, 1);
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
        if (bag.Corrupt()) {
          bag.MarkDamaged();
          lost = true;
          return Status::Ok();
        }
        return bag.Error("reading message " + std::to_string(id));
      }
      const auto* data = static_cast<const uint8_t*>(sqlite3_column_blob(blob.stmt, 0));
      const size_t n = static_cast<size_t>(sqlite3_column_bytes(blob.stmt, 0));
      stats->bytes_read += n;
      RosMessageInfo info;
      info.topic = &t.name;
      info.type = &t.type;
      info.log_time_ns = sqlite3_column_int64(row, 2);
      // data is null for an empty blob: decoding then fails with "needs 4 bytes".
      static const uint8_t kEmpty = 0;
      if (!DispatchCdrMessage(t.kind, info, data != nullptr ? data : &kEmpty, n, sink, stats)) {
        return Status::Error(path + ": cancelled");
      }
    }
    ++done;
    if (opt.progress && (done % 256 == 0 || done == total)) {
      bag.set_fraction(total ? std::min(1.0, static_cast<double>(done) / total) : 1.0);
      if (!opt.progress(bag.fraction())) return Status::Error(path + ": cancelled");
    }
    return Status::Ok();
  };
  int rc = SQLITE_DONE;
  bool any = false;
  int64_t last_ts = 0, last_id = 0;  // the last message handed on, in (timestamp, id) order
  st = bag.Prepare("SELECT id, topic_id, timestamp FROM messages ORDER BY timestamp, id",
                   &order.stmt);
  if (!st.ok() && !bag.Corrupt()) return st;
  if (st.ok()) {
    while (!lost && (rc = sqlite3_step(order.stmt)) == SQLITE_ROW) {
      st = one(order.stmt);
      if (!st.ok()) return st;
      any = true;
      last_ts = sqlite3_column_int64(order.stmt, 2);
      last_id = sqlite3_column_int64(order.stmt, 0);
    }
    if (rc != SQLITE_DONE && rc != SQLITE_ROW && !bag.Corrupt())
      return bag.Error("reading messages");
  }
  if (rc != SQLITE_DONE || lost || bag.damaged()) {
    // Damaged: the order (by timestamp) broke off at the damage. The rows
    // not handed on yet that can still be read follow in storage order
    // (rosbag2 inserts them as they arrive, so nearly in time order).
    bag.MarkDamaged();
    Statement rest;
    if (!lost && bag.Prepare("SELECT id, topic_id, timestamp FROM messages", &rest.stmt).ok()) {
      while (!lost && sqlite3_step(rest.stmt) == SQLITE_ROW) {
        const int64_t ts = sqlite3_column_int64(rest.stmt, 2),
                      id = sqlite3_column_int64(rest.stmt, 0);
        if (any && (ts < last_ts || (ts == last_ts && id <= last_id))) continue;
        st = one(rest.stmt);
        if (!st.ok()) return st;
      }
    }
    if (bag.cancelled()) return bag.Error("reading messages");
    if (report != nullptr) {
      report->damaged = true;
      report->warnings.push_back(bag.DamageWarning(done, "could be read"));
    }
  }
  return Status::Ok();
}

}  // namespace sweepscan::io
