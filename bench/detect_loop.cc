// detect_loop: runs the detector over frames in a loop, for profilers.
//
//   detect_loop CONFIG PASSES FRAME...
//
// Frames (JPEG or PNG) are decoded once with lane_decode; then every frame is
// detected PASSES times in turn, and the median detection time is printed.
// Only the OpenCV core and imgproc modules are linked (no imgcodecs, whose
// dependencies valgrind cannot run), so that instruction counts are
// repeatable on a busy machine:
//   valgrind --tool=callgrind
//     --toggle-collect='lane::Detector::Detect(cv::Mat const&) const'
//     build/bench/detect_loop configs/caltech.json 1 FRAMES...
// and `perf record build/bench/detect_loop ...` profiles detection alone.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "lane/config/config.h"
#include "lane/decode/image_decoder.h"
#include "lane/detector/detector.h"

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s CONFIG PASSES FRAME...\n", argv[0]);
    return 2;
  }
  auto config = lane::LoadConfigFile(argv[1]);
  if (!config.ok()) {
    std::fprintf(stderr, "%s\n", std::string(config.status().message()).c_str());
    return 1;
  }
  auto detector = lane::Detector::Create(config->camera, config->ipm, config->detector);
  if (!detector.ok()) {
    std::fprintf(stderr, "%s\n", std::string(detector.status().message()).c_str());
    return 1;
  }
  cv::setNumThreads(1);  // as lane-server (--opencv_threads 1): one frame per thread
  const int passes = std::max(1, std::atoi(argv[2]));
  std::vector<cv::Mat> frames;
  lane::decode::DecodeOptions options;
  options.width = config->camera.image_width;
  options.height = config->camera.image_height;
  options.cpu_budget = absl::InfiniteDuration();  // valgrind runs 50x slower
  for (int i = 3; i < argc; ++i) {
    std::ifstream in(argv[i], std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    auto frame = lane::decode::DecodeImage(bytes, options);
    if (!frame.ok()) {
      std::fprintf(stderr, "%s: %s\n", argv[i], std::string(frame.status().message()).c_str());
      return 1;
    }
    frames.push_back(*std::move(frame));
  }
  std::vector<double> ms;
  size_t lanes = 0;
  for (int p = 0; p < passes; ++p) {
    for (const cv::Mat& frame : frames) {
      const auto t0 = std::chrono::steady_clock::now();
      auto detection = detector->Detect(frame);
      ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      if (detection.ok()) lanes += detection->lanes.size();
    }
  }
  std::nth_element(ms.begin(), ms.begin() + ms.size() / 2, ms.end());
  std::printf("%zu detections, median %.3f ms, %.2f lanes per frame\n", ms.size(),
              ms[ms.size() / 2], static_cast<double>(lanes) / ms.size());
  return 0;
}
