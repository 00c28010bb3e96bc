// The one way the project writes a file (clouds, CSV exports, calibration
// files, reports, session metadata): a temporary file in the same folder
// (PATH.tmp-PID), every write() and the close() checked, fsync, then rename
// over PATH, then fsync of the folder. On any failure the temporary is
// removed and PATH is left as it was (absent, or the previous complete
// version); the error names the file and the operating system's reason, e.g.
//   out/lab.ply: write failed: No space left on device
// A file that exists under its final name is therefore always complete.
// A PATH that is a symbolic link is written through: the file it leads to
// is replaced (its folder holds the temporary) and the link stays.
//
// Stale temporaries (PATH.tmp-PID of a killed run whose process no longer
// exists) are deleted when the same PATH is written again; readers never
// look at *.tmp-* files.
//
// Threading: a CheckedFileWriter is used from one thread; the free functions
// are thread-safe (distinct paths).
#ifndef SWEEPSCAN_CORE_COMMON_CHECKED_FILE_H_
#define SWEEPSCAN_CORE_COMMON_CHECKED_FILE_H_

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/common/status.h"

namespace sweepscan {

class CheckedFileWriter {
 public:
  CheckedFileWriter() = default;
  ~CheckedFileWriter();  // Abort() unless committed.
  CheckedFileWriter(const CheckedFileWriter&) = delete;
  CheckedFileWriter& operator=(const CheckedFileWriter&) = delete;

  // Creates PATH.tmp-PID (mode 0644 before umask). Refuses a PATH that is a
  // folder. Deletes stale temporaries of PATH left by dead processes.
  Status Open(const std::string& path);
  // Buffered; a failure is sticky (later calls return it, Commit() fails).
  Status Write(const void* data, size_t n);
  Status Write(const std::string& s) { return Write(s.data(), s.size()); }
  // Replaces n bytes already written at `offset` (a header whose counts are
  // known only at the end); writing continues at the end.
  Status Overwrite(uint64_t offset, const void* data, size_t n);
  // Flushes, fsyncs, closes, renames over PATH, fsyncs the folder.
  Status Commit();
  // Closes and removes the temporary (nothing happens to PATH).
  void Abort();

  const std::string& path() const { return path_; }
  const std::string& temporary_path() const { return tmp_; }
  uint64_t bytes_written() const { return bytes_; }

 private:
  Status FlushBuffer();
  Status Fail(const std::string& what, int error_number);

  std::string path_;
  std::string target_;  // path_, or the file its symbolic links lead to
  std::string tmp_;
  int fd_ = -1;
  std::vector<char> buffer_;
  uint64_t bytes_ = 0;
  std::string failed_;  // Sticky error message.
};

// Whether `path` can be written, asked before the work that makes its
// contents (a project's clouds take minutes): its temporary is created and
// removed, and the error is the one writing would give, e.g.
//   out/x.las: cannot create x.las.tmp-1863 in out: No such file or directory
Status CheckCanWrite(const std::string& path);

// Writes `contents` to `path` through a CheckedFileWriter.
Status WriteFileChecked(const std::string& path, const std::string& contents);

// Copies the file `from` to `to` through a CheckedFileWriter, a megabyte at
// a time (any size, in bounded memory). Errors name the file and the reason.
// `progress` (optional) hears the bytes copied after each megabyte and
// cancels by returning false ("cancelled"; `to` is left as it was).
Status CopyFileChecked(const std::string& from, const std::string& to,
                       const std::function<bool(uint64_t bytes)>& progress = nullptr);

// "PATH: is a folder" / "PATH: cannot open for reading: No such file or
// directory" when PATH is not a readable regular file; Ok otherwise, with its
// size in *size (if not null).
Status CheckRegularFile(const std::string& path, uint64_t* size = nullptr);

// Deletes PATH.tmp-PID files whose process PID no longer runs (a killed
// writer's leftovers). Returns how many were deleted.
int RemoveStaleTemporaries(const std::string& path);

// The temporary this process writes PATH through: PATH.tmp-PID, PATH's
// name cut short if the whole would pass 255 bytes.
std::string TemporaryPathFor(const std::string& path);

// True for names written by CheckedFileWriter as temporaries ("x.ply.tmp-123").
bool IsTemporaryFileName(const std::string& name);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_COMMON_CHECKED_FILE_H_
