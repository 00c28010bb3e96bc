#include "core/io/rosbag1/rosbag1_check.h"

#include <bzlib.h>
#include <fcntl.h>
#include <roslz4/lz4s.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <map>
#include <vector>

namespace sweepscan::io {
namespace {

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr size_t kMagicSize = sizeof(kMagic) - 1;
// A chunk's decompressed size: rosbag record's default threshold is 768 KB;
// a chunk claiming more than this is a corrupt length, not a recording.
constexpr uint32_t kMaxChunkBytes = 1u << 30;

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

// The chunk's data decompressed as its `compression` says, to exactly
// `size` bytes.
std::vector<uint8_t> Decompress(const std::string& compression, const uint8_t* data, uint32_t len,
                                uint32_t size) {
  if (size > kMaxChunkBytes) {
    throw Bad{"the chunk claims " + std::to_string(size) + " bytes decompressed (at most " +
              std::to_string(kMaxChunkBytes) + " read)"};
  }
  std::vector<uint8_t> out(size);
  if (compression == "none") {
    if (len != size) {
      throw Bad{"an uncompressed chunk of " + std::to_string(len) + " bytes claims " +
                std::to_string(size)};
    }
    std::memcpy(out.data(), data, size);
    return out;
  }
  // Both libraries take non-const input they do not write.
  char* in = const_cast<char*>(reinterpret_cast<const char*>(data));
  unsigned int got = size;
  if (compression == "bz2") {
    const int rc =
        BZ2_bzBuffToBuffDecompress(reinterpret_cast<char*>(out.data()), &got, in, len, 0, 0);
    if (rc != BZ_OK)
      throw Bad{"its bz2 data do not decompress (bzip2 error " + std::to_string(rc) + ")"};
  } else if (compression == "lz4") {
    const int rc = roslz4_buffToBuffDecompress(in, len, reinterpret_cast<char*>(out.data()), &got);
    if (rc != ROSLZ4_OK)
      throw Bad{"its lz4 data do not decompress (roslz4 error " + std::to_string(rc) + ")"};
  } else {
    throw Bad{"unknown chunk compression '" + compression + "' (none, bz2, lz4)"};
  }
  if (got != size) {
    throw Bad{"the chunk decompresses to " + std::to_string(got) + " bytes, its header says " +
              std::to_string(size)};
  }
  return out;
}

Status CheckRosbag1(Source* source, const std::string& name) {
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
    // The records in order: chunks, each followed by its index data; from
    // index_pos the connections and then the chunk infos.
    // Each chunk's start -> its index data's entries per connection.
    std::map<uint64_t, std::map<uint32_t, uint32_t>> chunk_index;
    uint64_t last_chunk = 0;
    std::map<uint32_t, uint32_t> messages;  // the last chunk's: offset -> conn
    bool index_started = false;
    uint32_t index_connections = 0, index_chunks = 0;
    for (at = header.end; at < size;) {
      const Record r = ReadRecord(source, at);
      const auto data = [&] { return source->Read(r.data_at, r.data_len); };
      if (at > index_pos && !index_started) {
        throw Bad{"the index position " + std::to_string(index_pos) + " is not a record's start"};
      }
      if (at < index_pos) {
        if (r.op == kChunk) {
          const uint32_t decompressed = FieldU32(r.fields, "size");
          const std::vector<uint8_t> chunk =
              Decompress(Field(r.fields, "compression", 0), data(), r.data_len, decompressed);
          messages.clear();
          WalkChunk(chunk.data(), chunk.size(), &messages);
          chunk_index[at];
          last_chunk = at;
        } else if (r.op == kIndexData) {
          if (chunk_index.empty()) throw Bad{"index data before any chunk"};
          if (FieldU32(r.fields, "ver") != 1) throw Bad{"index data of a version other than 1"};
          const uint32_t conn = FieldU32(r.fields, "conn");
          const uint32_t count = FieldU32(r.fields, "count");
          if (static_cast<uint64_t>(count) * 12 != r.data_len) {
            throw Bad{"index data of " + std::to_string(count) + " entries in " +
                      std::to_string(r.data_len) + " bytes (12 an entry)"};
          }
          if (!chunk_index[last_chunk].emplace(conn, count).second) {
            throw Bad{"a second index data record of connection " + std::to_string(conn) +
                      " for one chunk"};
          }
          const uint8_t* entries = data();
          for (uint32_t k = 0; k < count; ++k) {
            const uint32_t offset = U32(entries + 12 * k + 8);
            const auto m = messages.find(offset);
            if (m == messages.end()) {
              throw Bad{"index entry " + std::to_string(k) + " points at byte " +
                        std::to_string(offset) + " of its chunk, where no message record starts"};
            }
            if (m->second != conn) {
              throw Bad{"index entry " + std::to_string(k) + " of connection " +
                        std::to_string(conn) + " points at a message of connection " +
                        std::to_string(m->second)};
            }
          }
        } else if (r.op == kConnection) {
          // Written before the index by some writers too: checked alike.
          FieldU32(r.fields, "conn");
          ParseFields(data(), r.data_len);
        } else {
          throw Bad{"a record of type " + std::to_string(r.op) + " before the index"};
        }
      } else {
        index_started = true;
        if (r.op == kConnection) {
          if (index_chunks > 0) throw Bad{"a connection after the chunk infos"};
          FieldU32(r.fields, "conn");
          Field(r.fields, "topic", 0);
          ParseFields(data(), r.data_len);
          ++index_connections;
        } else if (r.op == kChunkInfo) {
          if (FieldU32(r.fields, "ver") != 1) throw Bad{"chunk info of a version other than 1"};
          const uint64_t chunk_pos = FieldU64(r.fields, "chunk_pos");
          FieldU64(r.fields, "start_time");
          FieldU64(r.fields, "end_time");
          const uint32_t count = FieldU32(r.fields, "count");
          if (static_cast<uint64_t>(count) * 8 != r.data_len) {
            throw Bad{"chunk info of " + std::to_string(count) + " connections in " +
                      std::to_string(r.data_len) + " bytes (8 a connection)"};
          }
          const auto c = chunk_index.find(chunk_pos);
          if (c == chunk_index.end()) {
            throw Bad{"chunk info for byte " + std::to_string(chunk_pos) +
                      ", where no chunk starts"};
          }
          // rosbag reads as many index data records after the chunk as
          // the chunk info names connections, each with its count.
          if (c->second.size() != count) {
            throw Bad{"chunk info for byte " + std::to_string(chunk_pos) + " names " +
                      std::to_string(count) + " connections, the chunk has index data for " +
                      std::to_string(c->second.size())};
          }
          const uint8_t* entries = data();
          for (uint32_t k = 0; k < count; ++k) {
            const uint32_t conn = U32(entries + 8 * k), n = U32(entries + 8 * k + 4);
            const auto e = c->second.find(conn);
            if (e == c->second.end() || e->second != n) {
              throw Bad{"chunk info for byte " + std::to_string(chunk_pos) + ": connection " +
                        std::to_string(conn) + " with " + std::to_string(n) +
                        " messages, which its index data do not say"};
            }
          }
          ++index_chunks;
        } else {
          throw Bad{"a record of type " + std::to_string(r.op) + " in the index"};
        }
      }
      at = r.end;
    }
    if (index_connections != connections || index_chunks != chunks) {
      at = size;
      throw Bad{"the bag header counts " + std::to_string(connections) + " connections and " +
                std::to_string(chunks) + " chunks, the index holds " +
                std::to_string(index_connections) + " and " + std::to_string(index_chunks)};
    }
  } catch (const Bad& b) {
    return Status::Error(name + ": damaged ROS 1 bag at byte " + std::to_string(at) + ": " + b.why);
  }
  return Status::Ok();
}

}  // namespace

Status CheckRosbag1Image(const uint8_t* data, size_t size, const std::string& name) {
  MemorySource source(data, size);
  return CheckRosbag1(&source, name);
}

Status CheckRosbag1File(const std::string& path) {
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
    s = CheckRosbag1(&source, path);
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
