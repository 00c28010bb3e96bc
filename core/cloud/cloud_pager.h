// Memory for packed chunks' payloads (docs/cloud-store.md, "Compressed
// payloads" and "Out of core"): keeps the most recently sealed payloads
// unpacked up to the unpacked budget, compresses the rest (payload_codec.h,
// once a chunk, when it is evicted), and above the memory budget pages the
// least recently used compressed payloads out to a cache file. A compressed
// payload is unpacked for the reader that pins it, not kept.
//
// Why two budgets: readers (the view building a level, a pick, an export)
// want the 14-byte arrays, and a hundred million points of them are 1.3 GB;
// compressed they are under 3 bytes a point. The unpacked budget (128 MiB,
// at most half the memory budget) holds every payload of a cloud of up to
// about 9.5 M points (the last 32.5 minutes of scanning), so smaller clouds
// are never compressed at all.
//
// The cache file is created on the first page-out in the cache directory
// (the session's folder's parent for the app, TMPDIR otherwise or when
// that directory refuses it) and unlinked at once: it has no name, so a
// crash or a power loss leaves nothing behind, and the kernel frees it when
// the process ends. Payloads are appended and
// never rewritten (a sealed chunk never changes).
//
// Budget: payload bytes in memory, unpacked and compressed. Default: a
// quarter of physical memory, as the issue asks; the app's --memory-budget
// sets it.
//
// Threading: any thread. Lock order: the pager's mutex, then a chunk's. A
// chunk is compressed under both (about 4 ms for 65 536 points, on the
// thread whose Add went over the unpacked budget: the sealing thread);
// unpacking runs under neither.
#ifndef SWEEPSCAN_CORE_CLOUD_CLOUD_PAGER_H_
#define SWEEPSCAN_CORE_CLOUD_CLOUD_PAGER_H_

#include <cstdint>
#include <chrono>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

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
  // The cache file could not be created or written: what is in memory
  // stays there (the budget is kept) and paging is tried again after the
  // retry interval (30 s; space may have been freed), at once when the
  // cloud is gone or the cache directory changes.
  bool cache_failed() const;
  void SetCacheRetryInterval(std::chrono::milliseconds interval);
  // The directory the cache file is open in ("" while there is none).
  std::string file_directory() const;

  static constexpr size_t kDefaultUnpackedBudget = size_t{128} << 20;
  // The unpacked payloads' share; the pager uses at most half the memory budget.
  void SetUnpackedBudget(size_t bytes);
  size_t unpacked_budget() const;

  size_t resident_bytes() const;  // Unpacked and compressed payload bytes in memory.
  size_t unpacked_bytes() const;
  size_t packed_bytes() const;    // Compressed, in memory.
  size_t paged_out_chunks() const;  // Only in the cache file.
  size_t packed_chunks() const;     // Compressed once (in memory or the file).
  uint64_t page_outs() const;
  uint64_t page_ins() const;
  uint64_t unpacks() const;  // Whole payloads decoded from their compressed form.

  // PackedChunk's side (not for other callers).
  void Add(const PackedChunk* chunk);     // A new chunk, unpacked.
  void Remove(const PackedChunk* chunk);  // Chunk destroyed.
  // The unpacked payload of a chunk that is not unpacked: decoded from its
  // compressed form (read back from the file first if it was paged out)
  // for the caller, not kept.
  std::shared_ptr<const ChunkPayload> Unpack(const PackedChunk* chunk);
  // The compressed bytes of a chunk that is not unpacked (read back if paged
  // out); null if it is unpacked after all (another thread was first).
  std::shared_ptr<const std::vector<uint8_t>> PinPacked(const PackedChunk* chunk);
  void Touch(const PackedChunk* chunk);  // Most recently used.

 private:
  using Lru = std::list<const PackedChunk*>;
  struct Where {
    Lru::iterator unpacked, packed;
    bool is_unpacked = false, is_packed = false;
  };
  std::shared_ptr<const std::vector<uint8_t>> PinPackedLocked(const PackedChunk* chunk);
  void EvictLocked();  // Until within both budgets.
  void MaybeTrimLocked();  // Freed payloads back to the system (malloc_trim).
  bool WriteLocked(const std::vector<uint8_t>& bytes, int64_t* offset);
  std::shared_ptr<const std::vector<uint8_t>> ReadLocked(const PackedChunk* chunk);

  mutable std::mutex mutex_;
  size_t budget_;
  size_t unpacked_budget_ = kDefaultUnpackedBudget;
  std::string cache_dir_;
  std::string file_dir_;  // where fd_ was opened
  int fd_ = -1;
  int64_t file_end_ = 0;
  bool cache_failed_ = false;
  std::chrono::steady_clock::time_point cache_retry_at_;
  std::chrono::milliseconds cache_retry_interval_{30000};
  size_t unpacked_ = 0, packed_ = 0;  // Bytes in memory.
  size_t packed_chunks_ = 0;
  size_t in_file_ = 0;  // Live chunks with a copy in the cache file.
  size_t unreturned_ = 0;  // Payload bytes dropped since the last malloc_trim.
  std::chrono::steady_clock::time_point last_trim_{};
  uint64_t page_outs_ = 0, page_ins_ = 0, unpacks_ = 0;
  // Chunks unpacked and chunks compressed in memory, least recently used first.
  Lru lru_unpacked_, lru_packed_;
  std::unordered_map<const PackedChunk*, Where> where_;  // Every live chunk.
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CLOUD_CLOUD_PAGER_H_
