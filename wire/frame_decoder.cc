#include "wire/frame_decoder.h"

#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "lane/decode/detector_region.h"
#include "wire/status_map.h"

namespace lane::wire {
namespace {

absl::StatusOr<cv::Mat> DecodeRaw(const v1::RawImage& raw, const DecodeOptions& options) {
  int bytes_per_pixel = 0;
  int type = 0;
  switch (raw.pixel_format()) {
    case v1::PIXEL_FORMAT_BGR8:
    case v1::PIXEL_FORMAT_RGB8:
      bytes_per_pixel = 3;
      type = CV_8UC3;
      break;
    case v1::PIXEL_FORMAT_GRAY8:
      bytes_per_pixel = 1;
      type = CV_8UC1;
      break;
    default:
      return InvalidFrame(absl::StrCat("raw frame: unsupported pixel_format ", raw.pixel_format()));
  }
  const int64_t width = raw.width();
  const int64_t height = raw.height();
  if (absl::Status s = decode::CheckFrameSize(width, height, options); !s.ok()) {
    return InvalidFrame(absl::StrCat("raw ", s.message()));
  }
  const int64_t row_bytes = width * bytes_per_pixel;
  const int64_t stride = raw.stride() == 0 ? row_bytes : int64_t{raw.stride()};
  if (stride < row_bytes) {
    return InvalidFrame(absl::StrCat("raw frame: stride ", stride, " is less than width * ",
                                     bytes_per_pixel, " = ", row_bytes, " bytes"));
  }
  const int64_t size = static_cast<int64_t>(raw.data().size());
  const int64_t min_size = stride * (height - 1) + row_bytes;
  const int64_t max_size = stride * height;
  if (size < min_size || size > max_size) {
    return InvalidFrame(absl::StrCat("raw frame: ", size, " bytes of data, expected ",
                                     min_size == max_size ? "" : absl::StrCat(min_size, " to "),
                                     max_size, " for ", width, "x", height, " with stride ",
                                     stride));
  }
  // A header over the request's bytes: no copy.
  cv::Mat image(static_cast<int>(height), static_cast<int>(width), type,
                const_cast<char*>(raw.data().data()), static_cast<size_t>(stride));
  if (raw.pixel_format() == v1::PIXEL_FORMAT_RGB8) {
    cv::Mat converted;
    cv::cvtColor(image, converted, options.gray ? cv::COLOR_RGB2GRAY : cv::COLOR_RGB2BGR);
    return converted;
  }
  return image;
}

}  // namespace

absl::StatusOr<cv::Mat> DecodeFrame(const v1::FrameRequest& request, const DecodeOptions& options,
                                    const lane::FrameNeeds* needs) {
  switch (request.image_case()) {
    case v1::FrameRequest::kEncoded: {
      if (request.encoded().empty()) return InvalidFrame("encoded frame is empty");
      if (needs == nullptr) return decode::DecodeImage(request.encoded(), options);
      return decode::DecodeForDetector(request.encoded(), options, *needs);
    }
    case v1::FrameRequest::kRaw:
      return DecodeRaw(request.raw(), options);
    default:
      return InvalidFrame("the request carries no image (set encoded or raw)");
  }
}

}  // namespace lane::wire
