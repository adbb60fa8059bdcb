// A user's program on the installed library: reads a config and an encoded
// frame, decodes it with lanedet's bounded decoder, detects the lanes and
// prints them. Exit 0 with at least one lane, 1 otherwise.
//
//   detect_one CONFIG FRAME
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>

#include "lane/config/config.h"
#include "lane/decode/image_decoder.h"
#include "lane/detector/detector.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: detect_one CONFIG FRAME\n");
    return 2;
  }
  const absl::StatusOr<lane::Config> config = lane::LoadConfigFile(argv[1]);
  if (!config.ok()) {
    std::fprintf(stderr, "config: %s\n", std::string(config.status().message()).c_str());
    return 1;
  }
  std::ifstream in(argv[2], std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const absl::StatusOr<cv::Mat> frame =
      lane::decode::DecodeImage(bytes, lane::decode::DecodeOptions{});
  if (!frame.ok()) {
    std::fprintf(stderr, "decode: %s\n", std::string(frame.status().message()).c_str());
    return 1;
  }
  const absl::StatusOr<lane::Detector> detector =
      lane::Detector::Create(config->camera, config->ipm, config->detector);
  if (!detector.ok()) {
    std::fprintf(stderr, "detector: %s\n", std::string(detector.status().message()).c_str());
    return 1;
  }
  const absl::StatusOr<lane::Detection> detection = detector->Detect(*frame);
  if (!detection.ok()) {
    std::fprintf(stderr, "detect: %s\n", std::string(detection.status().message()).c_str());
    return 1;
  }
  for (const lane::Lane& lane : detection->lanes) {
    std::printf("lane at %.2f m, image (%.1f, %.1f) - (%.1f, %.1f)\n", lane.ground[3].x(),
                lane.image[0].x(), lane.image[0].y(), lane.image[3].x(), lane.image[3].y());
  }
  std::printf("%zu lanes\n", detection->lanes.size());
  return detection->lanes.empty() ? 1 : 0;
}
