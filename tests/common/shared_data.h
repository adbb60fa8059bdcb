// ../shared/data's clips for the tests that use them when present.
#ifndef LANE_TESTS_COMMON_SHARED_DATA_H_
#define LANE_TESTS_COMMON_SHARED_DATA_H_

#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

namespace lane::testing {

// ../shared/data/<clip> beside the source tree, else $LANE_DATA_DIR/<clip>;
// "" if neither holds it (the caller skips with a message).
inline std::string FindSharedClip(const std::string& clip) {
  namespace fs = std::filesystem;
  std::vector<fs::path> roots = {fs::path(LANE_SOURCE_DIR) / ".." / "shared" / "data"};
  if (const char* env = std::getenv("LANE_DATA_DIR"); env != nullptr && *env != '\0') {
    roots.emplace_back(env);
  }
  for (const fs::path& root : roots) {
    std::error_code ec;
    if (fs::is_directory(root / clip, ec)) return (root / clip).lexically_normal().string();
  }
  return "";
}

}  // namespace lane::testing

#endif  // LANE_TESTS_COMMON_SHARED_DATA_H_
