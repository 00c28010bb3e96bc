#include "core/io/ros2/mcap_records.h"

#include <fcntl.h>
#include <lz4frame.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "core/io/ros2/mcap.h"

#include <zlib.h>

namespace sweepscan::io {

// MCAP's CRC is zlib's CRC-32 (ISO-HDLC); zlib's own, which runs several
// times faster than a byte-wise table (it was half the time of an MCAP
// import, docs/performance.md).
uint32_t McapCrc32(const uint8_t* data, size_t n, uint32_t crc) {
  return static_cast<uint32_t>(crc32_z(crc, data, n));
}

namespace mcap_internal {

namespace {

class FileSource : public ByteSource {
 public:
  FileSource(std::string path, int fd, uint64_t size)
      : path_(std::move(path)), fd_(fd), size_(size) {}
  ~FileSource() override { close(fd_); }
  uint64_t size() const override { return size_; }
  const std::string& name() const override { return path_; }
  Status ReadAt(uint64_t offset, size_t n, uint8_t* out) override {
    while (n > 0) {
      const ssize_t got = pread(fd_, out, n, static_cast<off_t>(offset));
      if (got < 0 && errno == EINTR) continue;
      if (got < 0) {
        return Status::Error(path_ + ": read failed at byte " + std::to_string(offset) + ": " +
                             strerror(errno));
      }
      if (got == 0) {
        return Status::Error(path_ + ": the file ends at byte " + std::to_string(offset) +
                             " (it was " + std::to_string(size_) + " bytes when opened)");
      }
      out += got;
      offset += static_cast<uint64_t>(got);
      n -= static_cast<size_t>(got);
    }
    return Status::Ok();
  }

 private:
  std::string path_;
  int fd_;
  uint64_t size_;
};

class MemSource : public ByteSource {
 public:
  MemSource(const uint8_t* data, size_t n) : data_(data), n_(n) {}
  uint64_t size() const override { return n_; }
  const std::string& name() const override { return name_; }
  Status ReadAt(uint64_t offset, size_t n, uint8_t* out) override {
    if (offset > n_ || n > n_ - offset) {
      return Status::Error(name_ + ": read past the end at byte " + std::to_string(offset));
    }
    if (n > 0) memcpy(out, data_ + offset, n);
    return Status::Ok();
  }

 private:
  const uint8_t* data_;
  size_t n_;
  std::string name_ = "<memory>";
};

}  // namespace

Status OpenFileSource(const std::string& path, std::unique_ptr<ByteSource>* source) {
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Status::Error(path + ": cannot open for reading: " + strerror(errno));
  struct stat st;
  if (fstat(fd, &st) != 0) {
    const int e = errno;
    close(fd);
    return Status::Error(path + ": cannot stat: " + strerror(e));
  }
  if (!S_ISREG(st.st_mode)) {
    close(fd);
    return Status::Error(path + (S_ISDIR(st.st_mode) ? ": is a folder" : ": not a regular file"));
  }
  *source = std::make_unique<FileSource>(path, fd, static_cast<uint64_t>(st.st_size));
  return Status::Ok();
}

std::unique_ptr<ByteSource> MemorySource(const uint8_t* data, size_t n) {
  return std::make_unique<MemSource>(data, n);
}

Status Fields::Need(const char* field, uint64_t n) const {
  if (n <= n_ - pos_) return Status::Ok();
  return Status::Error(where_ + ": " + field + ": needs " + std::to_string(n) + " bytes, " +
                       std::to_string(n_ - pos_) + " left at byte " + std::to_string(pos_) +
                       " of the record");
}

// MCAP is little-endian on the wire; so are all hosts this builds for.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "MCAP fields are read as stored");

Status Fields::U16(const char* field, uint16_t* v) {
  Status s = Need(field, 2);
  if (s.ok()) memcpy(v, data_ + pos_, 2), pos_ += 2;
  return s;
}

Status Fields::U32(const char* field, uint32_t* v) {
  Status s = Need(field, 4);
  if (s.ok()) memcpy(v, data_ + pos_, 4), pos_ += 4;
  return s;
}

Status Fields::U64(const char* field, uint64_t* v) {
  Status s = Need(field, 8);
  if (s.ok()) memcpy(v, data_ + pos_, 8), pos_ += 8;
  return s;
}

Status Fields::String(const char* field, std::string* str) {
  uint32_t n;
  Status s = U32(field, &n);
  if (s.ok()) s = Need(field, n);
  if (s.ok()) str->assign(reinterpret_cast<const char*>(data_ + pos_), n), pos_ += n;
  return s;
}

Status Fields::Skip32(const char* field) {
  uint32_t n;
  Status s = U32(field, &n);
  if (s.ok()) s = Need(field, n);
  if (s.ok()) pos_ += n;
  return s;
}

Status Fields::MapU16U64(const char* field, std::map<uint16_t, uint64_t>* m) {
  uint32_t n;
  Status s = U32(field, &n);
  if (s.ok()) s = Need(field, n);
  if (!s.ok()) return s;
  if (n % 10 != 0) {
    return Status::Error(where_ + ": " + field + ": " + std::to_string(n) +
                         " bytes are not a whole number of (uint16, uint64) entries");
  }
  for (uint32_t i = 0; i < n; i += 10) {
    uint16_t key;
    uint64_t value;
    memcpy(&key, data_ + pos_ + i, 2);
    memcpy(&value, data_ + pos_ + i + 2, 8);
    (*m)[key] = value;
  }
  pos_ += n;
  return Status::Ok();
}

namespace {

// Output grows in steps of this (up to the chunk's uncompressed_size).
constexpr size_t kGrowStep = size_t{1} << 20;

// Makes room for more output: returns false when `total` is reached.
bool Grow(size_t produced, uint64_t total, std::vector<uint8_t>* out) {
  if (produced < out->size()) return true;
  if (out->size() >= total) return false;
  const uint64_t next = std::max<uint64_t>(out->size() * 2, kGrowStep);
  out->resize(static_cast<size_t>(std::min<uint64_t>(next, total)));
  return true;
}

std::string SizeMismatch(size_t produced, uint64_t total) {
  return "decompresses to " + std::to_string(produced) + " bytes, the chunk says " +
         std::to_string(total);
}

}  // namespace

Decompressors::~Decompressors() {
  if (zstd_ != nullptr) ZSTD_freeDCtx(zstd_);
  if (lz4_ != nullptr) LZ4F_freeDecompressionContext(lz4_);
}

std::string Decompressors::Run(const std::string& compression, const uint8_t* in, size_t n,
                               uint64_t total, std::vector<uint8_t>* out) {
  out->clear();
  if (compression == "zstd") return Zstd(in, n, total, out);
  if (compression == "lz4") return Lz4(in, n, total, out);
  return "unknown compression '" + compression + "'";
}

std::string Decompressors::Zstd(const uint8_t* in, size_t n, uint64_t total,
                                std::vector<uint8_t>* out) {
  if (zstd_ == nullptr && (zstd_ = ZSTD_createDCtx()) == nullptr) return "out of memory";
  ZSTD_DCtx_reset(zstd_, ZSTD_reset_session_only);
  // A first frame that states its content size must fit the chunk (the
  // output is bounded anyway; this only gives the clearer message).
  const unsigned long long declared = ZSTD_getFrameContentSize(in, n);
  if (declared == ZSTD_CONTENTSIZE_ERROR) return "does not start with a zstd frame";
  if (declared != ZSTD_CONTENTSIZE_UNKNOWN && declared > total) {
    return "the zstd frame holds " + std::to_string(declared) + " bytes, the chunk says " +
           std::to_string(total);
  }
  ZSTD_inBuffer input{in, n, 0};
  size_t produced = 0;
  for (;;) {
    const bool room = Grow(produced, total, out);
    ZSTD_outBuffer output{out->data(), out->size(), produced};
    const size_t in_before = input.pos;
    const size_t r = ZSTD_decompressStream(zstd_, &output, &input);
    if (ZSTD_isError(r)) return ZSTD_getErrorName(r);
    const bool progress = input.pos != in_before || output.pos != produced;
    produced = output.pos;
    if (r == 0 && input.pos == input.size) break;  // every frame complete
    if (!progress) {
      return room ? "the zstd data ends inside a frame"
                  : "decompresses to more than the " + std::to_string(total) +
                        " bytes the chunk says";
    }
  }
  return produced == total ? "" : SizeMismatch(produced, total);
}

std::string Decompressors::Lz4(const uint8_t* in, size_t n, uint64_t total,
                               std::vector<uint8_t>* out) {
  if (lz4_ == nullptr && LZ4F_isError(LZ4F_createDecompressionContext(&lz4_, LZ4F_VERSION))) {
    lz4_ = nullptr;
    return "out of memory";
  }
  LZ4F_resetDecompressionContext(lz4_);
  size_t consumed = 0, produced = 0;
  for (;;) {
    const bool room = Grow(produced, total, out);
    size_t dst_n = out->size() - produced;
    size_t src_n = n - consumed;
    const size_t r =
        LZ4F_decompress(lz4_, out->data() + produced, &dst_n, in + consumed, &src_n, nullptr);
    if (LZ4F_isError(r)) {
      LZ4F_resetDecompressionContext(lz4_);
      return LZ4F_getErrorName(r);
    }
    consumed += src_n;
    produced += dst_n;
    if (r == 0 && consumed == n) break;  // frame complete, input used up
    if (src_n == 0 && dst_n == 0) {
      LZ4F_resetDecompressionContext(lz4_);
      return room ? "the lz4 data ends inside a frame"
                  : "decompresses to more than the " + std::to_string(total) +
                        " bytes the chunk says";
    }
  }
  return produced == total ? "" : SizeMismatch(produced, total);
}

std::string OpName(uint8_t op) {
  static const char* const kNames[] = {nullptr,      "Header",           "Footer",
                                       "Schema",     "Channel",          "Message",
                                       "Chunk",      "Message Index",    "Chunk Index",
                                       "Attachment", "Attachment Index", "Statistics",
                                       "Metadata",   "Metadata Index",   "Summary Offset",
                                       "Data End"};
  if (op >= 1 && op <= 0x0F) return kNames[op];
  char text[32];
  snprintf(text, sizeof(text), "%s 0x%02x", op >= 0x80 ? "private record" : "record", op);
  return text;
}

}  // namespace mcap_internal

}  // namespace sweepscan::io
