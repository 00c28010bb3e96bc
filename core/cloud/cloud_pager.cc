#include "core/cloud/cloud_pager.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "core/cloud/packed_chunk.h"
#include "core/cloud/payload_codec.h"

namespace sweepscan {
namespace {

bool WriteAll(int fd, const void* data, size_t n, int64_t offset) {
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::pwrite(fd, p, n, offset);
    if (w < 0 && errno == EINTR) continue;
    if (w == 0) errno = ENOSPC;  // No progress without an error: say why.
    if (w <= 0) return false;
    p += w;
    n -= static_cast<size_t>(w);
    offset += w;
  }
  return true;
}

bool ReadAll(int fd, void* data, size_t n, int64_t offset) {
  char* p = static_cast<char*>(data);
  while (n > 0) {
    const ssize_t r = ::pread(fd, p, n, offset);
    if (r < 0 && errno == EINTR) continue;
    if (r == 0) errno = EIO;  // Short: the file ends before what we wrote.
    if (r <= 0) return false;
    p += r;
    n -= static_cast<size_t>(r);
    offset += r;
  }
  return true;
}

// An unnamed file in `dir`: O_TMPFILE where the file system has it, else a
// named one unlinked at once.
int OpenUnnamed(const std::string& dir) {
  int fd = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (fd >= 0) return fd;
  std::string name = dir + "/.sweepscan-cloud-cache-XXXXXX";
  std::vector<char> buf(name.begin(), name.end());
  buf.push_back('\0');
  fd = ::mkostemp(buf.data(), O_CLOEXEC);
  if (fd >= 0) ::unlink(buf.data());
  return fd;
}

}  // namespace

CloudPager& CloudPager::Default() {
  // Never destroyed: chunks may outlive main's statics (a kept cloud in a
  // static, a detached job), and the pager must outlive every chunk.
  static CloudPager* pager = new CloudPager();
  return *pager;
}

size_t CloudPager::DefaultBudgetBytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES);
  const long page = ::sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page <= 0) return size_t{2} << 30;
  return static_cast<size_t>(pages) * static_cast<size_t>(page) / 4;
}

CloudPager::CloudPager(size_t budget_bytes, std::string cache_dir)
    : budget_(budget_bytes), cache_dir_(std::move(cache_dir)) {}

CloudPager::~CloudPager() {
  if (fd_ >= 0) ::close(fd_);
}

void CloudPager::SetBudget(size_t bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  budget_ = bytes;
  EvictLocked();
}

size_t CloudPager::budget() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return budget_;
}

void CloudPager::SetCacheDirectory(const std::string& dir) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (dir == cache_dir_) return;
  cache_dir_ = dir;
  if (in_file_ == 0) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    file_end_ = 0;
    file_dir_.clear();
    cache_failed_ = false;  // Another disk: try again.
  }
}

std::string CloudPager::file_directory() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return file_dir_;
}

bool CloudPager::cache_failed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return cache_failed_;
}

void CloudPager::SetCacheRetryInterval(std::chrono::milliseconds interval) {
  std::lock_guard<std::mutex> lock(mutex_);
  cache_retry_interval_ = interval;
  if (cache_failed_) cache_retry_at_ = std::chrono::steady_clock::now() + interval;
}

size_t CloudPager::file_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<size_t>(file_end_);
}

void CloudPager::SetUnpackedBudget(size_t bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  unpacked_budget_ = bytes;
  EvictLocked();
}

size_t CloudPager::unpacked_budget() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return unpacked_budget_;
}

size_t CloudPager::resident_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return unpacked_ + packed_;
}

size_t CloudPager::unpacked_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return unpacked_;
}

size_t CloudPager::packed_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return packed_;
}

size_t CloudPager::paged_out_chunks() const {
  std::lock_guard<std::mutex> lock(mutex_);
  size_t n = 0;
  for (const auto& [chunk, w] : where_) n += !w.is_unpacked && !w.is_packed;
  return n;
}

size_t CloudPager::packed_chunks() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return packed_chunks_;
}

uint64_t CloudPager::page_outs() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return page_outs_;
}

uint64_t CloudPager::page_ins() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return page_ins_;
}

uint64_t CloudPager::unpacks() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return unpacks_;
}

void CloudPager::Add(const PackedChunk* chunk) {
  std::lock_guard<std::mutex> lock(mutex_);
  Where& w = where_[chunk];
  w.unpacked = lru_unpacked_.insert(lru_unpacked_.end(), chunk);
  w.is_unpacked = true;
  unpacked_ += chunk->payload_bytes();
  EvictLocked();
}

void CloudPager::Remove(const PackedChunk* chunk) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = where_.find(chunk);
  if (it != where_.end()) {
    if (it->second.is_unpacked) {
      lru_unpacked_.erase(it->second.unpacked);
      unpacked_ -= chunk->payload_bytes();
      unreturned_ += chunk->payload_bytes();
    }
    if (it->second.is_packed) {
      lru_packed_.erase(it->second.packed);
      packed_ -= chunk->packed_bytes_;
      unreturned_ += chunk->packed_bytes_;
    }
    where_.erase(it);
  }
  if (where_.empty()) cache_failed_ = false;  // The cloud is gone: the next one tries again.
  if (chunk->packed_bytes_ > 0) --packed_chunks_;
  // The file space of a dropped chunk is not reused one by one (a cache
  // lives as long as the cloud it pages, one session in the app); when the
  // last chunk in the file goes (the cloud cleared), the file is closed (it
  // has no name: its space comes back), and the next cloud's file opens
  // where its session is (SetCacheDirectory), not on the last one's disk.
  if (chunk->file_offset_ >= 0 && --in_file_ == 0 && fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
    file_end_ = 0;
    file_dir_.clear();
  }
  MaybeTrimLocked();
}

void CloudPager::Touch(const PackedChunk* chunk) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = where_.find(chunk);
  if (it == where_.end()) return;
  if (it->second.is_unpacked) lru_unpacked_.splice(lru_unpacked_.end(), lru_unpacked_, it->second.unpacked);
  if (it->second.is_packed) lru_packed_.splice(lru_packed_.end(), lru_packed_, it->second.packed);
}

std::shared_ptr<const std::vector<uint8_t>> CloudPager::PinPackedLocked(const PackedChunk* chunk) {
  Where& w = where_.at(chunk);
  std::shared_ptr<const std::vector<uint8_t>> bytes;
  {
    std::lock_guard<std::mutex> chunk_lock(chunk->mutex_);
    if (chunk->payload_ != nullptr) return nullptr;  // Another thread unpacked it.
    bytes = chunk->packed_;
  }
  if (bytes != nullptr) {
    lru_packed_.splice(lru_packed_.end(), lru_packed_, w.packed);
    return bytes;
  }
  bytes = ReadLocked(chunk);
  {
    std::lock_guard<std::mutex> chunk_lock(chunk->mutex_);
    chunk->packed_ = bytes;
  }
  ++page_ins_;
  w.packed = lru_packed_.insert(lru_packed_.end(), chunk);
  w.is_packed = true;
  packed_ += chunk->packed_bytes_;
  return bytes;
}

std::shared_ptr<const std::vector<uint8_t>> CloudPager::PinPacked(const PackedChunk* chunk) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto bytes = PinPackedLocked(chunk);
  EvictLocked();  // The pin keeps these bytes even if they go out again.
  return bytes;
}

std::shared_ptr<const ChunkPayload> CloudPager::Unpack(const PackedChunk* chunk) {
  std::shared_ptr<const std::vector<uint8_t>> bytes;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    bytes = PinPackedLocked(chunk);
    if (bytes == nullptr) {
      std::lock_guard<std::mutex> chunk_lock(chunk->mutex_);
      return chunk->payload_;
    }
    ++unpacks_;
    EvictLocked();  // The compressed bytes may have been read back from the file.
  }
  // Decoded outside the locks (about 2 ms for 65 536 points), for this
  // caller only: not kept among the unpacked. The readers of a large cloud
  // (the view's levels, an export) read each chunk once a pass, in an
  // order no cache smaller than the cloud would serve; keeping what they
  // unpack only evicted (and compressed, on their thread) the most
  // recently sealed chunks, which the live view reads next.
  return chunk->Unpack(*bytes, PackedChunk::kWholeChunk);
}

void CloudPager::EvictLocked() {
  // Unpacked payloads beyond their budget are compressed (the first time)
  // and dropped; the most recently used stays whatever the budget: it is
  // the one being read.
  const size_t unpacked_cap = std::min(unpacked_budget_, budget_ / 2);
  while (unpacked_ > unpacked_cap && lru_unpacked_.size() > 1) {
    const PackedChunk* victim = lru_unpacked_.front();
    Where& w = where_.at(victim);
    {
      std::lock_guard<std::mutex> chunk_lock(victim->mutex_);
      if (victim->packed_ == nullptr && victim->file_offset_ < 0) {
        auto bytes = std::make_shared<std::vector<uint8_t>>();
        EncodePayload(*victim->payload_, victim->size(), bytes.get(), &victim->segment_ends_);
        victim->packed_bytes_ = bytes->size();
        victim->packed_ = std::move(bytes);
        w.packed = lru_packed_.insert(lru_packed_.end(), victim);
        w.is_packed = true;
        packed_ += victim->packed_bytes_;
        if (victim->packed_bytes_ > 0) ++packed_chunks_;
      }
      // A reader holding a pin keeps its copy until it lets go.
      victim->payload_.reset();
    }
    lru_unpacked_.pop_front();
    w.is_unpacked = false;
    unpacked_ -= victim->payload_bytes();
    unreturned_ += victim->payload_bytes();
  }
  // Above the memory budget, compressed payloads go to the cache file,
  // least recently used first.
  const bool paging = !cache_failed_ || std::chrono::steady_clock::now() >= cache_retry_at_;
  while (paging && unpacked_ + packed_ > budget_ && !lru_packed_.empty()) {
    const PackedChunk* victim = lru_packed_.front();
    Where& w = where_.at(victim);
    {
      std::lock_guard<std::mutex> chunk_lock(victim->mutex_);
      if (victim->file_offset_ < 0) {
        int64_t offset = 0;
        if (!WriteLocked(*victim->packed_, &offset)) return;  // Stays in memory.
        victim->file_offset_ = offset;
        ++in_file_;
      }
      victim->packed_.reset();
    }
    lru_packed_.pop_front();
    w.is_packed = false;
    packed_ -= victim->packed_bytes_;
    ++page_outs_;
    unreturned_ += victim->packed_bytes_;
  }
  MaybeTrimLocked();
}

void CloudPager::MaybeTrimLocked() {
  // Freed payloads (128 KiB to 768 KiB arrays) go back to the system: glibc
  // serves such blocks from its heap once it has raised its mmap threshold,
  // and a free in the middle of a heap returns nothing (measured: 874 MiB
  // paged out, resident memory unchanged). Trimming walks the heap, so at
  // most once a second and after 256 MiB (a fixed mmap threshold instead
  // made every page-in fault fresh pages: picks 20 times slower).
  const auto now = std::chrono::steady_clock::now();
  if (unreturned_ >= (size_t{256} << 20) && now - last_trim_ >= std::chrono::seconds(1)) {
    malloc_trim(0);
    unreturned_ = 0;
    last_trim_ = now;
  }
}

bool CloudPager::WriteLocked(const std::vector<uint8_t>& bytes, int64_t* offset) {
  if (fd_ < 0) {
    // The cache directory, else (read-only, full, gone) the temporary one.
    const char* tmp = std::getenv("TMPDIR");
    const std::string temporary = tmp != nullptr && *tmp != '\0' ? tmp : "/tmp";
    std::string dir = cache_dir_.empty() ? temporary : cache_dir_;
    fd_ = OpenUnnamed(dir);
    if (fd_ < 0 && dir != temporary) fd_ = OpenUnnamed(dir = temporary);
    if (fd_ < 0) {
      if (!cache_failed_) {  // Said once a failure, not at every retry.
        std::fprintf(stderr, "sweepscan: cannot create the cloud cache file in %s: %s\n",
                     dir.c_str(), std::strerror(errno));
      }
      cache_failed_ = true;  // What is in memory stays there.
      cache_retry_at_ = std::chrono::steady_clock::now() + cache_retry_interval_;
      return false;
    }
    file_dir_ = dir;
  }
  // The compressed frames as they are in memory (payload_codec.h), back to
  // back with the other chunks'; their offsets stay in the chunks' headers.
  if (!WriteAll(fd_, bytes.data(), bytes.size(), file_end_)) {
    if (!cache_failed_) {
      std::fprintf(stderr,
                   "sweepscan: cannot write the cloud cache file in %s: %s; keeping the cloud "
                   "in memory\n",
                   file_dir_.c_str(), std::strerror(errno));
    }
    // Not for good: the budget stays the operator's, and paging is tried
    // again after the retry interval (space freed, the next cloud).
    cache_failed_ = true;
    cache_retry_at_ = std::chrono::steady_clock::now() + cache_retry_interval_;
    return false;
  }
  cache_failed_ = false;
  *offset = file_end_;
  file_end_ += static_cast<int64_t>(bytes.size());
  return true;
}

std::shared_ptr<const std::vector<uint8_t>> CloudPager::ReadLocked(const PackedChunk* chunk) {
  auto bytes = std::make_shared<std::vector<uint8_t>>(chunk->packed_bytes_);
  if (!ReadAll(fd_, bytes->data(), bytes->size(), chunk->file_offset_)) {
    // Our own unnamed file, written by us: a failed read is an I/O error of
    // the machine, and a cloud with holes would be worse than stopping.
    std::fprintf(
        stderr,
        "sweepscan: cannot read back the cloud cache file in %s (%zu bytes at byte %lld): %s\n",
        file_dir_.c_str(), chunk->packed_bytes_, static_cast<long long>(chunk->file_offset_),
        std::strerror(errno));
    std::abort();
  }
  return bytes;
}

}  // namespace sweepscan
