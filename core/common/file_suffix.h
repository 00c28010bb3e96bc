// A file name's suffix, as the CLI and the readers choose formats by it:
// case-insensitively (".PLY", ".Las" as ".ply", ".las"), as the operator
// expects of a file system that keeps the case a camera or a colleague used.
//
// Pure function; any thread.
#ifndef SWEEPSCAN_CORE_COMMON_FILE_SUFFIX_H_
#define SWEEPSCAN_CORE_COMMON_FILE_SUFFIX_H_

#include <cctype>
#include <string>
#include <string_view>

namespace sweepscan {

// `lower_suffix` in lower case, e.g. ".las".
inline bool HasFileSuffix(std::string_view path, std::string_view lower_suffix) {
  if (path.size() < lower_suffix.size()) return false;
  const std::string_view tail = path.substr(path.size() - lower_suffix.size());
  for (size_t i = 0; i < tail.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(tail[i])) != lower_suffix[i]) return false;
  }
  return true;
}

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_COMMON_FILE_SUFFIX_H_
