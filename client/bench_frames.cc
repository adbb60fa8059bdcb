// The frames of `lane-client bench`: rendered or read from INPUT, prepared
// once as requests.
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "bench.h"
#include "frames.h"
#include "lane/synthetic.h"

namespace lane::client {
namespace {

namespace v1 = lane::v1;

BenchFrame MakeBenchFrame(std::string name, v1::FrameRequest request) {
  BenchFrame frame;
  frame.name = std::move(name);
  frame.request = std::move(request);
  frame.image_part = frame.request.SerializeAsString();
  return frame;
}

}  // namespace

absl::StatusOr<std::vector<BenchFrame>> SyntheticBenchFrames(const lane::CameraModel& camera,
                                                             int count, bool raw,
                                                             int jpeg_quality) {
  std::vector<BenchFrame> frames;
  for (int i = 0; i < count; ++i) {
    absl::StatusOr<lane::SyntheticFrame> frame =
        lane::RenderSyntheticFrame(camera, lane::SyntheticOptions(), static_cast<uint64_t>(i + 1));
    if (!frame.ok()) return frame.status();
    v1::FrameRequest request;
    if (raw) {
      SetRawBgr(frame->bgr, &request);
    } else {
      std::vector<uchar> bytes;
      if (!cv::imencode(".jpg", frame->bgr, bytes, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality})) {
        return absl::InternalError("cannot JPEG-encode a synthetic frame");
      }
      request.set_encoded(std::string(bytes.begin(), bytes.end()));
    }
    frames.push_back(MakeBenchFrame(absl::StrCat("synthetic-", i + 1), std::move(request)));
  }
  return frames;
}

absl::StatusOr<std::vector<BenchFrame>> LoadBenchFrames(const std::vector<std::string>& inputs,
                                                        bool raw, int max_frames) {
  FrameSource source(inputs, raw);
  std::vector<BenchFrame> frames;
  ClientFrame frame;
  while (static_cast<int>(frames.size()) < max_frames && source.Next(&frame)) {
    if (!frame.error.empty()) {
      return absl::InvalidArgumentError(absl::StrCat(frame.name, ": ", frame.error));
    }
    v1::FrameRequest request;
    SetRequestImage(frame, &request);
    frames.push_back(MakeBenchFrame(frame.name, std::move(request)));
  }
  if (frames.empty()) return absl::InvalidArgumentError("the inputs contain no frames");
  return frames;
}

}  // namespace lane::client
