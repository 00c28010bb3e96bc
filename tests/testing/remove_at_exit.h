// Files and folders a test process makes under the temporary directory,
// removed (with everything under them) when the process exits normally.
// CTest runs every test case as its own process, and the folders of this
// kind that each process named after its pid were never removed: /tmp held
// 4.9 GB of them on 2026-11-29 after a few weeks of runs. A test that
// crashes leaves its folder for a look.
#ifndef SWEEPSCAN_TESTS_TESTING_REMOVE_AT_EXIT_H_
#define SWEEPSCAN_TESTS_TESTING_REMOVE_AT_EXIT_H_

#include <filesystem>
#include <set>
#include <string>
#include <system_error>

namespace sweepscan::testing {

namespace remove_at_exit_internal {

// Destroyed with the process's other statics, after main returns.
struct Registry {
  std::set<std::string> paths;
  ~Registry() {
    std::error_code ignored;
    for (const std::string& p : paths) std::filesystem::remove_all(p, ignored);
  }
};

inline Registry& registry() {
  static Registry r;
  return r;
}

}  // namespace remove_at_exit_internal

// `path`, to be removed at exit (once, however often it is given).
inline const std::string& RemoveAtExit(const std::string& path) {
  remove_at_exit_internal::registry().paths.insert(path);
  return path;
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_REMOVE_AT_EXIT_H_
