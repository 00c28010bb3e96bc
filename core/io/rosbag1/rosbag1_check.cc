#include "core/io/rosbag1/rosbag1_check.h"

#include <bzlib.h>
#include <fcntl.h>
#include <roslz4/lz4s.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <functional>
#include <map>
#include <memory>
#include <vector>

namespace sweepscan::io {
namespace {

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr size_t kMagicSize = sizeof(kMagic) - 1;

enum Op : uint8_t {
  kMessageData = 0x02,
  kBagHeader = 0x03,
  kIndexData = 0x04,
  kChunk = 0x05,
  kChunkInfo = 0x06,
  kConnection = 0x07,
};

uint32_t U32(const uint8_t* p) {
  uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}
uint64_t U64(const uint8_t* p) {
  uint64_t v;
  std::memcpy(&v, p, 8);
  return v;
}

// Thrown with the reason; the walk adds the place.
struct Bad {
  std::string why;
};

// One record's header fields (name -> value bytes), every length checked.
using Fields = std::map<std::string, std::string>;

Fields ParseFields(const uint8_t* p, size_t size) {
  Fields fields;
  for (size_t i = 0; i < size;) {
    if (size - i < 4) throw Bad{"a header field's length is cut off"};
    const uint32_t len = U32(p + i);
    i += 4;
    if (len > size - i) {
      throw Bad{"a header field of " + std::to_string(len) + " bytes overruns its header (" +
                std::to_string(size - i) + " left)"};
    }
    const char* f = reinterpret_cast<const char*>(p + i);
    const void* eq = std::memchr(f, '=', len);
    if (eq == nullptr) throw Bad{"a header field has no '='"};
    const size_t name = static_cast<const char*>(eq) - f;
    fields[std::string(f, name)] = std::string(f + name + 1, len - name - 1);
    i += len;
  }
  return fields;
}

// A field that must be there with exactly `bytes` bytes.
const std::string& Field(const Fields& f, const char* name, size_t bytes) {
  const auto it = f.find(name);
  if (it == f.end()) throw Bad{std::string("no '") + name + "' field"};
  if (bytes != 0 && it->second.size() != bytes) {
    throw Bad{std::string("field '") + name + "' has " + std::to_string(it->second.size()) +
              " bytes, not " + std::to_string(bytes)};
  }
  return it->second;
}
uint32_t FieldU32(const Fields& f, const char* name) {
  return U32(reinterpret_cast<const uint8_t*>(Field(f, name, 4).data()));
}
uint64_t FieldU64(const Fields& f, const char* name) {
  return U64(reinterpret_cast<const uint8_t*>(Field(f, name, 8).data()));
}

// Where the bytes come from: memory (a chunk, a fuzzer's input) or a file
// read piece by piece (a bag of gigabytes is not mapped whole: its pages
// would count as the importer's memory).
class Source {
 public:
  virtual ~Source() = default;
  virtual size_t size() const = 0;
  // `n` bytes at `offset` (within size()).
  virtual const uint8_t* Read(size_t offset, size_t n) = 0;
};

class MemorySource : public Source {
 public:
  MemorySource(const uint8_t* p, size_t size) : p_(p), size_(size) {}
  size_t size() const override { return size_; }
  const uint8_t* Read(size_t offset, size_t) override { return p_ + offset; }

 private:
  const uint8_t* p_;
  size_t size_;
};

class FileSource : public Source {
 public:
  FileSource(int fd, size_t size) : fd_(fd), size_(size) {}
  size_t size() const override { return size_; }
  // Valid until the next Read.
  const uint8_t* Read(size_t offset, size_t n) override {
    buffer_.resize(n);
    for (size_t done = 0; done < n;) {
      const ssize_t k =
          ::pread(fd_, buffer_.data() + done, n - done, static_cast<off_t>(offset + done));
      if (k < 0 && errno == EINTR) continue;
      if (k <= 0)
        throw Bad{std::string("read failed: ") + (k < 0 ? std::strerror(errno) : "end of file")};
      done += static_cast<size_t>(k);
    }
    return buffer_.data();
  }

 private:
  int fd_;
  size_t size_;
  std::vector<uint8_t> buffer_;
};

struct Record {
  size_t at = 0;  // offset of its header_len
  uint8_t op = 0;
  Fields fields;
  size_t data_at = 0;
  uint32_t data_len = 0;
  size_t end = 0;  // offset after it
};

// The record at `at` within the source (its header and lengths; the data
// are read by the caller that needs them).
Record ReadRecord(Source* source, size_t at) {
  const size_t size = source->size();
  Record r;
  r.at = at;
  if (size - at < 4) throw Bad{"a record's header length is cut off"};
  const uint32_t header_len = U32(source->Read(at, 4));
  if (header_len > size - at - 4) {
    throw Bad{"a record header of " + std::to_string(header_len) + " bytes overruns (" +
              std::to_string(size - at - 4) + " left)"};
  }
  r.fields = ParseFields(source->Read(at + 4, header_len), header_len);
  r.op = static_cast<uint8_t>(Field(r.fields, "op", 1)[0]);
  const size_t data_at = at + 4 + header_len;
  if (size - data_at < 4) throw Bad{"a record's data length is cut off"};
  r.data_len = U32(source->Read(data_at, 4));
  if (r.data_len > size - data_at - 4) {
    throw Bad{"record data of " + std::to_string(r.data_len) + " bytes overruns (" +
              std::to_string(size - data_at - 4) + " left)"};
  }
  r.data_at = data_at + 4;
  r.end = r.data_at + r.data_len;
  return r;
}

// A chunk's records: connection and message data, each within the chunk;
// the message records' offsets and connections for the index to point at.
void WalkChunk(const uint8_t* p, size_t size, std::map<uint32_t, uint32_t>* messages) {
  MemorySource chunk(p, size);
  for (size_t at = 0; at < size;) {
    Record r;
    try {
      r = ReadRecord(&chunk, at);
      if (r.op == kMessageData) {
        FieldU64(r.fields, "time");
        (*messages)[static_cast<uint32_t>(at)] = FieldU32(r.fields, "conn");
      } else if (r.op == kConnection) {
        FieldU32(r.fields, "conn");
        Field(r.fields, "topic", 0);
        ParseFields(p + r.data_at, r.data_len);
      } else {
        throw Bad{"a record of type " + std::to_string(r.op) + " inside a chunk"};
      }
    } catch (const Bad& b) {
      throw Bad{"inside the chunk at its byte " + std::to_string(at) + ": " + b.why};
    }
    at = r.end;
  }
}

// bz2 through its stream interface into a buffer that grows with what the
// data really decompress to, doubling up to `size`: bzip2 can expand ~1:46
// million, so no bound on `size` follows from `len`, and a corrupt header's
// 4 GiB must not be allocated before the data say otherwise (the fuzzer's
// out-of-memory). Ends where bzip2's stream ends; output past `size` is
// refused, as BZ2_bzBuffToBuffDecompress refuses it (BZ_OUTBUFF_FULL).
std::unique_ptr<uint8_t[]> DecompressBz2(const uint8_t* data, uint32_t len, uint32_t size,
                                         uint64_t* got) {
  bz_stream bz{};
  int rc = BZ2_bzDecompressInit(&bz, 0, 0);
  if (rc != BZ_OK) throw Bad{"bzip2 could not start (bzip2 error " + std::to_string(rc) + ")"};
  struct End {
    bz_stream* bz;
    ~End() { BZ2_bzDecompressEnd(bz); }
  } end{&bz};
  // Both libraries take non-const input they do not write.
  bz.next_in = const_cast<char*>(reinterpret_cast<const char*>(data));
  bz.avail_in = len;
  uint64_t cap = std::min<uint64_t>(size, std::max<uint64_t>(uint64_t{len} * 16, 1 << 20));
  std::unique_ptr<uint8_t[]> out(new uint8_t[cap == 0 ? 1 : cap]);
  *got = 0;
  for (;;) {
    if (*got == cap && cap < size) {
      const uint64_t grown = std::min<uint64_t>(size, cap * 2);
      std::unique_ptr<uint8_t[]> bigger(new uint8_t[grown]);
      std::memcpy(bigger.get(), out.get(), *got);
      out = std::move(bigger);
      cap = grown;
    }
    char spare;  // Once `size` bytes are out: any more is too many.
    const bool full = *got == cap;
    const unsigned room = full ? 1u : static_cast<unsigned>(std::min<uint64_t>(cap - *got, 1u << 30));
    bz.next_out = full ? &spare : reinterpret_cast<char*>(out.get() + *got);
    bz.avail_out = room;
    const unsigned in_before = bz.avail_in;
    rc = BZ2_bzDecompress(&bz);
    const unsigned produced = room - bz.avail_out;
    if (full && produced > 0) rc = BZ_OUTBUFF_FULL;
    if (rc == BZ_OK && produced == 0 && bz.avail_in == in_before) rc = BZ_UNEXPECTED_EOF;
    if (rc != BZ_OK && rc != BZ_STREAM_END)
      throw Bad{"its bz2 data do not decompress (bzip2 error " + std::to_string(rc) + ")"};
    if (!full) *got += produced;
    if (rc == BZ_STREAM_END) return out;
  }
}

// The chunk's data decompressed as its `compression` says, to exactly
// `size` bytes (any size a u32 holds: one message of a gigabyte makes a
// chunk that big). The buffer is left uninitialised: a corrupt size costs
// the pages the decompressor writes before it fails, not `size` of zeros;
// bz2's grows with its output, and lz4's is bounded by lz4's best ratio.
std::unique_ptr<uint8_t[]> Decompress(const std::string& compression, const uint8_t* data,
                                      uint32_t len, uint32_t size) {
  if (compression == "none") {
    std::unique_ptr<uint8_t[]> out(new uint8_t[size == 0 ? 1 : size]);
    std::memcpy(out.get(), data, size);  // len == size, checked by the caller
    return out;
  }
  uint64_t got = 0;
  std::unique_ptr<uint8_t[]> out;
  if (compression == "bz2") {
    out = DecompressBz2(data, len, size, &got);
  } else {
    // An LZ4 sequence expands at most ~255 times (a match's length grows by
    // 255 a byte), plus the frame's own bytes: a header claiming more than
    // that is refused before anything is allocated.
    if (size > uint64_t{len} * 255 + 65536) {
      throw Bad{"the chunk's header says it decompresses to " + std::to_string(size) +
                " bytes, more than its " + std::to_string(len) + " bytes of lz4 can hold"};
    }
    out.reset(new uint8_t[size == 0 ? 1 : size]);
    unsigned int lz4_got = size;
    const int rc = roslz4_buffToBuffDecompress(const_cast<char*>(reinterpret_cast<const char*>(data)),
                                               len, reinterpret_cast<char*>(out.get()), &lz4_got);
    if (rc != ROSLZ4_OK)
      throw Bad{"its lz4 data do not decompress (roslz4 error " + std::to_string(rc) + ")"};
    got = lz4_got;
  }
  if (got != size) {
    throw Bad{"the chunk decompresses to " + std::to_string(got) + " bytes, its header says " +
              std::to_string(size)};
  }
  return out;
}

// Follows rosbag_storage's own reading of a bag (format 2.0), every length
// checked: the bag header; at index_pos, conn_count connections and
// chunk_count chunk infos; for each chunk info, the chunk record at its
// chunk_pos and the index data records right after it, one a connection the
// chunk info names. Nothing else in the file is read by rosbag (a bag
// `rosbag reindex` repaired keeps its cut old index before the new one), so
// nothing else is judged.
Status CheckRosbag1(Source* source, const std::string& name, bool walk_chunks,
                    const std::function<bool(double)>& progress, std::string* first_compression) {
  uint64_t first_chunk = UINT64_MAX;
  const size_t size = source->size();
  if (size < kMagicSize || std::memcmp(source->Read(0, kMagicSize), kMagic, kMagicSize) != 0) {
    return Status::Error(name + ": not a ROS 1 bag (it does not start with \"#ROSBAG V2.0\")");
  }
  size_t at = kMagicSize;
  try {
    const Record header = ReadRecord(source, at);
    if (header.op != kBagHeader) throw Bad{"the first record is not the bag header"};
    const uint64_t index_pos = FieldU64(header.fields, "index_pos");
    const uint32_t connections = FieldU32(header.fields, "conn_count");
    const uint32_t chunks = FieldU32(header.fields, "chunk_count");
    if (index_pos == 0) return Status::Ok();  // unindexed: rosbag says what to do
    if (index_pos > size) {
      return Status::Error(name + ": its index is said to start at byte " +
                           std::to_string(index_pos) + ", beyond the end of the file (" +
                           std::to_string(size) +
                           " bytes): a copy cut short? Run `rosbag reindex " + name +
                           "` and import the reindexed bag");
    }
    if (index_pos < header.end) throw Bad{"the index position lies inside the bag header"};
    // The index. Damage here (or an index cut short by the end of the
    // file) is what `rosbag reindex` repairs.
    struct ChunkInfo {
      uint64_t pos;
      std::map<uint32_t, uint32_t> counts;  // connection -> messages
    };
    std::vector<ChunkInfo> infos;
    at = index_pos;
    try {
      for (uint32_t k = 0; k < connections; ++k) {
        const Record r = ReadRecord(source, at);
        if (r.op != kConnection) {
          throw Bad{"connection " + std::to_string(k) + " of " + std::to_string(connections) +
                    " is a record of type " + std::to_string(r.op)};
        }
        FieldU32(r.fields, "conn");
        Field(r.fields, "topic", 0);
        ParseFields(source->Read(r.data_at, r.data_len), r.data_len);
        at = r.end;
      }
      for (uint32_t k = 0; k < chunks; ++k) {
        const Record r = ReadRecord(source, at);
        if (r.op != kChunkInfo) {
          throw Bad{"chunk info " + std::to_string(k) + " of " + std::to_string(chunks) +
                    " is a record of type " + std::to_string(r.op)};
        }
        if (FieldU32(r.fields, "ver") != 1) throw Bad{"chunk info of a version other than 1"};
        ChunkInfo info;
        info.pos = FieldU64(r.fields, "chunk_pos");
        FieldU64(r.fields, "start_time");
        FieldU64(r.fields, "end_time");
        const uint32_t count = FieldU32(r.fields, "count");
        if (static_cast<uint64_t>(count) * 8 != r.data_len) {
          throw Bad{"chunk info of " + std::to_string(count) + " connections in " +
                    std::to_string(r.data_len) + " bytes (8 a connection)"};
        }
        const uint8_t* entries = source->Read(r.data_at, r.data_len);
        for (uint32_t e = 0; e < count; ++e) {
          if (!info.counts.emplace(U32(entries + 8 * e), U32(entries + 8 * e + 4)).second) {
            throw Bad{"chunk info names connection " + std::to_string(U32(entries + 8 * e)) +
                      " twice"};
          }
        }
        if (info.pos < header.end || info.pos >= size) {
          throw Bad{"chunk info for byte " + std::to_string(info.pos) +
                    ", outside the file's chunks"};
        }
        infos.push_back(std::move(info));
        at = r.end;
      }
    } catch (const Bad& b) {
      throw Bad{b.why + " (the index, from byte " + std::to_string(index_pos) +
                "; `rosbag reindex " + name + "` rebuilds it)"};
    }
    // Each chunk as rosbag reads it.
    for (size_t c = 0; c < infos.size(); ++c) {
      if (progress && !progress(static_cast<double>(c) / static_cast<double>(infos.size()))) {
        return Status::Error(name + ": cancelled");
      }
      const ChunkInfo& info = infos[c];
      at = info.pos;
      const Record chunk = ReadRecord(source, at);
      if (chunk.op != kChunk) {
        throw Bad{"a chunk info points here, at a record of type " + std::to_string(chunk.op)};
      }
      const uint32_t decompressed = FieldU32(chunk.fields, "size");
      const std::string& compression = Field(chunk.fields, "compression", 0);
      if (first_compression != nullptr && info.pos < first_chunk) {
        first_chunk = info.pos;
        *first_compression = compression;
      }
      if (compression != "none" && compression != "bz2" && compression != "lz4") {
        throw Bad{"unknown chunk compression '" + compression + "' (none, bz2, lz4)"};
      }
      if (compression == "none" && chunk.data_len != decompressed) {
        throw Bad{"an uncompressed chunk of " + std::to_string(chunk.data_len) + " bytes claims " +
                  std::to_string(decompressed)};
      }
      std::map<uint32_t, uint32_t> messages;  // offset -> conn
      if (walk_chunks) {
        const std::unique_ptr<uint8_t[]> bytes = Decompress(
            compression, source->Read(chunk.data_at, chunk.data_len), chunk.data_len, decompressed);
        WalkChunk(bytes.get(), decompressed, &messages);
      }
      at = chunk.end;
      for (size_t k = 0; k < info.counts.size(); ++k) {
        const Record r = ReadRecord(source, at);
        if (r.op != kIndexData) {
          throw Bad{"index data " + std::to_string(k) + " of " +
                    std::to_string(info.counts.size()) + " after the chunk at byte " +
                    std::to_string(info.pos) + " is a record of type " + std::to_string(r.op)};
        }
        if (FieldU32(r.fields, "ver") != 1) throw Bad{"index data of a version other than 1"};
        const uint32_t conn = FieldU32(r.fields, "conn");
        const uint32_t count = FieldU32(r.fields, "count");
        if (static_cast<uint64_t>(count) * 12 != r.data_len) {
          throw Bad{"index data of " + std::to_string(count) + " entries in " +
                    std::to_string(r.data_len) + " bytes (12 an entry)"};
        }
        const auto named = info.counts.find(conn);
        if (named == info.counts.end() || named->second != count) {
          throw Bad{"index data of connection " + std::to_string(conn) + " with " +
                    std::to_string(count) + " entries, which the chunk info for byte " +
                    std::to_string(info.pos) + " does not name"};
        }
        const uint8_t* entries = source->Read(r.data_at, r.data_len);
        for (uint32_t e = 0; e < count; ++e) {
          const uint32_t offset = U32(entries + 12 * e + 8);
          if (!walk_chunks) {
            if (offset >= decompressed) {
              throw Bad{"index entry " + std::to_string(e) + " points at byte " +
                        std::to_string(offset) + " of a chunk of " + std::to_string(decompressed) +
                        " bytes"};
            }
            continue;
          }
          const auto m = messages.find(offset);
          if (m == messages.end()) {
            throw Bad{"index entry " + std::to_string(e) + " points at byte " +
                      std::to_string(offset) + " of its chunk, where no message record starts"};
          }
          if (m->second != conn) {
            throw Bad{"index entry " + std::to_string(e) + " of connection " +
                      std::to_string(conn) + " points at a message of connection " +
                      std::to_string(m->second)};
          }
        }
        at = r.end;
      }
    }
  } catch (const Bad& b) {
    return Status::Error(name + ": damaged ROS 1 bag at byte " + std::to_string(at) + ": " + b.why);
  }
  return Status::Ok();
}

}  // namespace

Status CheckRosbag1Image(const uint8_t* data, size_t size, const std::string& name, bool chunks) {
  MemorySource source(data, size);
  return CheckRosbag1(&source, name, chunks, nullptr, nullptr);
}

Status CheckRosbag1File(const std::string& path, bool chunks,
                        const std::function<bool(double)>& progress,
                        std::string* first_compression) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Status::Error(path + ": cannot open: " + std::strerror(errno));
  struct stat st;
  if (::fstat(fd, &st) != 0) {
    const int e = errno;
    ::close(fd);
    return Status::Error(path + ": cannot stat: " + std::strerror(e));
  }
  ::posix_fadvise(fd, 0, 0, POSIX_FADV_SEQUENTIAL);
  FileSource source(fd, static_cast<size_t>(st.st_size));
  Status s;
  try {
    s = CheckRosbag1(&source, path, chunks, progress, first_compression);
  } catch (const Bad& b) {  // a read failed outside the walk's own catch
    s = Status::Error(path + ": " + b.why);
  }
  ::close(fd);
  return s;
}

namespace {

// ROS 1 serialisation walked by field.
class Walker {
 public:
  Walker(const uint8_t* p, size_t size) : p_(p), size_(size) {}
  void Skip(size_t bytes, const char* field) {
    if (bytes > size_ - at_) {
      throw Bad{std::string(field) + " needs " + std::to_string(bytes) + " bytes at byte " +
                std::to_string(at_) + ", " + std::to_string(size_ - at_) + " left"};
    }
    at_ += bytes;
  }
  uint32_t Count(const char* field) {
    Skip(4, field);
    return U32(p_ + at_ - 4);
  }
  // A u32 count of `element`-byte items, checked against the bytes left
  // before anything is allocated for them.
  uint32_t Array(size_t element, const char* field) {
    const uint32_t n = Count(field);
    if (static_cast<uint64_t>(n) * element > size_ - at_) {
      throw Bad{std::string(field) + ": " + std::to_string(n) + " elements of " +
                std::to_string(element) + " bytes at byte " + std::to_string(at_ - 4) + ", " +
                std::to_string(size_ - at_) + " bytes left"};
    }
    at_ += static_cast<size_t>(n) * element;
    return n;
  }
  void Header(const char* what) {
    Skip(4 + 8, what);  // seq, stamp
    Array(1, "header.frame_id");
  }
  size_t left() const { return size_ - at_; }

 private:
  const uint8_t* p_;
  size_t size_;
  size_t at_ = 0;
};

}  // namespace

Status CheckRos1Message(RosMessageKind kind, const uint8_t* data, size_t size) {
  Walker w(data, size);
  try {
    switch (kind) {
      case RosMessageKind::kOther:
        return Status::Ok();
      case RosMessageKind::kLaserScan:
        w.Header("header");
        w.Skip(7 * 4, "angle_min .. range_max");
        w.Array(4, "ranges");
        w.Array(4, "intensities");
        break;
      case RosMessageKind::kOdometry:
        w.Header("header");
        w.Array(1, "child_frame_id");
        w.Skip((7 + 36 + 6 + 36) * 8, "pose, twist and their covariances");
        break;
      case RosMessageKind::kImu:
        w.Header("header");
        w.Skip((4 + 9 + 3 + 9 + 3 + 9) * 8, "orientation .. linear_acceleration_covariance");
        break;
      case RosMessageKind::kTf: {
        // Each TransformStamped: header (>= 16 bytes), child_frame_id (>= 4), 7 doubles.
        const uint32_t n = w.Count("transforms");
        if (static_cast<uint64_t>(n) * (16 + 4 + 56) > w.left()) {
          throw Bad{"transforms: " + std::to_string(n) + " transforms cannot fit in " +
                    std::to_string(w.left()) + " bytes"};
        }
        for (uint32_t k = 0; k < n; ++k) {
          w.Header("transforms[].header");
          w.Array(1, "transforms[].child_frame_id");
          w.Skip(7 * 8, "transforms[].transform");
        }
        break;
      }
    }
    if (w.left() != 0)
      throw Bad{std::to_string(w.left()) + " bytes left over after the last field"};
  } catch (const Bad& b) {
    return Status::Error(std::string(RosMessageKindName(kind)) + ": " + b.why);
  }
  return Status::Ok();
}

}  // namespace sweepscan::io
