// Arbitrary bytes as an encoded frame (JPEG/PNG or anything else): header
// checks, decoding, and detection when the frame decodes at the camera size.
#include <cstddef>
#include <cstdint>

#include "fuzz_common.h"
#include "wire/frame_decoder.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const auto session = lane::fuzz::SyntheticSession();
  lane::v1::FrameRequest request;
  request.set_camera_id("fuzz");
  request.set_encoded(reinterpret_cast<const char*>(data), size);
  lane::wire::DecodeOptions options;
  options.width = session->config.camera.image_width;
  options.height = session->config.camera.image_height;
  options.max_pixels = int64_t{1920} * 1080;
  absl::StatusOr<cv::Mat> image = lane::wire::DecodeFrame(request, options);
  if (image.ok()) (void)session->detector.Detect(*image);
  return 0;
}
