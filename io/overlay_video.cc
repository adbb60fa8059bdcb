#include "io/overlay_video.h"

#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "io/inputs.h"

namespace lane::io {
namespace {

int FourccFor(const std::string& extension) {
  if (extension == ".avi") return cv::VideoWriter::fourcc('M', 'J', 'P', 'G');
  return cv::VideoWriter::fourcc('m', 'p', '4', 'v');
}

}  // namespace

std::string OverlayVideo::CheckPath(const std::string& path) {
  const std::string ext = LowerExtension(path);
  if (ext == ".mp4" || ext == ".mov" || ext == ".mkv" || ext == ".avi") return "";
  return absl::StrCat("--overlay-video ", path, ": use a .mp4, .mov, .mkv or .avi file");
}

OverlayVideo::OverlayVideo(std::string path, double fps)
    : path_(std::move(path)), fps_(fps > 0 ? fps : 10.0) {}

OverlayVideo::~OverlayVideo() { Close(); }

std::string OverlayVideo::Add(const cv::Mat& bgr) {
  if (failed_) return "";  // reported once
  if (bgr.empty()) return "";
  if (!writer_) {
    size_ = bgr.size();
    writer_ = std::make_unique<cv::VideoWriter>();
    const auto level = cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
    bool opened = false;
    try {
      opened =
          writer_->open(path_, cv::CAP_FFMPEG, FourccFor(LowerExtension(path_)), fps_, size_, true);
    } catch (const cv::Exception&) {
      opened = false;
    }
    cv::utils::logging::setLogLevel(level);
    if (!opened) {
      failed_ = true;
      writer_.reset();
      return absl::StrCat("cannot write the overlay video ", path_);
    }
  }
  if (bgr.size() == size_) {
    writer_->write(bgr);
  } else {
    cv::Mat scaled;
    cv::resize(bgr, scaled, size_, 0, 0, cv::INTER_AREA);
    writer_->write(scaled);
  }
  ++frames_;
  return "";
}

std::string OverlayVideo::Close() {
  if (writer_) {
    writer_->release();
    writer_.reset();
  }
  return failed_ ? absl::StrCat("cannot write the overlay video ", path_) : "";
}

}  // namespace lane::io
