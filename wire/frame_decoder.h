// A frame request's image -> an image the detector accepts (CV_8UC3 BGR or
// CV_8UC1): encoded frames through the bounded decoder (lane/decode: header
// checks before decoding, a byte cap, a scan limit, a CPU-time budget, damaged data
// refused unless accepted), raw frames checked and wrapped without a copy.
#ifndef LANE_WIRE_FRAME_DECODER_H_
#define LANE_WIRE_FRAME_DECODER_H_

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "lane/decode/image_decoder.h"
#include "lane/detector/detector.h"
#include "lane/v1/lane_service.pb.h"

namespace lane::wire {

using decode::DecodeOptions;
using decode::EncodedFormat;
using decode::EncodedHeader;
using decode::ReadEncodedHeader;

// The frame of `request` (its `encoded` or `raw` image) as CV_8UC3 BGR or
// CV_8UC1 of exactly options.width x options.height. INVALID_ARGUMENT for
// every bad frame, with a message saying what is wrong; RESOURCE_EXHAUSTED
// when decoding uses more than options.cpu_budget of the thread's CPU time.
//
// A raw BGR8 or GRAY8 frame is not copied: the returned Mat points into
// `request`, which must outlive it.
//
// With `needs` (a detector's, lane::Detector::Needs), an encoded frame is
// decoded only in the rows the detector reads and, where one channel is all
// it needs, only that channel (CV_8UC1): the Mat has the frame's size, and
// its other rows hold anything (the detector never reads them). The same
// checks, limits and errors apply as to the whole frame; options.gray is
// ignored then.
absl::StatusOr<cv::Mat> DecodeFrame(const v1::FrameRequest& request, const DecodeOptions& options,
                                    const lane::FrameNeeds* needs = nullptr);

}  // namespace lane::wire

#endif  // LANE_WIRE_FRAME_DECODER_H_
