// The part of a frame a detector reads (lane::Detector::Needs) as a region
// for DecodeImageRegion. Header-only; the one part of lane_decode that needs
// the detector, which is why lane_decode links lane_core (decode/CMakeLists.txt).
#ifndef LANE_DECODE_DETECTOR_REGION_H_
#define LANE_DECODE_DETECTOR_REGION_H_

#include "lane/decode/image_decoder.h"
#include "lane/detector/detector.h"

namespace lane::decode {

inline DecodeRegion RegionFor(const FrameNeeds& needs) {
  DecodeRegion region;
  region.top = needs.top;
  region.bottom = needs.bottom;
  switch (needs.pixels) {
    case FrameNeeds::Pixels::kBgr:
      region.output = DecodeRegion::Output::kBgr;
      break;
    case FrameNeeds::Pixels::kRed:
      region.output = DecodeRegion::Output::kRed;
      break;
  }
  return region;
}

// DecodeImageRegion of what the detector reads, with `options` (gray off:
// the region's output says what is decoded): a frame of the camera's size
// whose rows outside the region hold anything.
inline absl::StatusOr<cv::Mat> DecodeForDetector(absl::string_view bytes, DecodeOptions options,
                                                 const FrameNeeds& needs) {
  const DecodeRegion region = RegionFor(needs);
  options.gray = false;
  absl::StatusOr<DecodedRegion> decoded = DecodeImageRegion(bytes, options, region);
  if (!decoded.ok()) return decoded.status();
  return std::move(decoded->image);
}

}  // namespace lane::decode

#endif  // LANE_DECODE_DETECTOR_REGION_H_
