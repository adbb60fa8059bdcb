// Frame bytes -> an image the detector accepts (CV_8UC3 BGR or CV_8UC1).
//
// Every check that can be made before decoding is made first: an encoded
// frame's size is read from its JPEG/PNG header and compared with the limit
// and the camera's size, so an oversized or mismatched frame costs no decode.
#ifndef LANE_SERVER_FRAME_DECODER_H_
#define LANE_SERVER_FRAME_DECODER_H_

#include <cstdint>
#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "lane/v1/lane_service.pb.h"

namespace lane::server {

struct DecodeOptions {
  // The session camera's frame size, pixels. Frames of another size are
  // INVALID_ARGUMENT.
  int width = 0;
  int height = 0;
  // Largest frame accepted at all, width * height (checked on the header
  // before decoding; guards against decompression bombs).
  int64_t max_pixels = int64_t{3840} * 2160;
  // Decode to one grey channel (the detector reads the grey channel): JPEG
  // and PNG then skip the colour conversion.
  bool gray = false;
};

enum class EncodedFormat { kJpeg, kPng };

struct EncodedHeader {
  EncodedFormat format = EncodedFormat::kJpeg;
  int width = 0;
  int height = 0;
};

// Format and size from a JPEG (SOFn marker) or PNG (IHDR) header without
// decoding. INVALID_ARGUMENT for anything else or a truncated header.
absl::StatusOr<EncodedHeader> ReadEncodedHeader(absl::string_view bytes);

// The frame of `request` (its `encoded` or `raw` image) as CV_8UC3 BGR or
// CV_8UC1 of exactly options.width x options.height. INVALID_ARGUMENT for
// every bad frame, with a message saying what is wrong.
//
// A raw BGR8 or GRAY8 frame is not copied: the returned Mat points into
// `request`, which must outlive it.
absl::StatusOr<cv::Mat> DecodeFrame(const v1::FrameRequest& request, const DecodeOptions& options);

}  // namespace lane::server

#endif  // LANE_SERVER_FRAME_DECODER_H_
