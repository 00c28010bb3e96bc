#include "core/cloud/cloud_pager.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <malloc.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "core/cloud/packed_chunk.h"

namespace sweepscan {
namespace {

bool WriteAll(int fd, const void* data, size_t n, int64_t offset) {
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::pwrite(fd, p, n, offset);
    if (w < 0 && errno == EINTR) continue;
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
  if (fd_ >= 0 && in_file_ == 0) {
    ::close(fd_);
    fd_ = -1;
    file_end_ = 0;
  }
}

size_t CloudPager::file_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<size_t>(file_end_);
}

size_t CloudPager::resident_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return resident_;
}

size_t CloudPager::paged_out_chunks() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return paged_out_;
}

uint64_t CloudPager::page_outs() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return page_outs_;
}

uint64_t CloudPager::page_ins() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return page_ins_;
}

void CloudPager::Add(const PackedChunk* chunk) {
  std::lock_guard<std::mutex> lock(mutex_);
  where_[chunk] = lru_.insert(lru_.end(), chunk);
  resident_ += chunk->payload_bytes();
  EvictLocked();
}

void CloudPager::Remove(const PackedChunk* chunk) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = where_.find(chunk);
  if (it != where_.end()) {
    lru_.erase(it->second);
    where_.erase(it);
    resident_ -= chunk->payload_bytes();
    unreturned_ += chunk->payload_bytes();
  } else {
    --paged_out_;
  }
  // The file space of a dropped chunk is not reused one by one (a cache
  // lives as long as the cloud it pages, one session in the app); when the
  // last chunk in the file goes (the cloud cleared), the file is emptied.
  if (chunk->file_offset_ >= 0 && --in_file_ == 0 && fd_ >= 0) {
    if (::ftruncate(fd_, 0) == 0) file_end_ = 0;
  }
  MaybeTrimLocked();
}

void CloudPager::Touch(const PackedChunk* chunk) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = where_.find(chunk);
  if (it != where_.end()) lru_.splice(lru_.end(), lru_, it->second);
}

std::shared_ptr<const ChunkPayload> CloudPager::PageIn(const PackedChunk* chunk) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::shared_ptr<const ChunkPayload> payload;
  {
    std::lock_guard<std::mutex> chunk_lock(chunk->mutex_);
    if (chunk->payload_ != nullptr) return chunk->payload_;  // Another thread was first.
    payload = ReadLocked(chunk, chunk->file_offset_);
    chunk->payload_ = payload;
  }
  ++page_ins_;
  --paged_out_;
  where_[chunk] = lru_.insert(lru_.end(), chunk);
  resident_ += chunk->payload_bytes();
  EvictLocked();
  return payload;
}

void CloudPager::EvictLocked() {
  // The most recently used chunk stays whatever the budget: it is the one
  // being read.
  while (resident_ > budget_ && lru_.size() > 1) {
    const PackedChunk* victim = lru_.front();
    {
      std::lock_guard<std::mutex> chunk_lock(victim->mutex_);
      if (victim->file_offset_ < 0) {
        int64_t offset = 0;
        if (!WriteLocked(victim, *victim->payload_, &offset)) return;  // Stays resident.
        victim->file_offset_ = offset;
        ++in_file_;
      }
      // A reader holding a pin keeps its copy until it lets go.
      victim->payload_.reset();
    }
    lru_.pop_front();
    where_.erase(victim);
    resident_ -= victim->payload_bytes();
    ++paged_out_;
    ++page_outs_;
    unreturned_ += victim->payload_bytes();
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

bool CloudPager::WriteLocked(const PackedChunk* chunk, const ChunkPayload& p, int64_t* offset) {
  (void)chunk;
  if (fd_ < 0) {
    // The cache directory, else (read-only, full, gone) the temporary one.
    const char* tmp = std::getenv("TMPDIR");
    const std::string temporary = tmp != nullptr && *tmp != '\0' ? tmp : "/tmp";
    std::string dir = cache_dir_.empty() ? temporary : cache_dir_;
    fd_ = OpenUnnamed(dir);
    if (fd_ < 0 && dir != temporary) fd_ = OpenUnnamed(dir = temporary);
    if (fd_ < 0) {
      std::fprintf(stderr, "sweepscan: cannot create the cloud cache file in %s: %s\n",
                   dir.c_str(), std::strerror(errno));
      budget_ = static_cast<size_t>(-1);  // Stay in memory: say it once.
      return false;
    }
  }
  // Layout: xyz (int16 grid steps or float), range (uint16 or float), dt_ns,
  // beam, back to back.
  int64_t at = file_end_;
  const struct {
    const void* data;
    size_t bytes;
  } parts[] = {{p.xyz_mm.empty() ? static_cast<const void*>(p.xyz.data()) : p.xyz_mm.data(),
                p.xyz_mm.empty() ? p.xyz.size() * 4 : p.xyz_mm.size() * 2},
               {p.range_q.empty() ? static_cast<const void*>(p.range_f.data()) : p.range_q.data(),
                p.range_q.empty() ? p.range_f.size() * 4 : p.range_q.size() * 2},
               {p.dt_ns.data(), p.dt_ns.size() * 4},
               {p.beam.data(), p.beam.size() * 2}};
  for (const auto& part : parts) {
    if (!WriteAll(fd_, part.data, part.bytes, at)) {
      std::fprintf(stderr, "sweepscan: cannot write the cloud cache file: %s; keeping the cloud "
                   "in memory\n", std::strerror(errno));
      budget_ = static_cast<size_t>(-1);
      return false;
    }
    at += static_cast<int64_t>(part.bytes);
  }
  *offset = file_end_;
  file_end_ = at;
  return true;
}

std::shared_ptr<ChunkPayload> CloudPager::ReadLocked(const PackedChunk* chunk, int64_t offset) {
  auto p = std::make_shared<ChunkPayload>();
  const size_t n = chunk->size();
  const bool grid = chunk->positions_on_grid();
  const bool quantised = chunk->ranges_quantised();
  (grid ? p->xyz_mm.resize(3 * n) : p->xyz.resize(3 * n));
  (quantised ? p->range_q.resize(n) : p->range_f.resize(n));
  p->dt_ns.resize(n);
  p->beam.resize(n);
  bool ok = grid ? ReadAll(fd_, p->xyz_mm.data(), 6 * n, offset)
                 : ReadAll(fd_, p->xyz.data(), 12 * n, offset);
  offset += static_cast<int64_t>((grid ? 6 : 12) * n);
  ok = ok && (quantised ? ReadAll(fd_, p->range_q.data(), 2 * n, offset)
                        : ReadAll(fd_, p->range_f.data(), 4 * n, offset));
  offset += static_cast<int64_t>((quantised ? 2 : 4) * n);
  ok = ok && ReadAll(fd_, p->dt_ns.data(), 4 * n, offset);
  offset += static_cast<int64_t>(4 * n);
  ok = ok && ReadAll(fd_, p->beam.data(), 2 * n, offset);
  if (!ok) {
    // Our own unnamed file, written by us: a failed read is an I/O error of
    // the machine, and a cloud with holes would be worse than stopping.
    std::fprintf(stderr, "sweepscan: cannot read back the cloud cache file: %s\n",
                 std::strerror(errno));
    std::abort();
  }
  return p;
}

}  // namespace sweepscan
