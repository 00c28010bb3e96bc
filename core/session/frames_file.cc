// Reading frames.bin from disk (docs/session-format.md, "Reading rules" and
// "A file that fails under its reader"): mapped, visited front to back,
// the pages behind the reader dropped, the mapping guarded.
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include "core/common/checked_file.h"
#include "core/session/frames_bytes.h"
#include "core/session/guarded_mapping.h"
#include "core/session/session.h"

namespace sweepscan {

namespace {

// The CRC of the file's first record, if it is whole (read with pread, before
// the mapping): a fingerprint of the recording.
bool FirstRecordCrc(int fd, uint32_t* crc) {
  uint8_t length[4];
  if (::pread(fd, length, 4, kSessionFramesHeaderSize) != 4) return false;
  const uint32_t n = session_internal::GetU32(length);
  if (n > kSessionMaxRecordBytes) return false;
  uint8_t field[4];
  const off_t at = static_cast<off_t>(kSessionFramesHeaderSize + 12 + n);
  if (::pread(fd, field, 4, at) != 4) return false;
  *crc = session_internal::GetU32(field);
  return true;
}

}  // namespace

Status VisitFramesFile(const std::string& path, const FramesLoadOptions& options,
                       const FrameVisitor& visit, FramesLoadReport* report) {
  const Status regular = CheckRegularFile(path);  // A folder named frames.bin is a clear error.
  if (!regular.ok()) return regular;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Status::Error(path + ": cannot open for reading: " + std::strerror(errno));
  struct stat opened;
  if (::fstat(fd, &opened) != 0) {
    const Status failed = Status::Error(path + ": cannot stat: " + std::strerror(errno));
    ::close(fd);
    return failed;
  }
  const auto device = static_cast<uint64_t>(opened.st_dev);
  const auto inode = static_cast<uint64_t>(opened.st_ino);
  uint32_t first_crc = 0;
  const bool has_first = FirstRecordCrc(fd, &first_crc);
  // The recording is known by its first record (a recording written over
  // the session begins with another: its receive time differs), the file
  // by its inode only when the first pass saw no whole record. Not the
  // inode alone: some network file systems (sshfs without use_ino, CIFS
  // with noserverino) number a file anew at each open, and a file made
  // after another was deleted can get its number back.
  const bool replaced =
      options.expect_first_record
          ? !has_first || first_crc != options.expect_first_record_crc
          : (options.expect_device != 0 || options.expect_inode != 0) &&
                (device != options.expect_device || inode != options.expect_inode);
  if (replaced) {
    ::close(fd);
    return Status::Error(path +
                         ": replaced since its first pass was read (a recording written over "
                         "the session?); open the session again");
  }
  // Filled however the visit ends.
  auto identify = [&] {
    if (report != nullptr) {
      report->file_device = device;
      report->file_inode = inode;
      report->has_first_record = has_first;
      report->first_record_crc = first_crc;
    }
  };
  // Mapped, not read: the file is visited once, front to back, and the
  // pages behind the reader are dropped every 64 MiB, so a 10-hour
  // session (1.4 GB) costs a few tens of MB resident, not its size. The
  // mapping is guarded: a file cut short or a disk failing under the reader
  // (a USB disk pulled mid-replay) is an error with its place, not SIGBUS.
  GuardedMapping map;
  const Status mapped = map.Map(fd, path);
  if (!mapped.ok()) {
    ::close(fd);
    return mapped;
  }
  const size_t n = map.size();
  if (n == 0) {
    ::close(fd);
    const Status empty = VisitFramesInMemory(nullptr, 0, path, options, visit, report);
    identify();
    return empty;
  }
  uint8_t* const base = const_cast<uint8_t*>(map.data());
  ::madvise(base, n, MADV_SEQUENTIAL);
  constexpr size_t kDropEvery = size_t{64} << 20;
  const size_t page = static_cast<size_t>(::sysconf(_SC_PAGESIZE));
  size_t dropped = 0;
  // A record the visitor read while its bytes failed (the file cut between
  // the CRC check and the visit): named in the error.
  std::string tainted;
  const Status s = VisitFramesInMemory(
      map.data(), n, path, options,
      [&](const SessionRecordView& r) {
        // What follows a failed page is zeros, not the file.
        if (map.failed()) return false;
        if (r.offset >= dropped + kDropEvery) {
          const size_t upto = r.offset / page * page;
          ::madvise(base, upto, MADV_DONTNEED);
          dropped = upto;
        }
        const bool more = visit(r);
        if (map.failed() && map.failed_offset() < r.offset + kSessionRecordOverhead + r.size) {
          tainted = "; record " + std::to_string(r.ordinal) + " at byte " +
                    std::to_string(r.offset) +
                    " was being read as it failed and may have been passed on "
                    "damaged";
        }
        return more;
      },
      report);
  identify();
  // Cut short under the reader: the pages past the new end faulted (and
  // read as zeros), or the record the cut runs through failed its CRC (the
  // rest of its page reads as zeros). Either way, say what happened.
  struct stat now;
  const bool shrank = ::fstat(fd, &now) == 0 && static_cast<size_t>(now.st_size) < n;
  ::close(fd);
  if ((map.failed() || !s.ok()) && shrank) {
    return Status::Error(path + ": the file shrank from " + std::to_string(n) + " to " +
                         std::to_string(now.st_size) + " bytes while it was read" + tainted);
  }
  if (map.failed()) return Status::Error(map.FailureMessage() + tainted);
  return s;
}

}  // namespace sweepscan
