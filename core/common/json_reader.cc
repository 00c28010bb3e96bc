#include "core/common/json_reader.h"

#include <fcntl.h>
#include <unistd.h>

#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "core/common/checked_file.h"

namespace sweepscan {

std::string JsonTypeName(const nlohmann::json& j) {
  if (j.is_null()) return "null";
  if (j.is_boolean()) return "a boolean";
  if (j.is_number()) return "a number";
  if (j.is_string()) return "a string";
  if (j.is_array()) return "an array";
  return "an object";
}

JsonObject::JsonObject(const nlohmann::json& j, std::string path) : j_(j), path_(std::move(path)) {
  if (!j_.is_object()) {
    throw JsonError((path_.empty() ? std::string("document") : path_) + ": expected an object, got " +
                    JsonTypeName(j_));
  }
}

void JsonObject::Fail(const std::string& key, const std::string& message) const {
  throw JsonError(Path(key) + ": " + message);
}

const nlohmann::json& JsonObject::Get(const std::string& key) const {
  const auto it = j_.find(key);
  if (it == j_.end()) Fail(key, "missing");
  return *it;
}

JsonObject JsonObject::Object(const std::string& key) const { return JsonObject(Get(key), Path(key)); }

const nlohmann::json& JsonObject::Array(const std::string& key) const {
  const nlohmann::json& v = Get(key);
  if (!v.is_array()) Fail(key, "expected an array, got " + JsonTypeName(v));
  return v;
}

double JsonObject::Number(const std::string& key) const {
  const nlohmann::json& v = Get(key);
  if (!v.is_number()) Fail(key, "expected a number, got " + JsonTypeName(v));
  const double d = v.get<double>();
  if (!std::isfinite(d)) Fail(key, "must be finite");
  return d;
}

static std::string Str(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

double JsonObject::Positive(const std::string& key) const {
  const double d = Number(key);
  if (!(d > 0.0)) Fail(key, "must be > 0, got " + Str(d));
  return d;
}

double JsonObject::NonNegative(const std::string& key, double fallback) const {
  if (!Has(key)) return fallback;
  const double d = Number(key);
  if (!(d >= 0.0)) Fail(key, "must be >= 0, got " + Str(d));
  return d;
}

double JsonObject::InRange(const std::string& key, double lo, double hi, double fallback) const {
  if (!Has(key)) return fallback;
  const double d = Number(key);
  if (!(d >= lo && d <= hi)) Fail(key, "must be within [" + Str(lo) + ", " + Str(hi) + "], got " + Str(d));
  return d;
}

int64_t JsonObject::Integer(const std::string& key) const {
  const nlohmann::json& v = Get(key);
  if (!v.is_number_integer()) Fail(key, "expected an integer, got " + JsonTypeName(v));
  // Above 2^63 - 1 the parser keeps it unsigned, and as int64 it would wrap
  // ("unsupported version -1", "sample at time -1 ns").
  if (v.is_number_unsigned() && v.get<uint64_t>() > static_cast<uint64_t>(INT64_MAX)) {
    Fail(key, "out of range, got " + std::to_string(v.get<uint64_t>()));
  }
  return v.get<int64_t>();
}

uint64_t JsonObject::Count(const std::string& key) const {
  const nlohmann::json& v = Get(key);
  if (v.is_number_unsigned()) return v.get<uint64_t>();
  if (!v.is_number_integer()) Fail(key, "expected a whole number >= 0, got " + JsonTypeName(v));
  Fail(key, "must be >= 0, got " + std::to_string(v.get<int64_t>()));
}

bool JsonObject::Bool(const std::string& key, bool fallback) const {
  if (!Has(key)) return fallback;
  const nlohmann::json& v = Get(key);
  if (!v.is_boolean()) Fail(key, "expected a boolean, got " + JsonTypeName(v));
  return v.get<bool>();
}

std::string JsonObject::String(const std::string& key) const {
  const nlohmann::json& v = Get(key);
  if (!v.is_string()) Fail(key, "expected a string, got " + JsonTypeName(v));
  return v.get<std::string>();
}

void JsonObject::AllowOnly(const std::set<std::string>& keys) const {
  for (auto it = j_.begin(); it != j_.end(); ++it) {
    if (!keys.count(it.key())) Fail(it.key(), "unknown key");
  }
}

namespace {
// Deeper than any file of ours nests (a scenario: 5 levels): a value nested
// 200 000 deep parses, but copying or printing it recurses once a level and
// overflows the stack.
constexpr int kMaxJsonDepth = 64;
struct TooDeep {};
struct DuplicateKey {
  std::string key;
};
}  // namespace

Status ParseJson(const std::string& text, const std::string& source, nlohmann::json* out) {
  // The keys seen in each open object: a key given twice is refused, not
  // resolved by the parser to its last value (a hand edit that added
  // "gamma" again would have been used silently).
  std::vector<std::set<std::string>> keys;
  try {
    using Event = nlohmann::json::parse_event_t;
    *out = nlohmann::json::parse(text, [&keys](int depth, Event event, nlohmann::json& parsed) {
      if (depth > kMaxJsonDepth && (event == Event::object_start || event == Event::array_start)) {
        throw TooDeep();
      }
      if (event == Event::object_start) keys.emplace_back();
      if (event == Event::object_end && !keys.empty()) keys.pop_back();
      if (event == Event::key && !keys.empty() &&
          !keys.back().insert(parsed.get<std::string>()).second) {
        throw DuplicateKey{parsed.get<std::string>()};
      }
      return true;
    });
  } catch (const TooDeep&) {
    return Status::Error(source + ": not a file of ours (values nested more than " +
                         std::to_string(kMaxJsonDepth) + " deep)");
  } catch (const DuplicateKey& d) {
    return Status::Error(source + ": not a file of ours (the key '" + d.key +
                         "' appears twice in one object)");
  } catch (const nlohmann::json::parse_error& e) {
    // Translate the byte offset into line:column for the operator.
    size_t line = 1, col = 1;
    for (size_t i = 0; i + 1 < e.byte && i < text.size(); ++i) {
      if (text[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
    std::string what = e.what();
    const size_t pos = what.find("parse error");
    return Status::Error(source + ":" + std::to_string(line) + ":" + std::to_string(col) +
                         ": not valid JSON (" + (pos == std::string::npos ? what : what.substr(pos)) +
                         ")");
  } catch (const nlohmann::json::exception& e) {
    // e.g. a number too large for a double (1e999).
    return Status::Error(source + ": not valid JSON (" + e.what() + ")");
  }
  return Status::Ok();
}

Status ReadJsonFile(const std::string& path, nlohmann::json* out) {
  const Status regular = CheckRegularFile(path);
  if (!regular.ok()) return regular;
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::Error(path + ": cannot open for reading");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return ParseJson(buffer.str(), path, out);
}

Status WriteFileAtomically(const std::string& path, const std::string& contents) {
  return WriteFileChecked(path, contents);
}

}  // namespace sweepscan
