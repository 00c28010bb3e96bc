// Out of core for packed chunks: keeps the payloads of sealed chunks in
// memory up to a budget and pages the least recently used out to a cache
// file (docs/cloud-store.md, "Out of core").
//
// The cache file is created on the first page-out in the cache directory
// (the session's folder's parent for the app, TMPDIR otherwise or when
// that directory refuses it) and unlinked at once: it has no name, so a
// crash or a power loss leaves nothing behind, and the kernel frees it when
// the process ends. Payloads are appended and
// never rewritten (a sealed chunk never changes).
//
// Budget: resident payload bytes. Default: a quarter of physical memory, as
// the issue asks; the app's --memory-budget sets it.
//
// Threading: any thread. Lock order: the pager's mutex, then a chunk's.
#ifndef SWEEPSCAN_CORE_CLOUD_CLOUD_PAGER_H_
#define SWEEPSCAN_CORE_CLOUD_CLOUD_PAGER_H_

#include <cstdint>
#include <chrono>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

namespace sweepscan {

class PackedChunk;
struct ChunkPayload;

class CloudPager {
 public:
  // The pager every PointChunks uses unless given another.
  static CloudPager& Default();
  static size_t DefaultBudgetBytes();  // A quarter of physical memory.

  explicit CloudPager(size_t budget_bytes = DefaultBudgetBytes(), std::string cache_dir = "");
  ~CloudPager();
  CloudPager(const CloudPager&) = delete;
  CloudPager& operator=(const CloudPager&) = delete;

  void SetBudget(size_t bytes);
  size_t budget() const;
  // Where the cache file goes (its filesystem: not a RAM-backed /tmp). Takes
  // effect at once if no live chunk is in the file, else for the next file.
  void SetCacheDirectory(const std::string& dir);
  size_t file_bytes() const;  // The cache file's size now.

  size_t resident_bytes() const;
  size_t paged_out_chunks() const;
  uint64_t page_outs() const;
  uint64_t page_ins() const;

  // PackedChunk's side (not for other callers).
  void Add(const PackedChunk* chunk);     // A new resident chunk.
  void Remove(const PackedChunk* chunk);  // Chunk destroyed.
  // The payload of a chunk that was paged out, read back (and accounted).
  std::shared_ptr<const ChunkPayload> PageIn(const PackedChunk* chunk);
  void Touch(const PackedChunk* chunk);  // Most recently used.

 private:
  void EvictLocked();  // Until within budget.
  void MaybeTrimLocked();  // Freed payloads back to the system (malloc_trim).
  bool WriteLocked(const PackedChunk* chunk, const ChunkPayload& payload, int64_t* offset);
  std::shared_ptr<ChunkPayload> ReadLocked(const PackedChunk* chunk, int64_t offset);

  mutable std::mutex mutex_;
  size_t budget_;
  std::string cache_dir_;
  int fd_ = -1;
  int64_t file_end_ = 0;
  size_t resident_ = 0;
  size_t paged_out_ = 0;
  size_t in_file_ = 0;  // Live chunks with a copy in the cache file.
  size_t unreturned_ = 0;  // Payload bytes dropped since the last malloc_trim.
  std::chrono::steady_clock::time_point last_trim_{};
  uint64_t page_outs_ = 0, page_ins_ = 0;
  // Resident chunks, least recently used first.
  std::list<const PackedChunk*> lru_;
  std::unordered_map<const PackedChunk*, std::list<const PackedChunk*>::iterator> where_;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CLOUD_CLOUD_PAGER_H_
