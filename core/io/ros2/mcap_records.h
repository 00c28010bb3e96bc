// The MCAP reader's building blocks (core/io/ros2/mcap.h): where the bytes
// come from (a file read with pread, or memory), bounds-checked reads of
// record fields (little-endian, https://mcap.dev/spec "Serialization"), the
// chunk decompressors and opcode names for messages. Internal to the ROS 2
// readers; not a public interface.
//
// Thread: each object is used from one thread.
#ifndef SWEEPSCAN_CORE_IO_ROS2_MCAP_RECORDS_H_
#define SWEEPSCAN_CORE_IO_ROS2_MCAP_RECORDS_H_

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/common/status.h"

struct ZSTD_DCtx_s;
struct LZ4F_dctx_s;

namespace sweepscan::io::mcap_internal {

// Random access to the file's bytes.
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  virtual uint64_t size() const = 0;
  virtual const std::string& name() const = 0;  // the path, or "<memory>"
  // Reads exactly n bytes at offset; the caller has checked that they lie in
  // the file (an error here is an I/O error or a file that shrank).
  virtual Status ReadAt(uint64_t offset, size_t n, uint8_t* out) = 0;
};

Status OpenFileSource(const std::string& path, std::unique_ptr<ByteSource>* source);
// Does not copy: data must outlive the source.
std::unique_ptr<ByteSource> MemorySource(const uint8_t* data, size_t n);

// Bounds-checked reads of one record's fields. Errors read
// "<where>: <field>: needs 8 bytes, 3 left at byte 17 of the record".
class Fields {
 public:
  Fields(const uint8_t* data, size_t n, std::string where)
      : data_(data), n_(n), where_(std::move(where)) {}
  Status U16(const char* field, uint16_t* v);
  Status U32(const char* field, uint32_t* v);
  Status U64(const char* field, uint64_t* v);
  Status String(const char* field, std::string* s);  // uint32 length + bytes
  Status Skip32(const char* field);                  // uint32 length + bytes, unread
  Status MapU16U64(const char* field, std::map<uint16_t, uint64_t>* m);
  const uint8_t* rest() const { return data_ + pos_; }
  size_t left() const { return n_ - pos_; }
  const std::string& where() const { return where_; }

 private:
  Status Need(const char* field, uint64_t n) const;
  const uint8_t* data_;
  size_t n_;
  size_t pos_ = 0;
  std::string where_;
};

// zstd and lz4 (frame format) chunk decompression, contexts kept between
// chunks. Output grows with what the data really decompresses to (never past
// `total`), so a lying uncompressed_size costs no memory.
class Decompressors {
 public:
  Decompressors() = default;
  ~Decompressors();
  Decompressors(const Decompressors&) = delete;
  Decompressors& operator=(const Decompressors&) = delete;
  // Decompresses all of in[0, n) into *out (resized to `total`); returns ""
  // or why not ("decompresses to more than the 4096 bytes the chunk says").
  std::string Run(const std::string& compression, const uint8_t* in, size_t n, uint64_t total,
                  std::vector<uint8_t>* out);

 private:
  std::string Zstd(const uint8_t* in, size_t n, uint64_t total, std::vector<uint8_t>* out);
  std::string Lz4(const uint8_t* in, size_t n, uint64_t total, std::vector<uint8_t>* out);
  ZSTD_DCtx_s* zstd_ = nullptr;
  LZ4F_dctx_s* lz4_ = nullptr;
};

// "Chunk", "Message", ..., "private record 0x80", "record 0x42".
std::string OpName(uint8_t op);

}  // namespace sweepscan::io::mcap_internal

#endif  // SWEEPSCAN_CORE_IO_ROS2_MCAP_RECORDS_H_
