#include "core/session/session.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <limits>
#include <mutex>
#include <sstream>
#include <thread>

#include "core/common/checked_file.h"
#include "core/common/crc32c.h"
#include "core/common/json_reader.h"

namespace sweepscan {
namespace {

using json = nlohmann::json;

void PutU32(uint32_t v, std::vector<uint8_t>* out) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<uint8_t>(v >> (8 * i)));
}
void PutI64(int64_t v, std::vector<uint8_t>* out) {
  const uint64_t u = static_cast<uint64_t>(v);
  for (int i = 0; i < 8; ++i) out->push_back(static_cast<uint8_t>(u >> (8 * i)));
}

std::string Join(const std::string& dir, const char* file) {
  return dir.empty() || dir.back() == '/' ? dir + file : dir + "/" + file;
}

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

// mkdir -p.
Status MakeDirs(const std::string& dir) {
  std::string partial;
  std::stringstream ss(dir);
  std::string part;
  if (!dir.empty() && dir[0] == '/') partial = "/";
  while (std::getline(ss, part, '/')) {
    if (part.empty()) continue;
    partial += part;
    if (::mkdir(partial.c_str(), 0755) != 0 && errno != EEXIST) {
      return Status::Error(Errno(partial + ": cannot create folder"));
    }
    partial += "/";
  }
  return Status::Ok();
}

// fsync of the folder makes new directory entries (frames.bin, the renamed
// meta.json) durable, not only the files' contents.
void SyncDir(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}

bool WriteAll(int fd, const uint8_t* p, size_t n) {
  while (n > 0) {
    const ssize_t k = ::write(fd, p, n);
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) return false;
    p += k;
    n -= static_cast<size_t>(k);
  }
  return true;
}

}  // namespace

std::string UtcNowIso8601() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// ---------------------------------------------------------------------------
// meta.json

std::string SessionSystemIdentifier(const SessionMeta& meta) {
  if (meta.content == kSessionContentMeasurements) return "OTHER";
  if (meta.link.rfind("sim", 0) == 0) return "sweepscan simulation";
  // The app's simulator records over loopback TCP ("tcp:127.0.0.1:PORT"),
  // as a robot would: its scenario in the settings says what it was.
  if (meta.settings.is_object() && meta.settings.contains("scenario") &&
      meta.settings.at("scenario").is_object())
    return "sweepscan simulation";
  return "sweepscan YDLIDAR X4";
}

Pose2d SessionStartPose(const SessionMeta& meta) {
  Pose2d start;
  const json& s = meta.settings;
  if (!s.is_object()) return start;
  const json* found = nullptr;
  if (s.contains("scenario")) {
    const json& sc = s["scenario"];
    if (sc.is_object() && sc.contains("path") && sc["path"].is_object() &&
        sc["path"].contains("start") && sc["path"]["start"].is_object()) {
      found = &sc["path"]["start"];
    }
  } else if (s.contains("import") && s["import"].is_object() && s["import"].contains("start") &&
             s["import"]["start"].is_object()) {
    found = &s["import"]["start"];  // an imported bag: its odometry frame
  }
  if (found == nullptr) return start;
  const json& st = *found;
  const auto number = [&](const char* key, double* out) {
    if (st.contains(key) && st[key].is_number() && std::isfinite(st[key].get<double>())) {
      *out = st[key].get<double>();
    }
  };
  number("x_m", &start.x);
  number("y_m", &start.y);
  number("yaw_rad", &start.yaw);
  return start;
}

json SessionMetaToJson(const SessionMeta& m) {
  json j{
      {"format", "sweepscan-session"},
      {"format_version", m.format_version},
      {"created_utc", m.created_utc},
      {"robot",
       {{"lidar_height_m", m.geometry.lidar_height_m},
        {"lidar_offset_x_m", m.geometry.lidar_offset_x_m},
        {"imu_offset_x_m", m.geometry.imu_offset_x_m},
        {"wheel_distance_m", m.geometry.wheel_distance_m}}},
      {"lidar_angle_convention",
       {{"sign", m.lidar_angle_convention.sign},
        {"offset_rad", m.lidar_angle_convention.offset_rad}}},
      {"calibration",
       {{"alpha_rad", m.calibration.alpha},
        {"beta_rad", m.calibration.beta},
        {"gamma_rad", m.calibration.gamma}}},
      {"link", m.link},
      {"agent", m.agent},
      {"settings", m.settings.is_object() ? m.settings : json::object()},
      {"notes", m.notes},
  };
  // A mount other than sweepscan's own (an imported ROS bag's tf): written
  // only when set, so native sessions' meta.json is unchanged.
  if (!m.content.empty()) j["content"] = m.content;
  if (m.geometry.lidar_offset_y_m != 0.0) {
    j["robot"]["lidar_offset_y_m"] = m.geometry.lidar_offset_y_m;
  }
  if (m.geometry.HasNominalMountRotation()) {
    const Eigen::Quaterniond& q = m.geometry.lidar_mount;
    j["robot"]["lidar_mount"] = {{"x", q.x()}, {"y", q.y()}, {"z", q.z()}, {"w", q.w()}};
  }
  return j;
}

Status SessionMetaFromJson(const json& j, const std::string& source, SessionMeta* meta) {
  SessionMeta m;
  try {
    const JsonObject root(j, "");
    root.AllowOnly({"format", "format_version", "created_utc", "robot", "lidar_angle_convention",
                    "calibration", "link", "agent", "settings", "notes", "content"});
    if (root.String("format") != "sweepscan-session") {
      root.Fail("format", "expected \"sweepscan-session\", got \"" + root.String("format") + "\"");
    }
    const int64_t version = root.Integer("format_version");
    if (version < 1 || version > kSessionFormatVersion) {
      root.Fail("format_version", "unsupported version " + std::to_string(version) +
                                      " (this program reads 1.." +
                                      std::to_string(kSessionFormatVersion) + ")");
    }
    m.format_version = static_cast<uint32_t>(version);
    m.created_utc = root.String("created_utc");
    m.content = root.String("content", "");
    if (!m.content.empty() && m.content != kSessionContentMeasurements) {
      root.Fail("content", "unknown content \"" + m.content + "\" (this program reads \"" +
                               kSessionContentMeasurements + "\" or none: link frames)");
    }
    const JsonObject r = root.Object("robot");
    r.AllowOnly({"lidar_height_m", "lidar_offset_x_m", "imu_offset_x_m", "wheel_distance_m",
                 "lidar_offset_y_m", "lidar_mount"});
    // sweepscan's robot has its lidar above the floor; an imported robot's
    // may sit at or below its base frame's origin.
    m.geometry.lidar_height_m = m.content.empty() ? r.Positive("lidar_height_m")
                                                  : r.Number("lidar_height_m");
    m.geometry.lidar_offset_x_m = r.Number("lidar_offset_x_m");
    m.geometry.imu_offset_x_m = r.Number("imu_offset_x_m");
    m.geometry.wheel_distance_m = r.Positive("wheel_distance_m");
    m.geometry.lidar_offset_y_m = r.Number("lidar_offset_y_m", 0.0);
    if (r.Has("lidar_mount")) {
      const JsonObject q = r.Object("lidar_mount");
      q.AllowOnly({"x", "y", "z", "w"});
      const Eigen::Quaterniond mount(q.Number("w"), q.Number("x"), q.Number("y"), q.Number("z"));
      if (std::abs(mount.norm() - 1.0) > 1e-6) {
        q.Fail("w", "not a unit quaternion (norm " + std::to_string(mount.norm()) + ")");
      }
      m.geometry.lidar_mount = mount;
    }
    const JsonObject a = root.Object("lidar_angle_convention");
    a.AllowOnly({"sign", "offset_rad"});
    const int64_t sign = a.Integer("sign");
    if (sign != 1 && sign != -1) a.Fail("sign", "must be 1 or -1, got " + std::to_string(sign));
    m.lidar_angle_convention.sign = static_cast<int>(sign);
    m.lidar_angle_convention.offset_rad = a.Number("offset_rad");
    const JsonObject c = root.Object("calibration");
    c.AllowOnly({"alpha_rad", "beta_rad", "gamma_rad"});
    // Mounting errors are small angles; anything beyond pi is a unit mistake (degrees).
    auto angle = [&c](const char* key) {
      c.Number(key);  // Required: reports "missing" / wrong type first.
      return c.InRange(key, -M_PI, M_PI, 0.0);
    };
    m.calibration.alpha = angle("alpha_rad");
    m.calibration.beta = angle("beta_rad");
    m.calibration.gamma = angle("gamma_rad");
    m.link = root.String("link", "");
    m.agent = root.String("agent", "");
    if (root.Has("settings")) {
      root.Object("settings");  // Must be an object; its content is not ours to check.
      m.settings = j.at("settings");
    }
    m.notes = root.String("notes", "");
  } catch (const JsonError& e) {
    return Status::Error(source + ": " + e.what());
  }
  *meta = std::move(m);
  return Status::Ok();
}

Status ReadSessionMeta(const std::string& path, SessionMeta* meta) {
  json j;
  const Status s = ReadJsonFile(path, &j);
  if (!s.ok()) return s;
  return SessionMetaFromJson(j, path, meta);
}

Status WriteSessionMeta(const std::string& path, const SessionMeta& meta) {
  return WriteFileAtomically(path, SessionMetaToJson(meta).dump(2) + "\n");
}

Status LoadSession(const std::string& dir, const FramesLoadOptions& options, Session* session) {
  struct stat st;
  if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    return Status::Error(dir + ": not a session folder (does not exist or is not a folder)");
  }
  Session s;
  s.dir = dir;
  Status status = ReadSessionMeta(Join(dir, kSessionMetaFile), &s.meta);
  if (!status.ok()) return status;
  status = LoadFramesFile(Join(dir, kSessionFramesFile), options, &s.records, &s.frames);
  if (!status.ok()) return status;
  *session = std::move(s);
  return Status::Ok();
}

// ---------------------------------------------------------------------------
// Writing

bool SessionWriterOptions::IsValid(std::string* error) const {
  if (flush_interval <= std::chrono::steady_clock::duration::zero()) {
    *error = "flush_interval must be > 0";
    return false;
  }
  if (max_buffered_bytes == 0) {
    *error = "max_buffered_bytes must be > 0";
    return false;
  }
  return true;
}

// Writes a file's bytes and fdatasyncs them on a thread of its own
// (SessionWriterOptions::sync_on_thread): the caller hands them over and
// goes on, and the disk's time is this thread's. Bytes handed while it
// writes wait, and go with the next write; a sync asked for meanwhile is
// one sync after it. After a failure nothing more is written.
class BackgroundFileWriter {
 public:
  BackgroundFileWriter(int fd, std::string name)
      : fd_(fd), name_(std::move(name)), thread_([this] { Run(); }) {}
  ~BackgroundFileWriter() {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    work_.notify_all();
    thread_.join();  // after what was handed is done
  }
  BackgroundFileWriter(const BackgroundFileWriter&) = delete;
  BackgroundFileWriter& operator=(const BackgroundFileWriter&) = delete;

  // Takes *bytes (left empty); `sync`: fdatasync once they are written.
  void Hand(std::vector<uint8_t>* bytes, bool sync) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (pending_.empty()) {
        pending_.swap(*bytes);
      } else {
        pending_.insert(pending_.end(), bytes->begin(), bytes->end());
      }
      sync_ = sync_ || sync;
      ++handed_;
    }
    bytes->clear();
    work_.notify_all();
  }
  // Waits until everything handed is done; the first failure ("" if none).
  std::string Wait() {
    std::unique_lock<std::mutex> lock(mutex_);
    done_changed_.wait(lock, [this] { return done_ == handed_; });
    return failed_;
  }
  std::string failed() const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return failed_;
  }

 private:
  void Run() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      work_.wait(lock, [this] { return stop_ || done_ != handed_; });
      if (done_ == handed_) return;  // stopped, nothing left
      std::vector<uint8_t> bytes;
      bytes.swap(pending_);
      const bool sync = sync_;
      sync_ = false;
      const uint64_t upto = handed_;
      const bool failed = !failed_.empty();
      lock.unlock();
      std::string error;
      if (!failed && !WriteAll(fd_, bytes.data(), bytes.size())) {
        error = Errno(name_ + ": write failed");
        ::fdatasync(fd_);  // what was written goes to the disk (WriteBuffer's why)
      } else if (!failed && sync && ::fdatasync(fd_) != 0) {
        error = Errno(name_ + ": fsync failed");
      }
      lock.lock();
      if (!error.empty() && failed_.empty()) failed_ = error;
      done_ = upto;
      done_changed_.notify_all();
    }
  }

  const int fd_;
  const std::string name_;
  mutable std::mutex mutex_;
  std::condition_variable work_, done_changed_;
  std::vector<uint8_t> pending_;
  bool sync_ = false;
  bool stop_ = false;
  uint64_t handed_ = 0, done_ = 0;
  std::string failed_;
  std::thread thread_;  // last: started once the rest is made
};

SessionWriter::SessionWriter(std::string dir, int fd, uint64_t file_bytes,
                             const SessionWriterOptions& options)
    : dir_(std::move(dir)),
      fd_(fd),
      options_(options),
      file_bytes_(file_bytes),
      last_sync_(std::chrono::steady_clock::now()) {
  if (options_.sync_on_thread)
    background_ = std::make_unique<BackgroundFileWriter>(fd_, Join(dir_, kSessionFramesFile));
}

Status RenameSessionIntoPlace(const std::string& from, const std::string& to) {
  // rename(2) onto an empty folder replaces it, onto a non-empty one fails
  // (ENOTEMPTY or EEXIST): another session there is never touched.
  if (::rename(from.c_str(), to.c_str()) != 0) {
    if (errno == ENOTEMPTY || errno == EEXIST)
      return Status::Error(to + ": folder exists and is not empty; refusing to overwrite a session");
    return Status::Error(Errno(to + ": cannot give the finished session its name"));
  }
  std::string name = to;
  while (name.size() > 1 && name.back() == '/') name.pop_back();
  const size_t slash = name.rfind('/');
  SyncDir(slash == std::string::npos ? "." : slash == 0 ? "/" : name.substr(0, slash));
  return Status::Ok();
}

std::string SessionWritingDir(const std::string& dir, const std::string& what) {
  std::string name = dir;
  while (name.size() > 1 && name.back() == '/') name.pop_back();
  const size_t slash = name.rfind('/');
  const std::string parent = slash == std::string::npos ? "" : name.substr(0, slash + 1);
  return parent + "." + name.substr(slash + 1) + "." + what + "-" + std::to_string(::getpid());
}

Status CheckNewSessionFolder(const std::string& dir) {
  struct stat st;
  if (::stat(dir.c_str(), &st) != 0) return Status::Ok();
  if (!S_ISDIR(st.st_mode)) return Status::Error(dir + ": exists and is not a folder");
  DIR* d = ::opendir(dir.c_str());
  if (d == nullptr) return Status::Error(Errno(dir + ": cannot be read"));
  bool empty = true;
  while (const dirent* e = ::readdir(d)) {
    if (std::strcmp(e->d_name, ".") != 0 && std::strcmp(e->d_name, "..") != 0) empty = false;
  }
  ::closedir(d);
  if (empty) return Status::Ok();
  return Status::Error(dir + ": folder exists and is not empty; refusing to overwrite a session");
}

Status SaidOfSession(const Status& s, const std::string& writing, const std::string& dir) {
  if (s.ok()) return s;
  std::string message = s.message();
  std::string name = dir;
  while (name.size() > 1 && name.back() == '/') name.pop_back();
  for (size_t at = message.find(writing); at != std::string::npos;
       at = message.find(writing, at + name.size()))
    message.replace(at, writing.size(), name);
  return Status::Error(message);
}

SessionWriter::~SessionWriter() { Close(); }

Status SessionWriter::Create(const std::string& dir, const SessionMeta& meta,
                             const SessionWriterOptions& options,
                             std::unique_ptr<SessionWriter>* out) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(dir + ": " + error);
  if (!meta.geometry.IsValid(&error)) return Status::Error(dir + ": " + error);
  struct stat st;
  bool made_dir = false;
  if (::stat(dir.c_str(), &st) == 0) {
    if (!S_ISDIR(st.st_mode)) return Status::Error(dir + ": exists and is not a folder");
    bool empty = true;
    if (DIR* d = ::opendir(dir.c_str())) {
      while (const dirent* e = ::readdir(d)) {
        if (std::strcmp(e->d_name, ".") != 0 && std::strcmp(e->d_name, "..") != 0) empty = false;
      }
      ::closedir(d);
    }
    if (!empty && !options.overwrite) {
      return Status::Error(dir +
                           ": folder exists and is not empty; refusing to overwrite a "
                           "session (ask for overwrite explicitly)");
    }
    if (!empty) {
      for (const char* f :
           {kSessionFramesFile, kSessionMetaFile, "picks.json", "calibration.json"}) {
        const std::string p = Join(dir, f);
        if (::unlink(p.c_str()) != 0 && errno != ENOENT) {
          return Status::Error(Errno(p + ": cannot remove old session file"));
        }
      }
    }
  } else {
    const Status s = MakeDirs(dir);
    if (!s.ok()) return s;
    made_dir = true;
  }
  const std::string frames = Join(dir, kSessionFramesFile);
  // A session that could not be begun (a full disk) leaves nothing behind:
  // its empty folder made the next `record` refuse it as an existing one.
  // Only what this call made goes (a frames.bin that O_EXCL found is
  // another writer's, and so is the meta.json beside it).
  bool made_meta = false, made_frames = false;
  auto undo = [&](const Status& failed) {
    if (made_frames) ::unlink(frames.c_str());
    if (made_meta) ::unlink(Join(dir, kSessionMetaFile).c_str());
    if (made_dir) ::rmdir(dir.c_str());  // Only if empty.
    return failed;
  };
  SessionMeta m = meta;
  m.format_version = kSessionFormatVersion;
  if (m.created_utc.empty()) m.created_utc = UtcNowIso8601();
  Status s = WriteSessionMeta(Join(dir, kSessionMetaFile), m);
  if (!s.ok()) return undo(s);  // Written atomically: no meta.json of ours.
  made_meta = true;
  const int fd = ::open(frames.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) {
    const int error = errno;
    const Status failed = Status::Error(Errno(frames + ": cannot create"));
    // EEXIST: another writer began a session here after the check above;
    // its files stay.
    if (error == EEXIST) return failed;
    return undo(failed);
  }
  made_frames = true;
  const std::vector<uint8_t> header = SessionFramesHeader();
  if (!WriteAll(fd, header.data(), header.size()) || ::fsync(fd) != 0) {
    const Status failed = Status::Error(Errno(frames + ": cannot write the file header"));
    ::close(fd);
    return undo(failed);
  }
  SyncDir(dir);
  out->reset(new SessionWriter(dir, fd, header.size(), options));
  (*out)->created_utc_ = m.created_utc;
  return Status::Ok();
}

Status SessionWriter::Open(const std::string& dir, const SessionWriterOptions& options,
                           std::unique_ptr<SessionWriter>* out, FramesLoadReport* report) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(dir + ": " + error);
  Session session;
  Status s = LoadSession(dir, FramesLoadOptions(), &session);
  if (!s.ok()) return s;
  const std::string frames = Join(dir, kSessionFramesFile);
  const int fd = ::open(frames.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) return Status::Error(Errno(frames + ": cannot open for appending"));
  // Cut a torn tail so new records follow the last good one.
  const off_t end = static_cast<off_t>(session.frames.valid_bytes);
  if (::ftruncate(fd, end) != 0 || ::lseek(fd, end, SEEK_SET) != end || ::fsync(fd) != 0) {
    ::close(fd);
    return Status::Error(Errno(frames + ": cannot cut the torn tail"));
  }
  if (report != nullptr) *report = session.frames;
  out->reset(new SessionWriter(dir, fd, session.frames.valid_bytes, options));
  (*out)->created_utc_ = session.meta.created_utc;
  return Status::Ok();
}

std::vector<uint8_t> SessionFramesHeader() {
  std::vector<uint8_t> h(kSessionFramesMagic, kSessionFramesMagic + 8);
  PutU32(kSessionFormatVersion, &h);
  PutU32(0, &h);  // reserved
  return h;
}

void AppendSessionRecord(const uint8_t* bytes, size_t n, int64_t receive_time_ns,
                         std::vector<uint8_t>* out) {
  const size_t start = out->size();
  PutU32(static_cast<uint32_t>(n), out);
  PutI64(receive_time_ns, out);
  if (n > 0) out->insert(out->end(), bytes, bytes + n);
  PutU32(Crc32c(out->data() + start, 12 + n), out);
}

Status SessionWriter::Append(const uint8_t* bytes, size_t n, int64_t receive_time_ns) {
  if (!failed_.empty()) return Status::Error(failed_);
  if (fd_ < 0) return Status::Error(dir_ + ": session is closed");
  if (n > kSessionMaxRecordBytes || (n > 0 && bytes == nullptr)) {
    return Status::Error(dir_ + ": record of " + std::to_string(n) + " bytes refused (limit " +
                         std::to_string(kSessionMaxRecordBytes) + ")");
  }
  AppendSessionRecord(bytes, n, receive_time_ns, &buffer_);
  ++records_appended_;
  dirty_ = true;
  if (buffer_.size() >= options_.max_buffered_bytes) return WriteBuffer();
  return Status::Ok();
}

Status SessionWriter::WriteBuffer() {
  if (buffer_.empty()) return Status::Ok();
  if (background_ != nullptr) {
    if (std::string f = background_->failed(); !f.empty()) {
      failed_ = std::move(f);
      return Status::Error(failed_);
    }
    file_bytes_ += buffer_.size();
    background_->Hand(&buffer_, false);
    return Status::Ok();
  }
  if (!WriteAll(fd_, buffer_.data(), buffer_.size())) {
    failed_ = Errno(Join(dir_, kSessionFramesFile) + ": write failed");
    // The recording ends here (disk full, a pulled disk): what was written
    // since the last sync goes to the disk now, as a flush would have taken
    // it, instead of waiting in the page cache for a power cut (Flush and
    // Close return the error from here on, and synced nothing).
    ::fdatasync(fd_);
    return Status::Error(failed_);
  }
  file_bytes_ += buffer_.size();
  buffer_.clear();
  return Status::Ok();
}

Status SessionWriter::Flush() {
  if (!failed_.empty()) return Status::Error(failed_);
  if (fd_ < 0) return Status::Ok();
  if (background_ != nullptr) {
    file_bytes_ += buffer_.size();
    background_->Hand(&buffer_, true);
    failed_ = background_->Wait();
    if (!failed_.empty()) return Status::Error(failed_);
    dirty_ = false;
    last_sync_ = std::chrono::steady_clock::now();
    return Status::Ok();
  }
  Status s = WriteBuffer();
  if (!s.ok()) return s;
  if (::fdatasync(fd_) != 0) {
    failed_ = Errno(Join(dir_, kSessionFramesFile) + ": fsync failed");
    return Status::Error(failed_);
  }
  dirty_ = false;
  last_sync_ = std::chrono::steady_clock::now();
  return Status::Ok();
}

Status SessionWriter::FlushIfDue(std::chrono::steady_clock::time_point now) {
  // A failure is said at every call, due or not (it was Ok between flushes).
  if (failed_.empty() && background_ != nullptr) failed_ = background_->failed();
  if (!failed_.empty()) return Status::Error(failed_);
  if (!dirty_) {
    last_sync_ = now;  // Nothing to lose: restart the interval.
    return Status::Ok();
  }
  if (now - last_sync_ < options_.flush_interval) return Status::Ok();
  if (background_ == nullptr) return Flush();
  file_bytes_ += buffer_.size();
  background_->Hand(&buffer_, true);
  dirty_ = false;
  last_sync_ = now;
  return Status::Ok();
}

Status SessionWriter::Close() {
  if (fd_ < 0) return failed_.empty() ? Status::Ok() : Status::Error(failed_);
  Status s = Flush();
  background_.reset();  // its thread ends before the descriptor does
  if (::close(fd_) != 0 && s.ok()) s = Status::Error(Errno(dir_ + ": close failed"));
  fd_ = -1;
  return s;
}

Status SessionWriter::UpdateMeta(const SessionMeta& meta) {
  SessionMeta m = meta;
  m.format_version = kSessionFormatVersion;
  // When the recording began stays what Create() wrote: a caller that
  // rewrites the meta it started from (a reconnection naming the agent) had
  // it empty, and the LAS export's GPS time needs it.
  if (m.created_utc.empty()) m.created_utc = created_utc_;
  const Status s = WriteSessionMeta(Join(dir_, kSessionMetaFile), m);
  if (s.ok()) SyncDir(dir_);
  return s;
}

}  // namespace sweepscan
