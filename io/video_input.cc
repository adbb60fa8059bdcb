#include "io/video_input.h"

#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgproc.hpp>
#include <regex>

namespace lane::io {

std::optional<LiveSource> ClassifyLiveSource(const std::string& input) {
  static const std::regex kUrl("^(rtsps?|rtmps?|https?|udp|tcp|srt)://.+",
                               std::regex::icase | std::regex::optimize);
  static const std::regex kDevice("^/dev/video[0-9]+$", std::regex::optimize);
  if (std::regex_match(input, kUrl)) return LiveSource{cv::CAP_FFMPEG, "stream"};
  if (std::regex_match(input, kDevice)) return LiveSource{cv::CAP_V4L2, "device"};
  if (input.find(" ! ") != std::string::npos) return LiveSource{cv::CAP_GSTREAMER, "pipeline"};
  return std::nullopt;
}

std::unique_ptr<VideoInput> VideoInput::Open(const std::string& path, int api) {
  auto capture = std::make_unique<cv::VideoCapture>();
  // OpenCV logs each backend's failure at length; the caller's message says it.
  const auto level = cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  bool opened = false;
  try {
    opened = capture->open(path, api) && capture->isOpened();
  } catch (const cv::Exception&) {
    opened = false;
  }
  cv::utils::logging::setLogLevel(level);
  if (!opened) return nullptr;
  return std::unique_ptr<VideoInput>(new VideoInput(std::move(capture)));
}

VideoInput::VideoInput(std::unique_ptr<cv::VideoCapture> capture) : capture_(std::move(capture)) {
  const double fps = capture_->get(cv::CAP_PROP_FPS);
  // Backends report 0, NaN or nonsense (90000: a time base) when they do not
  // know.
  fps_ = fps > 0 && fps <= 1000 ? fps : 0;
}

bool VideoInput::Read(cv::Mat* bgr) {
  cv::Mat image;
  try {
    if (!capture_->read(image) || image.empty()) return false;
  } catch (const cv::Exception&) {
    return false;
  }
  if (image.depth() != CV_8U) return false;
  if (image.channels() == 1) {
    cv::cvtColor(image, *bgr, cv::COLOR_GRAY2BGR);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, *bgr, cv::COLOR_BGRA2BGR);
  } else {
    *bgr = image;
  }
  ++frames_read_;
  return true;
}

}  // namespace lane::io
