// What the region decoder's tests share (image_region_test.cc,
// image_region_damage_test.cc): regions, their descriptions, and the check
// of a decoded region against the full decode.
#ifndef LANE_TESTS_DECODE_REGION_TEST_UTIL_H_
#define LANE_TESTS_DECODE_REGION_TEST_UTIL_H_

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "decode_test_util.h"
#include "lane/decode/image_decoder.h"

namespace lane::decode::region_test {

using namespace lane::decode::test_util;  // NOLINT: decode_test_util.h
using Output = DecodeRegion::Output;

inline constexpr Output kOutputs[] = {Output::kBgr, Output::kGray, Output::kRed};

inline const char* Name(Output output) {
  switch (output) {
    case Output::kBgr:
      return "BGR";
    case Output::kGray:
      return "grey";
    case Output::kRed:
      return "red";
  }
  return "?";
}

inline DecodeRegion Region(int top, int bottom, int left, int right, Output output = Output::kBgr,
                           int scale = 1) {
  DecodeRegion region;
  region.top = top;
  region.bottom = bottom;
  region.left = left;
  region.right = right;
  region.output = output;
  region.scale_denom = scale;
  return region;
}

inline std::string Describe(const DecodeRegion& r) {
  return absl::StrCat("rows [", r.top, ", ", r.bottom, ") columns [", r.left, ", ", r.right, ") 1/",
                      r.scale_denom, " ", Name(r.output), r.read_to_end ? "" : " (stops early)");
}

// Regions of a width x height frame (at least 128x128): the whole frame, a
// lane detector's (from near the horizon down), unaligned ones, single rows,
// columns and pixels, the edges and the corners.
inline std::vector<DecodeRegion> RegionsOf(int width, int height) {
  return {
      Region(0, 0, 0, 0),                                            // the whole frame
      Region(height * 5 / 12, 0, 0, 0),                              // 200..480 at 640x480
      Region(height * 2 / 3, 0, 0, 0),                               // 393..590 at 1640x590
      Region(37, height - 41, 13, width - 53),                       // nothing aligned
      Region(16, 48, 16, 64),                                        // iMCU-aligned
      Region(0, 1, 0, 0),                                            // the top row
      Region(height - 1, 0, 0, 0),                                   // the bottom row
      Region(height / 2, height / 2 + 1, width / 2, width / 2 + 1),  // one pixel
      Region(0, 0, width - 3, 0),                                    // the right columns
      Region(0, 0, 0, 5),                                            // the left columns
      Region(height - 5, 0, width - 7, 0),                           // the bottom-right corner
      Region(7, 9, 31, 33),                                          // across iMCU edges
      Region(100, 117, 47, 48),                                      // one column
  };
}

// `count` random regions of a width x height frame.
inline std::vector<DecodeRegion> RandomRegions(int width, int height, int count, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<DecodeRegion> regions;
  for (int i = 0; i < count; ++i) {
    const int top = static_cast<int>(rng() % static_cast<uint32_t>(height));
    const int bottom = top + 1 + static_cast<int>(rng() % static_cast<uint32_t>(height - top));
    const int left = static_cast<int>(rng() % static_cast<uint32_t>(width));
    const int right = left + 1 + static_cast<int>(rng() % static_cast<uint32_t>(width - left));
    regions.push_back(Region(top, bottom, left, right, kOutputs[i % 3]));
  }
  return regions;
}

// The whole frame as `output`, from the full decodes in BGR and grey.
inline cv::Mat FullFor(Output output, const cv::Mat& bgr, const cv::Mat& grey) {
  switch (output) {
    case Output::kBgr:
      return bgr;
    case Output::kGray:
      return grey;
    case Output::kRed:
      break;
  }
  cv::Mat red;
  cv::extractChannel(bgr, red, 2);
  return red;
}

inline int CeilDiv(int a, int b) { return (a + b - 1) / b; }

// Decodes `region` of `bytes` and checks it against `expected`, the whole
// frame decoded at the region's scale as the region's output: the image's
// size and type, the rectangle (the requested rows exactly; the requested
// columns and at most `max_extra` more on either side), the frame rectangle,
// and every pixel in the rectangle.
inline ::testing::AssertionResult RegionMatches(const std::string& bytes,
                                                const DecodeOptions& options,
                                                const DecodeRegion& region, const cv::Mat& expected,
                                                int max_extra) {
  absl::StatusOr<DecodedRegion> got = DecodeImageRegion(bytes, options, region);
  if (!got.ok()) return ::testing::AssertionFailure() << got.status();
  const int s = region.scale_denom;
  if (got->scale_denom != s) return ::testing::AssertionFailure() << "scale " << got->scale_denom;
  if (got->image.size() != expected.size() || got->image.type() != expected.type()) {
    return ::testing::AssertionFailure()
           << "image " << got->image.cols << "x" << got->image.rows << " type " << got->image.type()
           << ", expected " << expected.cols << "x" << expected.rows << " type " << expected.type();
  }
  const cv::Size frame = got->frame_size;
  const int top = region.top / s;
  const int bottom = CeilDiv(region.bottom == 0 ? frame.height : region.bottom, s);
  const int left = region.left / s;
  const int right = CeilDiv(region.right == 0 ? frame.width : region.right, s);
  const cv::Rect& r = got->rect;
  if (r.y != top || r.y + r.height != bottom) {
    return ::testing::AssertionFailure() << "rect rows [" << r.y << ", " << r.y + r.height
                                         << "), expected [" << top << ", " << bottom << ")";
  }
  if (r.x > left || r.x + r.width < right || r.x < std::max(0, left - max_extra) ||
      r.x + r.width > std::min(got->image.cols, right + max_extra)) {
    return ::testing::AssertionFailure() << "rect columns [" << r.x << ", " << r.x + r.width
                                         << ") for the requested [" << left << ", " << right << ")";
  }
  const cv::Rect frame_rect(r.x * s, r.y * s, std::min(frame.width, (r.x + r.width) * s) - r.x * s,
                            std::min(frame.height, (r.y + r.height) * s) - r.y * s);
  if (got->frame_rect != frame_rect) {
    return ::testing::AssertionFailure()
           << "frame_rect " << got->frame_rect << ", expected " << frame_rect;
  }
  return Identical(got->Region(), expected(r));
}

// The widest a JPEG region's rectangle may be beyond the request on either
// side: one iMCU (at most 32 pixels, for 4:1:1) at scale 1.
inline constexpr int kMaxExtraJpeg = 32;

// The full BGR and grey decodes of `bytes` by DecodeImage.
struct FullDecodes {
  cv::Mat bgr;
  cv::Mat grey;
};

inline FullDecodes Full(const std::string& bytes, int width, int height) {
  FullDecodes full;
  absl::StatusOr<cv::Mat> bgr = DecodeImage(bytes, For(width, height));
  absl::StatusOr<cv::Mat> grey = DecodeImage(bytes, For(width, height, true));
  EXPECT_TRUE(bgr.ok()) << bgr.status();
  EXPECT_TRUE(grey.ok()) << grey.status();
  if (bgr.ok()) full.bgr = *bgr;
  if (grey.ok()) full.grey = *grey;
  return full;
}

}  // namespace lane::decode::region_test

#endif  // LANE_TESTS_DECODE_REGION_TEST_UTIL_H_
