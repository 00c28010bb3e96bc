// Strict reading of JSON documents (scenarios, calibrations, pick files):
// every value is checked for presence, type and range, unknown keys are
// refused (they are usually typos), and the first problem is reported with
// the file and the JSON path, e.g.
//   lab.json: robot.wheel_distance_m: must be > 0, got -0.15
#ifndef SWEEPSCAN_CORE_COMMON_JSON_READER_H_
#define SWEEPSCAN_CORE_COMMON_JSON_READER_H_

#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <string>

#include "core/common/status.h"

namespace sweepscan {

class JsonError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A view of one JSON object at a path. Throws JsonError on the first problem.
class JsonObject {
 public:
  JsonObject(const nlohmann::json& j, std::string path);

  bool Has(const std::string& key) const { return j_.contains(key); }
  JsonObject Object(const std::string& key) const;
  const nlohmann::json& Array(const std::string& key) const;
  std::string Path(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  const std::string& path() const { return path_; }

  double Number(const std::string& key) const;
  double Number(const std::string& key, double fallback) const {
    return Has(key) ? Number(key) : fallback;
  }
  double Positive(const std::string& key) const;
  double Positive(const std::string& key, double fallback) const {
    return Has(key) ? Positive(key) : fallback;
  }
  double NonNegative(const std::string& key, double fallback) const;
  double InRange(const std::string& key, double lo, double hi, double fallback) const;
  int64_t Integer(const std::string& key) const;
  // A whole number >= 0 up to 2^64 - 1 (an int64 read of one above 2^63 would
  // wrap negative).
  uint64_t Count(const std::string& key) const;
  bool Bool(const std::string& key, bool fallback) const;
  std::string String(const std::string& key) const;
  std::string String(const std::string& key, const std::string& fallback) const {
    return Has(key) ? String(key) : fallback;
  }

  // Refuses keys that were never declared by the caller.
  void AllowOnly(const std::set<std::string>& keys) const;

  [[noreturn]] void Fail(const std::string& key, const std::string& message) const;

 private:
  const nlohmann::json& Get(const std::string& key) const;
  const nlohmann::json& j_;
  std::string path_;
};

std::string JsonTypeName(const nlohmann::json& j);

// Parses text; on a syntax error the message gives line and column.
Status ParseJson(const std::string& text, const std::string& source, nlohmann::json* out);
Status ReadJsonFile(const std::string& path, nlohmann::json* out);

// Writes text to path atomically: a temporary file in the same folder,
// flushed to disk, then renamed over the target, so a crash never leaves a
// half-written file in place of a good one.
Status WriteFileAtomically(const std::string& path, const std::string& contents);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_COMMON_JSON_READER_H_
