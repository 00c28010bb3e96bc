#include "app/cli_outputs.h"

#include <filesystem>
#include <system_error>

#include "app/cli_common.h"

namespace sweepscan::app {
namespace {

namespace fs = std::filesystem;

// Where `path` is, with links and "..": an output need not exist yet.
fs::path Resolved(const std::string& path) {
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  return ec ? fs::path(path).lexically_normal() : p;
}

// One file under two names: the same resolved path, or (both existing)
// the same inode, a hard link included (calibrate's check had caught it).
bool SameFile(const std::string& a, const fs::path& resolved_a, const std::string& b,
              const fs::path& resolved_b) {
  if (resolved_a == resolved_b) return true;
  std::error_code ec;
  return fs::exists(a, ec) && fs::exists(b, ec) && fs::equivalent(a, b, ec);
}

bool Inside(const fs::path& file, const fs::path& folder) {
  for (fs::path p = file.parent_path(); !p.empty(); p = p.parent_path()) {
    if (p == folder) return true;
    if (p == p.parent_path()) break;
  }
  return false;
}

}  // namespace

std::string OutputOverInput(const std::vector<CommandOutput>& outputs,
                            const std::vector<CommandInput>& inputs) {
  for (size_t i = 0; i < outputs.size(); ++i) {
    const CommandOutput& out = outputs[i];
    if (out.path.empty()) continue;
    const fs::path target = Resolved(out.path);
    for (const CommandInput& in : inputs) {
      if (in.path.empty()) continue;
      const fs::path source = Resolved(in.path);
      if (in.folder) {
        if (target == source || Inside(target, source)) {
          return out.option + " " + out.path + " is inside " + in.what + ": write it elsewhere";
        }
      } else if (SameFile(out.path, target, in.path, source)) {
        return out.option + " " + out.path + " is " + in.what + ": it would be replaced";
      }
    }
    for (size_t j = 0; j < i; ++j) {
      if (!outputs[j].path.empty() &&
          SameFile(outputs[j].path, Resolved(outputs[j].path), out.path, target)) {
        return out.option + " " + out.path + " is also " + outputs[j].option +
               "'s file: give each output its own";
      }
    }
  }
  return std::string();
}

int RefuseOutputOverInput(const std::vector<CommandOutput>& outputs,
                          const std::vector<CommandInput>& inputs) {
  const std::string why = OutputOverInput(outputs, inputs);
  if (why.empty()) return kExitOk;
  PrintError(why);
  return kExitBadInput;
}

}  // namespace sweepscan::app
