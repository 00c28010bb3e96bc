// A value read from a file, fit to be said in an error message: a damaged
// file can hold any bytes, and an error line that echoes them raw can hold
// terminal escapes, line breaks or megabytes of one line.
#ifndef SWEEPSCAN_CORE_COMMON_QUOTED_H_
#define SWEEPSCAN_CORE_COMMON_QUOTED_H_

#include <nlohmann/json.hpp>
#include <string>

namespace sweepscan {

// As a JSON string (RFC 8259 §7): in double quotes, control characters and
// anything not ASCII as \uXXXX escapes, bytes that are not UTF-8 as U+FFFD;
// cut to `max_bytes` of the value (between UTF-8 characters) with "..."
// after the closing quote.
inline std::string Quoted(const std::string& value, size_t max_bytes = 80) {
  const bool cut = value.size() > max_bytes;
  size_t n = cut ? max_bytes : value.size();
  for (int back = 0;
       cut && back < 3 && n > 0 && (static_cast<unsigned char>(value[n]) & 0xC0) == 0x80; ++back)
    --n;
  const std::string kept = value.substr(0, n);
  return nlohmann::json(kept).dump(-1, ' ', /*ensure_ascii=*/true,
                                   nlohmann::json::error_handler_t::replace) +
         (cut ? "..." : "");
}

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_COMMON_QUOTED_H_
