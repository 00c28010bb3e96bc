// Numbers as text for files, whatever the C locale: printf's "%.3f" writes a
// comma under de_DE and the like, and the desktop app runs under the user's
// locale (QApplication calls setlocale(LC_ALL, "")), so a drawing written
// from it would read "1,500000" where DXF and SVG need "1.500000".
// std::to_chars never consults the locale.
#ifndef SWEEPSCAN_CORE_COMMON_FORMAT_NUMBER_H_
#define SWEEPSCAN_CORE_COMMON_FORMAT_NUMBER_H_

#include <charconv>
#include <string>

namespace sweepscan {

// As printf("%.*f", decimals, v), with '.' always.
inline std::string FormatFixed(double v, int decimals) {
  char buf[352];  // DBL_MAX in fixed notation is 309 digits.
  const auto r = std::to_chars(buf, buf + sizeof(buf), v, std::chars_format::fixed, decimals);
  return r.ec == std::errc() ? std::string(buf, r.ptr) : std::string("nan");
}

// As printf("%g", v), with '.' always.
inline std::string FormatGeneral(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v, std::chars_format::general, 6);
  return r.ec == std::errc() ? std::string(buf, r.ptr) : std::string("nan");
}

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_COMMON_FORMAT_NUMBER_H_
