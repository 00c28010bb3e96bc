// The file helpers the pairs file and the calibration file share; not part
// of the room's interface.
#ifndef SWEEPSCAN_CORE_CALIBRATION_FILE_INTERNAL_H_
#define SWEEPSCAN_CORE_CALIBRATION_FILE_INTERNAL_H_

#include <fstream>
#include <sstream>
#include <string>

#include "core/common/checked_file.h"
#include "core/common/json_reader.h"
#include "core/common/status.h"

namespace sweepscan::calibration_internal {

inline void CheckHeader(const JsonObject& root, const std::string& format) {
  if (root.String("format") != format) {
    root.Fail("format", "expected \"" + format + "\", got \"" + root.String("format") + "\"");
  }
  if (root.Integer("version") != 1) {
    root.Fail("version", "unsupported version " + std::to_string(root.Integer("version")));
  }
}

// ParseJson (core/common/json_reader.cc) catches only parse_error; a number that
// overflows a double ("1e999") throws out_of_range, so guard here.
inline Status ParseJsonNoThrow(const std::string& text, const std::string& source,
                               nlohmann::json* j) {
  try {
    return ParseJson(text, source, j);
  } catch (const nlohmann::json::exception& e) {
    return Status::Error(source + ": not valid JSON (" + e.what() + ")");
  }
}

inline Status ReadText(const std::string& path, std::string* text) {
  const Status regular = CheckRegularFile(path);  // A folder is a clear error, not an empty text.
  if (!regular.ok()) return regular;
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::Error(path + ": cannot open for reading");
  std::stringstream buffer;
  buffer << in.rdbuf();
  *text = buffer.str();
  return Status::Ok();
}

}  // namespace sweepscan::calibration_internal

#endif  // SWEEPSCAN_CORE_CALIBRATION_FILE_INTERNAL_H_
