// What the benchmark binary's files share (detector_bench.cc, decode_bench.cc):
// finding the shared data sets and their frames.
#ifndef LANE_BENCH_BENCH_FRAMES_H_
#define LANE_BENCH_BENCH_FRAMES_H_

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

namespace lane::bench {

// ../shared/data/<name>, looked for from the usual working directories, or
// $LANE_DATA_DIR/<name>; "" if absent.
inline std::string SharedDataDir(const std::string& name) {
  namespace fs = std::filesystem;
  for (const std::string root : {"../shared/data/", "../../shared/data/", "/work/shared/data/"}) {
    if (fs::is_directory(root + name)) return root + name;
  }
  if (const char* env = std::getenv("LANE_DATA_DIR")) {
    if (fs::is_directory(std::string(env) + "/" + name)) return std::string(env) + "/" + name;
  }
  return "";
}

// The files of `dir` whose extension is `ext` (".jpg"), sorted.
inline std::vector<std::string> FilesWithExtension(const std::string& dir, const std::string& ext) {
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().extension() == ext) files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace lane::bench

#endif  // LANE_BENCH_BENCH_FRAMES_H_
