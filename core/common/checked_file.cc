#include "core/common/checked_file.h"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace sweepscan {
namespace {

constexpr size_t kBufferSize = 1 << 16;

std::string FolderOf(const std::string& path) {
  const size_t slash = path.rfind('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

std::string BaseOf(const std::string& path) {
  const size_t slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string ErrnoText(int error_number) { return std::strerror(error_number); }

// The file a write of `path` replaces: `path`, or the file its symbolic
// links lead to. Written through, as an editor saves: renaming over the
// link replaced it with a file (a project kept under version control and
// linked into a work folder lost its link, and the file it pointed to kept
// the old text). A link that leads nowhere is written where it points; a
// loop of links (past 40 hops, the kernel's limit) gives "".
std::string FollowLinks(const std::string& path) {
  std::string target = path;
  for (int hop = 0; hop < 40; ++hop) {
    struct stat st;
    if (::lstat(target.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return target;
    std::vector<char> link(static_cast<size_t>(st.st_size > 0 ? st.st_size : 4096) + 1);
    const ssize_t n = ::readlink(target.c_str(), link.data(), link.size());
    if (n <= 0 || static_cast<size_t>(n) >= link.size()) return path;
    const std::string to(link.data(), static_cast<size_t>(n));
    const size_t slash = target.rfind('/');
    target = to[0] == '/' || slash == std::string::npos ? to : target.substr(0, slash + 1) + to;
  }
  return std::string();
}

// "BASE.tmp-", BASE cut where the PID (up to 10 digits) would take the
// name past a file name's 255 bytes (NAME_MAX on Linux' file systems): a
// 252-byte name could be written by `cp` but not by us ("File name too
// long"). Cut between UTF-8 characters (at most 3 bytes back), then "~"
// and 8 hex digits of the whole name's FNV-1a hash, so that two names cut
// alike do not share one temporary.
std::string TemporaryPrefix(const std::string& base) {
  constexpr size_t kNameMax = 255, kSuffix = 5 + 10, kHash = 9;  // ".tmp-" + the PID; "~" + 8
  if (base.size() + kSuffix <= kNameMax) return base + ".tmp-";
  size_t n = kNameMax - kSuffix - kHash;
  for (int back = 0; back < 3 && n > 0 && (static_cast<unsigned char>(base[n]) & 0xC0) == 0x80;
       ++back)
    --n;
  uint32_t hash = 2166136261u;
  for (const unsigned char c : base) hash = (hash ^ c) * 16777619u;
  char hex[10];
  std::snprintf(hex, sizeof(hex), "~%08x", hash);
  return base.substr(0, n) + hex + ".tmp-";
}

// Parses the PID of "BASE.tmp-PID"; -1 if `name` is not a temporary of BASE.
long TemporaryPid(const std::string& name, const std::string& base) {
  const std::string prefix = TemporaryPrefix(base);
  if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) return -1;
  const std::string digits = name.substr(prefix.size());
  if (digits.size() > 9 || digits.find_first_not_of("0123456789") != std::string::npos) return -1;
  return std::strtol(digits.c_str(), nullptr, 10);
}

}  // namespace

std::string TemporaryPathFor(const std::string& path) {
  const size_t slash = path.rfind('/');
  const std::string folder = slash == std::string::npos ? "" : path.substr(0, slash + 1);
  return folder + TemporaryPrefix(BaseOf(path)) + std::to_string(::getpid());
}

bool IsTemporaryFileName(const std::string& name) {
  const size_t at = name.rfind(".tmp-");
  if (at == std::string::npos || at + 5 >= name.size()) return false;
  return name.find_first_not_of("0123456789", at + 5) == std::string::npos;
}

int RemoveStaleTemporaries(const std::string& path) {
  const std::string folder = FolderOf(path);
  const std::string base = BaseOf(path);
  DIR* d = ::opendir(folder.c_str());
  if (d == nullptr) return 0;
  int removed = 0;
  std::vector<std::string> stale;
  while (const dirent* e = ::readdir(d)) {
    const long pid = TemporaryPid(e->d_name, base);
    if (pid <= 0 || pid == static_cast<long>(::getpid())) continue;
    // kill(pid, 0) fails with ESRCH only when no such process exists.
    if (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) stale.push_back(e->d_name);
  }
  ::closedir(d);
  for (const std::string& name : stale) {
    if (::unlink((folder + "/" + name).c_str()) == 0) ++removed;
  }
  return removed;
}

Status CheckRegularFile(const std::string& path, uint64_t* size) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) {
    return Status::Error(path + ": cannot open for reading: " + ErrnoText(errno));
  }
  if (S_ISDIR(st.st_mode)) return Status::Error(path + ": is a folder, expected a file");
  if (!S_ISREG(st.st_mode)) return Status::Error(path + ": not a regular file");
  if (size != nullptr) *size = static_cast<uint64_t>(st.st_size);
  return Status::Ok();
}

CheckedFileWriter::~CheckedFileWriter() { Abort(); }

Status CheckedFileWriter::Fail(const std::string& what, int error_number) {
  failed_ = path_ + ": " + what + (error_number != 0 ? ": " + ErrnoText(error_number) : "");
  return Status::Error(failed_);
}

Status CheckedFileWriter::Open(const std::string& path) {
  Abort();
  path_ = path;
  failed_.clear();
  bytes_ = 0;
  buffer_.clear();
  if (path.empty()) return Fail("empty file name", 0);
  struct stat st;
  if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
    return Fail("is a folder, cannot write a file there", 0);
  }
  target_ = FollowLinks(path);
  if (target_.empty()) return Fail("cannot follow its symbolic links", ELOOP);
  RemoveStaleTemporaries(target_);
  tmp_ = TemporaryPathFor(target_);
  fd_ = ::open(tmp_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    const int e = errno;
    const std::string tmp = BaseOf(tmp_);
    tmp_.clear();
    return Fail("cannot create " + tmp + " in " + FolderOf(target_), e);
  }
  buffer_.reserve(kBufferSize);
  return Status::Ok();
}

Status CheckedFileWriter::FlushBuffer() {
  const char* p = buffer_.data();
  size_t n = buffer_.size();
  while (n > 0) {
    const ssize_t k = ::write(fd_, p, n);
    if (k < 0 && errno == EINTR) continue;
    if (k < 0) return Fail("write failed", errno);
    if (k == 0) return Fail("write failed", ENOSPC);
    p += k;
    n -= static_cast<size_t>(k);
  }
  buffer_.clear();
  return Status::Ok();
}

Status CheckedFileWriter::Write(const void* data, size_t n) {
  if (!failed_.empty()) return Status::Error(failed_);
  if (fd_ < 0) return Fail("not open", 0);
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const size_t k = std::min(n, kBufferSize - buffer_.size());
    buffer_.insert(buffer_.end(), p, p + k);
    p += k;
    n -= k;
    bytes_ += k;
    if (buffer_.size() == kBufferSize) {
      const Status s = FlushBuffer();
      if (!s.ok()) return s;
    }
  }
  return Status::Ok();
}

Status CheckedFileWriter::Overwrite(uint64_t offset, const void* data, size_t n) {
  if (!failed_.empty()) return Status::Error(failed_);
  if (fd_ < 0) return Fail("not open", 0);
  if (offset + n > bytes_) return Fail("overwrite past the end", EINVAL);
  const Status s = FlushBuffer();
  if (!s.ok()) return s;
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t k = ::pwrite(fd_, p, n, static_cast<off_t>(offset));
    if (k < 0 && errno == EINTR) continue;
    if (k < 0) return Fail("write failed", errno);
    if (k == 0) return Fail("write failed", ENOSPC);
    p += k;
    offset += static_cast<uint64_t>(k);
    n -= static_cast<size_t>(k);
  }
  return Status::Ok();
}

Status CheckedFileWriter::Commit() {
  if (!failed_.empty()) {
    const Status s = Status::Error(failed_);
    Abort();
    return s;
  }
  if (fd_ < 0) return Fail("not open", 0);
  Status s = FlushBuffer();
  if (s.ok() && ::fsync(fd_) != 0) s = Fail("flush to disk (fsync) failed", errno);
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0 && s.ok()) s = Fail("close failed", errno);
  if (s.ok() && std::rename(tmp_.c_str(), target_.c_str()) != 0) {
    s = Fail("cannot rename the finished temporary file over it", errno);
  }
  if (!s.ok()) {
    ::unlink(tmp_.c_str());
    tmp_.clear();
    return s;
  }
  tmp_.clear();
  // Make the new directory entry durable too.
  const int dir = ::open(FolderOf(target_).c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
  return Status::Ok();
}

void CheckedFileWriter::Abort() {
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
  if (!tmp_.empty()) {
    ::unlink(tmp_.c_str());
    tmp_.clear();
  }
  buffer_.clear();
}

Status CheckCanWrite(const std::string& path) {
  CheckedFileWriter probe;
  const Status s = probe.Open(path);
  probe.Abort();
  return s;
}

Status WriteFileChecked(const std::string& path, const std::string& contents) {
  CheckedFileWriter w;
  Status s = w.Open(path);
  if (!s.ok()) return s;
  s = w.Write(contents);
  if (!s.ok()) return s;
  return w.Commit();
}

Status CopyFileChecked(const std::string& from, const std::string& to,
                       const std::function<bool(uint64_t bytes)>& progress) {
  Status s = CheckRegularFile(from);
  if (!s.ok()) return s;
  const int fd = ::open(from.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Status::Error(from + ": cannot open for reading: " + std::strerror(errno));
  CheckedFileWriter w;
  s = w.Open(to);
  std::vector<char> buffer(size_t{1} << 20);
  uint64_t copied = 0;
  while (s.ok()) {
    const ssize_t n = ::read(fd, buffer.data(), buffer.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) s = Status::Error(from + ": read error: " + std::strerror(errno));
    if (n <= 0) break;
    s = w.Write(buffer.data(), static_cast<size_t>(n));
    copied += static_cast<uint64_t>(n);
    if (s.ok() && progress && !progress(copied)) s = Status::Error(to + ": cancelled");
  }
  ::close(fd);
  return s.ok() ? w.Commit() : s;
}

}  // namespace sweepscan
