// The little-endian fields of frames.bin (docs/session-format.md) and the
// way its messages name a record; shared by the session's reader and writer.
#ifndef SWEEPSCAN_CORE_SESSION_FRAMES_BYTES_H_
#define SWEEPSCAN_CORE_SESSION_FRAMES_BYTES_H_

#include <cstdint>
#include <string>

namespace sweepscan::session_internal {

inline uint32_t GetU32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 |
         static_cast<uint32_t>(p[2]) << 16 | static_cast<uint32_t>(p[3]) << 24;
}
inline int64_t GetI64(const uint8_t* p) {
  return static_cast<int64_t>(static_cast<uint64_t>(GetU32(p)) |
                              static_cast<uint64_t>(GetU32(p + 4)) << 32);
}
// "record 9375 at byte 1142649": records counted from 0, skipped ones too.
inline std::string RecordAt(uint64_t index, uint64_t offset) {
  return "record " + std::to_string(index) + " at byte " + std::to_string(offset);
}

}  // namespace sweepscan::session_internal

#endif  // SWEEPSCAN_CORE_SESSION_FRAMES_BYTES_H_
