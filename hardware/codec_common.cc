#include "hardware/codec_common.h"

#include <cstring>
#include <sstream>

namespace sweepscan {
namespace hardware {

std::string DecoderStats::ToString() const {
  std::ostringstream s;
  s << "bytes_in=" << bytes_in << " bytes_in_frames=" << bytes_in_frames
    << " frames_ok=" << frames_ok << " bytes_skipped=" << bytes_skipped
    << " checksum_errors=" << checksum_errors << " length_errors=" << length_errors
    << " framing_errors=" << framing_errors << " payload_errors=" << payload_errors;
  return s.str();
}

// memcpy, not a pointer cast: the fields are unaligned and the host is assumed
// little-endian IEEE 754 (static_assert below guards the size).
float ReadF32Le(const uint8_t* p) {
  static_assert(sizeof(float) == 4, "float must be 32-bit IEEE 754");
  const uint32_t bits = ReadU32Le(p);
  float v;
  std::memcpy(&v, &bits, sizeof(v));
  return v;
}

void AppendF32Le(float v, std::vector<uint8_t>* out) {
  uint32_t bits;
  std::memcpy(&bits, &v, sizeof(bits));
  AppendU32Le(bits, out);
}

}  // namespace hardware
}  // namespace sweepscan
