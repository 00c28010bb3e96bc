// A file mapped for reading that survives the file failing under it.
//
// Reading a mapped file, a page the kernel cannot supply raises SIGBUS: the
// file was truncated while mapped (another program rewrote or cut it), or
// its disk failed or was pulled (a USB disk during a replay). The default
// action kills the process, taking the operator's unsaved work with it. A
// GuardedMapping registers its range with a process-wide SIGBUS handler
// that, for an address inside a registered range, maps a page of zeros over
// the failed page and notes the failure; the read then goes on, seeing
// zeros (which frames.bin's reader takes as damage: a zero length field
// has a CRC that does not match), and the owner asks failed() afterwards
// to refuse what it read from there with the place and the reason. A
// SIGBUS outside every registered range goes on to the handler installed
// before (or the default action), so other faults still crash as they
// should.
//
// The handler uses only lock-free atomics and mmap(2), a system call that
// is safe in a signal handler on Linux; it keeps errno. At most
// kMaxMappings mappings are guarded at once; more are mapped unguarded
// (guarded() is then false). A SIGBUS handler installed after the first
// mapping (nothing in this program does) would take the faults instead.
#ifndef SWEEPSCAN_CORE_SESSION_GUARDED_MAPPING_H_
#define SWEEPSCAN_CORE_SESSION_GUARDED_MAPPING_H_

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/common/status.h"

namespace sweepscan {

class GuardedMapping {
 public:
  static constexpr int kMaxMappings = 64;

  GuardedMapping() = default;
  ~GuardedMapping();
  GuardedMapping(const GuardedMapping&) = delete;
  GuardedMapping& operator=(const GuardedMapping&) = delete;

  // Maps the whole of `fd` (read-only, private); `path` names it in errors.
  // An empty file maps nothing (data() null, size() 0).
  Status Map(int fd, const std::string& path);

  const uint8_t* data() const { return data_; }
  size_t size() const { return size_; }
  bool guarded() const { return slot_ >= 0; }

  // A page could not be read (and reads as zeros): the first such offset.
  bool failed() const;
  size_t failed_offset() const;
  // "PATH: bytes from N on could not be read (its disk failed, or the file
  // shrank, while it was read)".
  std::string FailureMessage() const;

 private:
  void Unmap();

  std::string path_;
  uint8_t* data_ = nullptr;
  size_t size_ = 0;
  int slot_ = -1;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_SESSION_GUARDED_MAPPING_H_
