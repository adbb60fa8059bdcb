#include "frames.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <system_error>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "io/input_file.h"
#include "io/inputs.h"

namespace lane::client {
namespace {

namespace fs = std::filesystem;

std::string Where(const std::string& path, const std::string& name) {
  return path == name ? std::string() : absl::StrCat(" (", path, ")");
}

}  // namespace

bool IsJpegOrPng(const std::string& bytes) {
  static constexpr unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  if (bytes.size() >= 3 && p[0] == 0xFF && p[1] == 0xD8 && p[2] == 0xFF) return true;
  return bytes.size() >= 8 && std::equal(kPng, kPng + 8, p);
}

FrameSource::FrameSource(const std::vector<std::string>& inputs, bool raw, io::ReadOptions options)
    : raw_(raw), entries_(io::ExpandInputs(inputs)), gate_(options) {}

FrameSource::~FrameSource() = default;

void FrameSource::ReadImage(const io::InputEntry& entry, ClientFrame* frame) const {
  // Bounded and never blocking: a FIFO, a device or a /proc file is this
  // frame's error, and so is a file over the image cap (io/input_file.h).
  absl::StatusOr<std::string> read = io::ReadRegularFile(entry.path, io::kDefaultMaxImageBytes);
  if (!read.ok()) {
    frame->error = absl::StrCat("cannot read file", Where(entry.path, entry.name), ": ",
                                read.status().message());
    return;
  }
  std::string bytes = *std::move(read);
  if (!raw_ && IsJpegOrPng(bytes)) {
    frame->encoded = std::move(bytes);
    return;
  }
  // --raw, or a format the server does not take: decode here.
  cv::Mat decoded;
  try {
    decoded = cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8UC1, bytes.data()),
                           cv::IMREAD_COLOR);
  } catch (const cv::Exception&) {
    decoded.release();
  }
  if (decoded.empty()) {
    frame->error = absl::StrCat("cannot decode image", Where(entry.path, entry.name));
    return;
  }
  frame->bgr = decoded;
}

bool FrameSource::Next(ClientFrame* frame) {
  if (gate_.Closed()) return false;
  double source_fps = 0;
  if (!NextUnpaced(frame, &source_fps)) return false;
  gate_.HandOut(frame->error.empty(), source_fps);
  return true;
}

bool FrameSource::NextUnpaced(ClientFrame* frame, double* source_fps) {
  while (next_ < entries_.size()) {
    const io::InputEntry& entry = entries_[next_];
    *frame = ClientFrame();
    frame->name = entry.name;
    frame->stem = MakeStem(entry.name);
    switch (entry.kind) {
      case io::InputEntry::kError:
        frame->error = entry.error;
        ++next_;
        return true;
      case io::InputEntry::kImage:
        ReadImage(entry, frame);
        ++next_;
        return true;
      case io::InputEntry::kVideo: {
        const char* what = entry.live ? "live source" : "video";
        if (!video_) {
          video_ = io::VideoInput::Open(entry.path, entry.api);
          if (!video_) {
            frame->error = absl::StrCat("cannot open ", what, Where(entry.path, entry.name));
            ++next_;
            return true;
          }
        }
        const int index = video_->frames_read();
        if (video_->Read(&frame->bgr)) {
          frame->name = io::VideoFrameName(entry.name, index);
          frame->stem = MakeStem(frame->name);
          *source_fps = entry.live ? 0 : video_->fps();
          return true;
        }
        video_.reset();
        ++next_;
        if (index == 0) {
          frame->error =
              absl::StrCat("no frame could be decoded from ", what, Where(entry.path, entry.name));
          return true;
        }
        continue;
      }
    }
  }
  return false;
}

void SetRawBgr(const cv::Mat& bgr, lane::v1::FrameRequest* request) {
  lane::v1::RawImage* raw = request->mutable_raw();
  raw->set_width(static_cast<uint32_t>(bgr.cols));
  raw->set_height(static_cast<uint32_t>(bgr.rows));
  raw->set_stride(0);
  raw->set_pixel_format(lane::v1::PIXEL_FORMAT_BGR8);
  std::string* data = raw->mutable_data();
  const size_t row = static_cast<size_t>(bgr.cols) * 3;
  if (bgr.isContinuous()) {
    data->assign(reinterpret_cast<const char*>(bgr.data), row * static_cast<size_t>(bgr.rows));
  } else {
    data->clear();
    data->reserve(row * static_cast<size_t>(bgr.rows));
    for (int y = 0; y < bgr.rows; ++y) data->append(bgr.ptr<char>(y), row);
  }
}

void SetRequestImage(const ClientFrame& frame, lane::v1::FrameRequest* request) {
  if (!frame.encoded.empty()) {
    request->set_encoded(frame.encoded);
  } else {
    SetRawBgr(frame.bgr, request);
  }
}

cv::Mat DecodeRequestImage(const lane::v1::FrameRequest& request) {
  try {
    if (request.has_raw()) {
      const lane::v1::RawImage& raw = request.raw();
      const int channels = raw.pixel_format() == lane::v1::PIXEL_FORMAT_GRAY8 ? 1 : 3;
      const size_t stride = raw.stride() != 0 ? raw.stride() : size_t{raw.width()} * channels;
      if (raw.width() == 0 || raw.height() == 0 ||
          raw.data().size() < stride * (raw.height() - 1) + size_t{raw.width()} * channels) {
        return cv::Mat();
      }
      cv::Mat view(static_cast<int>(raw.height()), static_cast<int>(raw.width()),
                   channels == 1 ? CV_8UC1 : CV_8UC3, const_cast<char*>(raw.data().data()), stride);
      cv::Mat out;
      if (raw.pixel_format() == lane::v1::PIXEL_FORMAT_RGB8) {
        cv::cvtColor(view, out, cv::COLOR_RGB2BGR);
      } else {
        out = view.clone();
      }
      return out;
    }
    const std::string& bytes = request.encoded();
    if (bytes.empty()) return cv::Mat();
    return cv::imdecode(
        cv::Mat(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data())),
        cv::IMREAD_COLOR);
  } catch (const cv::Exception&) {
    return cv::Mat();
  }
}

}  // namespace lane::client
