#include "core/io/ros2/ros2_bag.h"

#include <dirent.h>
#include <sys/stat.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "core/common/checked_file.h"
#include "core/common/quoted.h"
#include "core/io/ros2/mcap.h"
#include "core/io/ros2/ros2_sqlite.h"

namespace sweepscan::io {

namespace {

bool EndsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

bool IsFolder(const std::string& path) {
  struct stat st;
  return stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

bool IsFile(const std::string& path) {
  struct stat st;
  return stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

std::string Trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}

// A scalar as rosbag2 writes it: plain, "double" or 'single' quoted.
std::string Scalar(const std::string& raw) {
  std::string v = Trim(raw);
  if (v.size() >= 2 && (v[0] == '"' || v[0] == '\'') && v.back() == v[0]) {
    return v.substr(1, v.size() - 2);
  }
  const size_t comment = v.find(" #");
  return comment == std::string::npos ? v : Trim(v.substr(0, comment));
}

// What we need of metadata.yaml. A line reader, not a YAML parser: it reads
// the block layout rosbag2 writes (keys two spaces under
// rosbag2_bagfile_information, list items under relative_file_paths as
// "- name" lines, or a flow list [a, b]).
struct Metadata {
  std::string storage, compression_mode;
  std::vector<std::string> files;
  bool has_info = false, has_files = false;
};

Metadata ParseMetadata(const std::string& text) {
  Metadata m;
  std::istringstream in(text);
  std::string line;
  int child_indent = -1;
  bool in_files = false;
  while (std::getline(in, line)) {
    const std::string t = Trim(line);
    if (t.empty() || t[0] == '#') continue;
    const int indent = static_cast<int>(line.find_first_not_of(' '));
    if (indent == 0) {
      m.has_info = m.has_info || t == "rosbag2_bagfile_information:";
      child_indent = -1;
      in_files = false;
      continue;
    }
    if (!m.has_info) continue;
    if (child_indent < 0) child_indent = indent;
    if (in_files && t.rfind("- ", 0) == 0 && indent >= child_indent) {
      m.files.push_back(Scalar(t.substr(2)));
      continue;
    }
    if (indent != child_indent) continue;
    in_files = false;
    const size_t colon = t.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = t.substr(0, colon), value = Trim(t.substr(colon + 1));
    if (key == "storage_identifier") m.storage = Scalar(value);
    if (key == "compression_mode") m.compression_mode = Scalar(value);
    if (key == "relative_file_paths") {
      m.has_files = true;
      if (value.empty()) {
        in_files = true;
      } else if (value.front() == '[' && value.back() == ']') {
        std::istringstream items(value.substr(1, value.size() - 2));
        std::string item;
        while (std::getline(items, item, ',')) {
          if (!Trim(item).empty()) m.files.push_back(Scalar(item));
        }
      }
    }
  }
  return m;
}

std::string StorageOfFile(const std::string& path) {
  if (EndsWith(path, ".db3")) return "sqlite3";
  if (EndsWith(path, ".mcap")) return "mcap";
  char head[16] = {};
  std::ifstream f(path, std::ios::binary);
  f.read(head, sizeof(head));
  if (memcmp(head, "\x89MCAP0\r\n", 8) == 0) return "mcap";
  if (memcmp(head, "SQLite format 3", 16) == 0) return "sqlite3";
  return "";
}

// NAME_N.EXT -> N, or -1 when the name is not so.
long SplitNumber(const std::string& name, const std::string& prefix, const std::string& ext) {
  if (name.size() <= prefix.size() + ext.size() || name.compare(0, prefix.size(), prefix) != 0 ||
      !EndsWith(name, ext)) {
    return -1;
  }
  const std::string digits = name.substr(prefix.size(), name.size() - prefix.size() - ext.size());
  if (digits.empty() || digits.size() > 9 ||
      digits.find_first_not_of("0123456789") != std::string::npos) {
    return -1;
  }
  return std::stol(digits);
}

// rosbag2 writes metadata.yaml when a recording closes: a recording that
// crashed or lost power leaves only its files, NAME_0.mcap, NAME_1.mcap, ...
// (the folder's name is NAME). One file is the bag; several are read as one
// bag in the order of N when they all are NAME_N of one storage.
Status FolderWithoutMetadata(const std::string& dir, std::string* storage,
                             std::vector<std::string>* files, std::vector<std::string>* warnings) {
  std::vector<std::string> found;
  if (DIR* d = opendir(dir.c_str())) {
    while (const dirent* e = readdir(d)) {
      const std::string name = e->d_name;
      if (EndsWith(name, ".db3") || EndsWith(name, ".mcap")) found.push_back(name);
    }
    closedir(d);
  }
  std::sort(found.begin(), found.end());
  if (found.size() == 1) {
    *storage = StorageOfFile(dir + "/" + found[0]);
    files->push_back(dir + "/" + found[0]);
    return Status::Ok();
  }
  std::string list;
  for (const std::string& f : found) list += (list.empty() ? " (" : ", ") + f;
  if (!list.empty()) list += ")";
  const auto refuse = [&](const std::string& why) {
    return Status::Error(dir + ": no metadata.yaml, and " + std::to_string(found.size()) +
                         " .db3/.mcap files" + list + ": " + why);
  };
  if (found.empty()) return refuse("not a ROS 2 bag folder");
  const std::string ext = EndsWith(found[0], ".db3") ? ".db3" : ".mcap";
  const size_t underscore = found[0].rfind('_');
  const std::string prefix =
      underscore == std::string::npos ? std::string() : found[0].substr(0, underscore + 1);
  std::vector<std::pair<long, std::string>> numbered;
  for (const std::string& f : found) {
    const long n = prefix.empty() ? -1 : SplitNumber(f, prefix, ext);
    if (n < 0) {
      return refuse(
          "without metadata.yaml, several files are read as one split bag only when "
          "all are NAME_0" +
          ext + ", NAME_1" + ext + ", ... of one storage");
    }
    numbered.emplace_back(n, f);
  }
  std::sort(numbered.begin(), numbered.end());
  std::string missing;
  for (size_t i = 0, expected = 0; i < numbered.size(); ++i, ++expected) {
    for (; static_cast<long>(expected) < numbered[i].first; ++expected) {
      missing += (missing.empty() ? "" : ", ") + prefix + std::to_string(expected) + ext;
    }
  }
  for (const auto& [n, f] : numbered) files->push_back(dir + "/" + f);
  *storage = ext == ".db3" ? "sqlite3" : "mcap";
  if (warnings != nullptr) {
    warnings->push_back(dir + ": no metadata.yaml (a recording that did not close?): its " +
                        std::to_string(numbered.size()) + " files " + numbered.front().second +
                        " .. " + numbered.back().second + " are read in that order as one bag" +
                        (missing.empty() ? "" : "; missing: " + missing));
  }
  return Status::Ok();
}

void Merge(const RosBagSummary& part, bool first, RosBagSummary* s) {
  if (first) {
    *s = part;
    return;
  }
  s->file_bytes += part.file_bytes;
  if (part.message_count > 0) {
    s->start_ns = s->message_count == 0 ? part.start_ns : std::min(s->start_ns, part.start_ns);
    s->end_ns = s->message_count == 0 ? part.end_ns : std::max(s->end_ns, part.end_ns);
  }
  s->message_count += part.message_count;
  std::vector<std::string> names;
  std::istringstream in(s->compression + "," + part.compression);
  for (std::string c; std::getline(in, c, ',');) {
    if (!c.empty()) names.push_back(c);
  }
  std::sort(names.begin(), names.end());
  names.erase(std::unique(names.begin(), names.end()), names.end());
  if (names.size() > 1) names.erase(std::remove(names.begin(), names.end(), "none"), names.end());
  s->compression.clear();
  for (const std::string& c : names) s->compression += (s->compression.empty() ? "" : ",") + c;
  std::map<std::string, RosTopicInfo> topics;
  for (const RosTopicInfo& t : s->topics) topics[t.topic] = t;
  for (const RosTopicInfo& t : part.topics) {
    auto [it, inserted] = topics.emplace(t.topic, t);
    if (inserted) continue;
    RosTopicInfo& m = it->second;
    // first/last are 0 when unknown (an MCAP summary section): stay unknown.
    if (t.message_count > 0 && m.message_count > 0 && t.first_ns != 0 && m.first_ns != 0) {
      m.first_ns = std::min(m.first_ns, t.first_ns);
      m.last_ns = std::max(m.last_ns, t.last_ns);
    } else if (m.message_count == 0) {
      m.first_ns = t.first_ns;
      m.last_ns = t.last_ns;
    } else if (t.message_count > 0) {
      m.first_ns = m.last_ns = 0;
    }
    m.message_count += t.message_count;
  }
  s->topics.clear();
  for (auto& [name, t] : topics) s->topics.push_back(std::move(t));
}

}  // namespace

Status FindRos2Bag(const std::string& path, std::string* storage, std::vector<std::string>* files,
                   std::vector<std::string>* warnings) {
  files->clear();
  if (!IsFolder(path)) {
    Status s = CheckRegularFile(path);
    if (!s.ok()) return s;
    *storage = StorageOfFile(path);
    if (storage->empty()) {
      return Status::Error(path +
                           ": not a ROS 2 bag (neither a rosbag2 folder, a .db3 sqlite3 "
                           "file nor an .mcap file)");
    }
    files->push_back(path);
    return Status::Ok();
  }
  std::string dir = path;
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  const std::string yaml = dir + "/metadata.yaml";
  if (!IsFile(yaml)) return FolderWithoutMetadata(dir, storage, files, warnings);
  std::ifstream in(yaml);
  std::stringstream text;
  text << in.rdbuf();
  if (!in) return Status::Error(yaml + ": cannot read");
  const Metadata m = ParseMetadata(text.str());
  if (!m.has_info) return Status::Error(yaml + ": no rosbag2_bagfile_information");
  if (!m.has_files || m.files.empty()) return Status::Error(yaml + ": no relative_file_paths");
  if (!m.compression_mode.empty() && m.compression_mode != "NONE") {
    return Status::Error(yaml + ": compression_mode " + Quoted(m.compression_mode) +
                         " is not supported (decompress the bag with `ros2 bag convert` first)");
  }
  for (const std::string& rel : m.files) {
    // Early rosbag2 versions wrote paths that start with the bag folder's name.
    std::string p = dir + "/" + rel;
    const size_t slash = rel.rfind('/');
    if (!IsFile(p) && slash != std::string::npos) p = dir + "/" + rel.substr(slash + 1);
    if (!IsFile(p)) {
      return Status::Error(yaml + ": lists " + Quoted(rel) + ", which is not a file in " + dir);
    }
    files->push_back(p);
  }
  *storage = m.storage.empty() ? StorageOfFile(files->front()) : m.storage;
  if (*storage != "sqlite3" && *storage != "mcap") {
    if (m.storage.empty()) {  // guessed from the first file, which is neither
      return Status::Error(yaml + ": no storage_identifier, and " + files->front() +
                           " is neither an MCAP nor a sqlite3 file");
    }
    return Status::Error(yaml + ": storage_identifier " + Quoted(m.storage) +
                         " is not supported (sqlite3 and mcap are)");
  }
  return Status::Ok();
}

namespace {

// A bag's files' shares of its bytes: a file's progress 0..1 as the whole
// bag's (the files are read in order).
class ByteShares {
 public:
  explicit ByteShares(const std::vector<std::string>& files) : before_(files.size() + 1, 0) {
    for (size_t i = 0; i < files.size(); ++i) {
      uint64_t size = 0;
      CheckRegularFile(files[i], &size);
      before_[i + 1] = before_[i] + size;
    }
  }
  std::function<bool(double)> Of(size_t i, const std::function<bool(double)>& whole) const {
    if (!whole) return nullptr;
    const double total = static_cast<double>(before_.back());
    const double before = static_cast<double>(before_[i]),
                 size = static_cast<double>(before_[i + 1]) - before;
    return [whole, total, before, size](double f) {
      return whole(total > 0 ? (before + f * size) / total : 1.0);
    };
  }

 private:
  std::vector<uint64_t> before_;  // bytes before file i; the total last
};

}  // namespace

Status SummarizeRos2Bag(const std::string& path, RosBagSummary* s, Ros2ReadReport* report,
                        const std::function<bool(double)>& progress) {
  std::string storage;
  std::vector<std::string> files;
  Status st = FindRos2Bag(path, &storage, &files, report != nullptr ? &report->warnings : nullptr);
  if (!st.ok()) return st;
  const ByteShares shares(files);
  for (size_t i = 0; st.ok() && i < files.size(); ++i) {
    RosBagSummary part;
    st = storage == "mcap" ? SummarizeMcap(files[i], &part, report, shares.Of(i, progress))
                           : SummarizeRos2Sqlite(files[i], &part, report, shares.Of(i, progress));
    if (st.ok()) Merge(part, i == 0, s);
  }
  return st;
}

Status ReadRos2Bag(const std::string& path, const RosReadOptions& opt, RosMessageSink* sink,
                   RosBagSummary* summary, RosReadStats* stats, Ros2ReadReport* report) {
  std::string storage;
  std::vector<std::string> files;
  Status st = FindRos2Bag(path, &storage, &files, report != nullptr ? &report->warnings : nullptr);
  if (!st.ok()) return st;
  const ByteShares shares(files);
  for (size_t i = 0; i < files.size(); ++i) {
    RosReadOptions file_opt;
    file_opt.topics = opt.topics;
    file_opt.progress = shares.Of(i, opt.progress);
    RosBagSummary part;
    st = storage == "mcap" ? ReadMcap(files[i], file_opt, sink, &part, stats, report)
                           : ReadRos2Sqlite(files[i], file_opt, sink, &part, stats, report);
    if (!st.ok()) return st;
    if (summary != nullptr) Merge(part, i == 0, summary);
  }
  return Status::Ok();
}

}  // namespace sweepscan::io
