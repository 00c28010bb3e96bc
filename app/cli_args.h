// A small strict command-line parser for the CLI tools: --flag, --key VALUE
// and --key=VALUE; unknown options and missing values are errors.
#ifndef SWEEPSCAN_APP_CLI_ARGS_H_
#define SWEEPSCAN_APP_CLI_ARGS_H_

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "app/cli_common.h"

namespace sweepscan::app {

class Args {
 public:
  // `flags` take no value, `options` take one.
  Args(const std::set<std::string>& flags, const std::set<std::string>& options)
      : flags_(flags), options_(options) {}

  bool Parse(int argc, char** argv, int first, std::string* error) {
    for (int i = first; i < argc; ++i) {
      std::string a = argv[i];
      if (a.rfind("--", 0) != 0) {
        positional_.push_back(a);
        continue;
      }
      std::string key = a.substr(2), value;
      const size_t eq = key.find('=');
      const bool has_value = eq != std::string::npos;
      if (has_value) {
        value = key.substr(eq + 1);
        key = key.substr(0, eq);
      }
      if (flags_.count(key)) {
        if (has_value) {
          *error = "option --" + key + " takes no value";
          return false;
        }
        set_flags_.insert(key);
      } else if (options_.count(key)) {
        if (!has_value) {
          // A missing value must not take the next option for it (`--out
          // --strict` wrote into a folder named --strict); a value that
          // starts with "--" can still be given as --key=--value.
          if (i + 1 >= argc || std::string(argv[i + 1]).rfind("--", 0) == 0) {
            *error = "option --" + key + " needs a value";
            return false;
          }
          value = argv[++i];
        }
        values_[key] = value;
      } else {
        *error = "unknown option --" + key;
        return false;
      }
    }
    return true;
  }

  bool Flag(const std::string& key) const { return set_flags_.count(key) > 0; }
  bool Has(const std::string& key) const { return values_.count(key) > 0; }
  std::string Get(const std::string& key, const std::string& fallback = "") const {
    const auto it = values_.find(key);
    return it == values_.end() ? fallback : it->second;
  }
  bool GetDouble(const std::string& key, double* out, std::string* error) const {
    if (!Has(key)) return true;
    const std::string v = Get(key);
    char* end = nullptr;
    const double d = std::strtod(v.c_str(), &end);
    if (v.empty() || *end != '\0' || !std::isfinite(d)) {
      *error = "option --" + key + " expects a number, got '" + v + "'";
      return false;
    }
    *out = d;
    return true;
  }
  // A whole number in [lo, hi], written in decimal digits (a count: "2.5",
  // "0x10" and "1e9" are refused, as is anything out of the range, which
  // would otherwise overflow or run for days).
  bool GetInteger(const std::string& key, int64_t lo, int64_t hi, int64_t* out,
                  std::string* error) const {
    if (!Has(key)) return true;
    const std::string v = Get(key);
    const size_t digits = v.find_first_not_of("0123456789", v[0] == '-' || v[0] == '+' ? 1 : 0);
    errno = 0;
    char* end = nullptr;
    const long long n = std::strtoll(v.c_str(), &end, 10);
    if (v.empty() || digits != std::string::npos || *end != '\0' || errno == ERANGE || n < lo ||
        n > hi) {
      *error = "option --" + key + " expects a whole number from " + std::to_string(lo) + " to " +
               std::to_string(hi) + ", got '" + v + "'";
      return false;
    }
    *out = n;
    return true;
  }
  const std::vector<std::string>& positional() const { return positional_; }
  // The first of `keys` that was given, "" if none.
  std::string FirstGiven(const std::set<std::string>& keys) const {
    for (const std::string& key : keys) {
      if (Flag(key) || Has(key)) return key;
    }
    return std::string();
  }
  // Every option given, flags and valued, by name.
  std::set<std::string> given() const {
    std::set<std::string> keys = set_flags_;
    for (const auto& [key, value] : values_) keys.insert(key);
    return keys;
  }

 private:
  std::set<std::string> flags_, options_, set_flags_;
  std::map<std::string, std::string> values_;
  std::vector<std::string> positional_;
};

// An option the command takes, but not for this input or mode, is refused
// rather than ignored (`plan cloud.ply --calibration c.json` drew the cloud
// as it was): one error line, "option --K does not apply to WHAT", and
// kExitBadInput; kExitOk if none of `keys` was given.
inline int RefuseOptions(const Args& args, const std::set<std::string>& keys,
                         const std::string& what) {
  const std::string key = args.FirstGiven(keys);
  if (key.empty()) return kExitOk;
  PrintError("option --" + key + " does not apply to " + what);
  return kExitBadInput;
}

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_CLI_ARGS_H_
