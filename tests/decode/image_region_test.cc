// DecodeImageRegion: regions of JPEG and PNG frames against the full decode
// (DecodeImage at scale 1, libjpeg's own scaled decode through cv::imdecode
// otherwise), and the limits and damaged-data handling of DecodeImage on
// every path of the region decoder.
#include <gtest/gtest.h>
#include <png.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "decode_test_util.h"
#include "hostile_frames.h"
#include "lane/decode/image_decoder.h"

// clang-format off
// After <cstdio> and <cstddef>: jpeglib.h needs FILE and size_t.
#include <jpeglib.h>
// clang-format on

namespace lane::decode {
namespace {

using namespace lane::testing;            // NOLINT: the frame builders of hostile_frames.h
using namespace lane::decode::test_util;  // NOLINT: decode_test_util.h
using Output = DecodeRegion::Output;

constexpr Output kOutputs[] = {Output::kBgr, Output::kGray, Output::kRed};

const char* Name(Output output) {
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

DecodeRegion Region(int top, int bottom, int left, int right, Output output = Output::kBgr,
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

std::string Describe(const DecodeRegion& r) {
  return absl::StrCat("rows [", r.top, ", ", r.bottom, ") columns [", r.left, ", ", r.right, ") 1/",
                      r.scale_denom, " ", Name(r.output), r.read_to_end ? "" : " (stops early)");
}

// Regions of a width x height frame (at least 128x128): the whole frame, a
// lane detector's (from near the horizon down), unaligned ones, single rows,
// columns and pixels, the edges and the corners.
std::vector<DecodeRegion> RegionsOf(int width, int height) {
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
std::vector<DecodeRegion> RandomRegions(int width, int height, int count, uint32_t seed) {
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
cv::Mat FullFor(Output output, const cv::Mat& bgr, const cv::Mat& grey) {
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

int CeilDiv(int a, int b) { return (a + b - 1) / b; }

// Decodes `region` of `bytes` and checks it against `expected`, the whole
// frame decoded at the region's scale as the region's output: the image's
// size and type, the rectangle (the requested rows exactly; the requested
// columns and at most `max_extra` more on either side), the frame rectangle,
// and every pixel in the rectangle.
::testing::AssertionResult RegionMatches(const std::string& bytes, const DecodeOptions& options,
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
constexpr int kMaxExtraJpeg = 32;

// The full BGR and grey decodes of `bytes` by DecodeImage.
struct FullDecodes {
  cv::Mat bgr;
  cv::Mat grey;
};

FullDecodes Full(const std::string& bytes, int width, int height) {
  FullDecodes full;
  absl::StatusOr<cv::Mat> bgr = DecodeImage(bytes, For(width, height));
  absl::StatusOr<cv::Mat> grey = DecodeImage(bytes, For(width, height, true));
  EXPECT_TRUE(bgr.ok()) << bgr.status();
  EXPECT_TRUE(grey.ok()) << grey.status();
  if (bgr.ok()) full.bgr = *bgr;
  if (grey.ok()) full.grey = *grey;
  return full;
}

// ---- JPEG at scale 1 ----------------------------------------------------------------

TEST(ImageRegionTest, JpegRegionsAreByteIdenticalToTheFullDecode) {
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(1640, 590)}) {
    for (bool colour : {true, false}) {
      const cv::Mat frame =
          colour ? Frame(size.width, size.height) : GreyFrame(size.width, size.height);
      for (bool progressive : {false, true}) {
        const std::string jpeg = Jpeg(frame, 95, progressive);
        const FullDecodes full = Full(jpeg, size.width, size.height);
        ASSERT_FALSE(full.bgr.empty());
        for (const DecodeRegion& base : RegionsOf(size.width, size.height)) {
          for (Output output : kOutputs) {
            DecodeRegion region = base;
            region.output = output;
            SCOPED_TRACE(absl::StrCat(size.width, "x", size.height, colour ? " colour" : " grey",
                                      progressive ? " progressive " : " baseline ",
                                      Describe(region)));
            EXPECT_TRUE(RegionMatches(jpeg, For(size.width, size.height), region,
                                      FullFor(output, full.bgr, full.grey), kMaxExtraJpeg));
          }
        }
      }
    }
  }
}

// Without the extra column on either side of libjpeg's crop, the column at
// an edge of the crop that is not the frame's would differ (fancy upsampling
// of 4:2:0 and 4:2:2 chroma), and a crop only a few columns wide would lose
// fancy upsampling altogether: the requested rectangle is compared, not only
// what the decoder reports.
TEST(ImageRegionTest, TheRequestedColumnsAreExactAtEveryOffset) {
  const cv::Mat frame = Frame(640, 64);
  const std::string jpeg = Jpeg(frame, 95);
  const FullDecodes full = Full(jpeg, 640, 64);
  ASSERT_FALSE(full.bgr.empty());
  std::vector<int> lefts;
  for (int left = 0; left < 80; ++left) lefts.push_back(left);
  for (int left = 600; left < 640; ++left) lefts.push_back(left);
  for (int left : lefts) {
    for (int width : {1, 2, 3, 4, 5, 15, 16, 17, 33}) {
      if (left + width > 640) continue;
      SCOPED_TRACE(absl::StrCat("columns [", left, ", ", left + width, ")"));
      const DecodeRegion region = Region(3, 61, left, left + width);
      absl::StatusOr<DecodedRegion> got = DecodeImageRegion(jpeg, For(640, 64), region);
      ASSERT_TRUE(got.ok()) << got.status();
      const cv::Rect requested(left, 3, width, 58);
      EXPECT_EQ(got->rect & requested, requested) << got->rect;
      EXPECT_TRUE(Identical(got->image(requested), full.bgr(requested)));
    }
  }
}

// Every chroma layout, odd sizes (partial iMCUs on the right and at the
// bottom), restart markers, an RGB file, and a hundred random regions each.
TEST(ImageRegionTest, JpegRegionsOfEveryLayout) {
  constexpr int kWidth = 333;
  constexpr int kHeight = 211;
  const cv::Mat frame = Frame(kWidth, kHeight, 4);
  struct Case {
    const char* name;
    std::string jpeg;
  };
  std::vector<Case> cases;
  const JpegLayout layouts[] = {
      {2, 2, false, 0, 90}, {2, 1, false, 0, 90}, {1, 2, false, 0, 90}, {4, 1, false, 0, 90},
      {1, 1, false, 0, 90}, {2, 2, false, 1, 90}, {2, 1, true, 0, 90},  {1, 2, true, 0, 90},
      {4, 1, true, 0, 90},  {2, 2, true, 2, 90},
  };
  const char* names[] = {"4:2:0",
                         "4:2:2",
                         "4:4:0",
                         "4:1:1",
                         "4:4:4",
                         "4:2:0 restart every MCU row",
                         "4:2:2 progressive",
                         "4:4:0 progressive",
                         "4:1:1 progressive",
                         "4:2:0 progressive, restarts"};
  for (size_t i = 0; i < std::size(layouts); ++i) {
    cases.push_back({names[i], LibjpegEncodeLayout(frame, layouts[i])});
  }
  cases.push_back({"grey, restart every MCU row",
                   LibjpegEncodeLayout(GreyFrame(kWidth, kHeight, 4), {1, 1, false, 1, 90})});
  cv::Mat rgb;
  cv::cvtColor(frame, rgb, cv::COLOR_BGR2RGB);
  cases.push_back({"RGB colour space", LibjpegEncode(rgb, JCS_RGB, {}, JCS_RGB)});

  std::vector<DecodeRegion> regions = RegionsOf(kWidth, kHeight);
  const std::vector<DecodeRegion> random = RandomRegions(kWidth, kHeight, 100, 17);
  regions.insert(regions.end(), random.begin(), random.end());
  for (const Case& c : cases) {
    ASSERT_FALSE(c.jpeg.empty()) << c.name;
    const FullDecodes full = Full(c.jpeg, kWidth, kHeight);
    ASSERT_FALSE(full.bgr.empty());
    for (size_t i = 0; i < regions.size(); ++i) {
      DecodeRegion region = regions[i];
      if (i < RegionsOf(kWidth, kHeight).size()) region.output = kOutputs[i % 3];
      SCOPED_TRACE(absl::StrCat(c.name, ": ", Describe(region)));
      EXPECT_TRUE(RegionMatches(c.jpeg, For(kWidth, kHeight), region,
                                FullFor(region.output, full.bgr, full.grey), kMaxExtraJpeg));
    }
  }
}

TEST(ImageRegionTest, GreyOptionAgreesWithGreyOutput) {
  const std::string jpeg = Jpeg(Frame(320, 240));
  const FullDecodes full = Full(jpeg, 320, 240);
  EXPECT_TRUE(RegionMatches(jpeg, For(320, 240, true), Region(100, 0, 0, 0, Output::kGray),
                            full.grey, kMaxExtraJpeg));
  absl::StatusOr<DecodedRegion> contradiction =
      DecodeImageRegion(jpeg, For(320, 240, true), Region(100, 0, 0, 0, Output::kRed));
  EXPECT_EQ(contradiction.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(contradiction.status().message(),
            "DecodeOptions.gray asks for grey but the DecodeRegion for another output");
}

// ---- JPEG scaled ----------------------------------------------------------------

// Mean absolute difference of two images of one size and type, per sample.
double MeanAbsDiff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  const cv::Scalar mean = cv::mean(diff);
  double sum = 0;
  for (int c = 0; c < a.channels(); ++c) sum += mean[c];
  return sum / a.channels();
}

TEST(ImageRegionTest, ScaledJpegRegionsAreLibjpegsScaledDecode) {
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(1640, 590)}) {
    for (bool colour : {true, false}) {
      const cv::Mat frame =
          colour ? Frame(size.width, size.height) : GreyFrame(size.width, size.height);
      for (bool progressive : {false, true}) {
        const std::string jpeg = Jpeg(frame, 95, progressive);
        for (const auto& [scale, colour_flag, grey_flag] :
             {std::tuple{2, cv::IMREAD_REDUCED_COLOR_2, cv::IMREAD_REDUCED_GRAYSCALE_2},
              std::tuple{4, cv::IMREAD_REDUCED_COLOR_4, cv::IMREAD_REDUCED_GRAYSCALE_4},
              std::tuple{8, cv::IMREAD_REDUCED_COLOR_8, cv::IMREAD_REDUCED_GRAYSCALE_8}}) {
          const cv::Mat bgr = CvDecodeWith(jpeg, colour_flag);
          const cv::Mat grey = CvDecodeWith(jpeg, grey_flag);
          ASSERT_EQ(bgr.size(), cv::Size(CeilDiv(size.width, scale), CeilDiv(size.height, scale)));
          // Each region in one output, in turn (every output at every scale).
          const std::vector<DecodeRegion> regions = RegionsOf(size.width, size.height);
          for (size_t i = 0; i < regions.size(); ++i) {
            DecodeRegion region = regions[i];
            region.output = kOutputs[(i + static_cast<size_t>(scale)) % 3];
            region.scale_denom = scale;
            SCOPED_TRACE(absl::StrCat(size.width, "x", size.height, colour ? " colour" : " grey",
                                      progressive ? " progressive " : " baseline ",
                                      Describe(region)));
            EXPECT_TRUE(RegionMatches(jpeg, For(size.width, size.height), region,
                                      FullFor(region.output, bgr, grey), kMaxExtraJpeg));
          }
        }
      }
    }
  }
}

// libjpeg's DCT scaling is a low-pass of its own, close to a box filter: the
// scaled region is near the full decode shrunk by area averaging (where one
// pixel of misplacement on this noisy frame costs a mean difference of ~15).
TEST(ImageRegionTest, ScaledJpegRegionsAreCloseToTheResizedFullDecode) {
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(1640, 590)}) {
    const std::string jpeg = Jpeg(Frame(size.width, size.height), 95);
    const FullDecodes full = Full(jpeg, size.width, size.height);
    for (int scale : {2, 4}) {
      for (Output output : kOutputs) {
        const DecodeRegion region = Region(size.height / 3, 0, 0, 0, output, scale);
        SCOPED_TRACE(absl::StrCat(size.width, "x", size.height, " ", Describe(region)));
        absl::StatusOr<DecodedRegion> got =
            DecodeImageRegion(jpeg, For(size.width, size.height), region);
        ASSERT_TRUE(got.ok()) << got.status();
        // Whole scale x scale blocks only: cv::resize spreads a partial one.
        const int rows = size.height / scale - got->rect.y;
        const cv::Rect whole(0, got->rect.y, size.width / scale, rows);
        cv::Mat resized;
        cv::resize(FullFor(output, full.bgr, full.grey), resized,
                   cv::Size(size.width / scale, size.height / scale), 0, 0, cv::INTER_AREA);
        const double diff = MeanAbsDiff(got->image(whole), resized(whole));
        std::printf("%dx%d 1/%d %s: mean |scaled decode - resized full decode| = %.2f\n",
                    size.width, size.height, scale, Name(output), diff);
        EXPECT_LT(diff, 3.0);
      }
    }
  }
}

// ---- Options and regions ------------------------------------------------------------

TEST(ImageRegionTest, RegionsAreValidated) {
  EXPECT_TRUE(DecodeRegion{}.Validate().ok());
  EXPECT_TRUE(Region(200, 0, 0, 0, Output::kRed, 8).Validate().ok());
  for (const DecodeRegion& bad :
       {Region(-1, 0, 0, 0), Region(5, 5, 0, 0), Region(6, 5, 0, 0), Region(0, -3, 0, 0)}) {
    EXPECT_TRUE(absl::StartsWith(bad.Validate().message(), "DecodeRegion: rows")) << Describe(bad);
  }
  for (const DecodeRegion& bad : {Region(0, 0, -1, 0), Region(0, 0, 9, 9), Region(0, 0, 0, -1)}) {
    EXPECT_TRUE(absl::StartsWith(bad.Validate().message(), "DecodeRegion: columns"))
        << Describe(bad);
  }
  for (int scale : {0, 3, 16, -2}) {
    EXPECT_EQ(Region(0, 0, 0, 0, Output::kBgr, scale).Validate().message(),
              absl::StrCat("DecodeRegion: scale_denom ", scale, " must be 1, 2, 4 or 8"));
  }

  const std::string jpeg = Jpeg(Frame(64, 48));
  const std::string png = Encode(Frame(64, 48), ".png");
  for (const std::string& bytes : {jpeg, png}) {
    for (const DecodeRegion& outside :
         {Region(0, 49, 0, 0), Region(48, 0, 0, 0), Region(0, 0, 0, 65), Region(0, 0, 64, 0)}) {
      absl::StatusOr<DecodedRegion> refused = DecodeImageRegion(bytes, For(64, 48), outside);
      EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
      EXPECT_TRUE(absl::StrContains(refused.status().message(), "is not inside the 64x48 frame"))
          << refused.status();
    }
    // The region's own checks come before the frame's.
    EXPECT_TRUE(
        absl::StartsWith(DecodeImageRegion(bytes, For(64, 48), Region(0, 0, 0, 0, Output::kBgr, 3))
                             .status()
                             .message(),
                         "DecodeRegion: scale_denom"));
    // And the frame's as in DecodeImage.
    EXPECT_EQ(DecodeImageRegion(bytes, For(32, 24), DecodeRegion{}).status().message(),
              "frame is 64x48 but the session's camera delivers 32x24");
    DecodeOptions bad = For(64, 48);
    bad.cpu_budget = absl::ZeroDuration();
    EXPECT_TRUE(absl::StrContains(DecodeImageRegion(bytes, bad, DecodeRegion{}).status().message(),
                                  "cpu_budget"));
  }
  EXPECT_EQ(DecodeImageRegion("", For(64, 48), DecodeRegion{}).status().message(),
            "encoded frame is empty");
  EXPECT_EQ(DecodeImageRegion("not an image", For(64, 48), DecodeRegion{}).status().code(),
            absl::StatusCode::kInvalidArgument);

  // A header claiming 60000x60000 is refused from the header, as by DecodeImage.
  std::string bomb = jpeg;
  const size_t sof = bomb.find("\xFF\xC0");
  ASSERT_NE(sof, std::string::npos);
  bomb[sof + 5] = static_cast<char>(0xEA);
  bomb[sof + 6] = 0x60;
  bomb[sof + 7] = static_cast<char>(0xEA);
  bomb[sof + 8] = 0x60;
  EXPECT_EQ(DecodeImageRegion(bomb, DecodeOptions{}, Region(59990, 0, 0, 0)).status().message(),
            "frame is 60000x60000 = 3600000000 pixels, more than the limit of 8294400 "
            "(--max_frame_pixels)");
  // And padding beyond the byte cap.
  std::string padded = jpeg;
  padded.append(size_t{2} << 20, '\0');
  EXPECT_TRUE(absl::StrContains(
      DecodeImageRegion(padded, For(64, 48), Region(40, 0, 0, 0)).status().message(),
      "twice the raw size"));
}

// ---- Damaged JPEGs -----------------------------------------------------------------

// Overwrites `count` bytes of the entropy-coded data of a baseline JPEG's
// scan, from `from_end` bytes before its end, with random bytes other than
// 0xFF (no markers).
std::string WithRandomisedEntropyData(std::string jpeg, size_t from_end, size_t count) {
  const std::vector<JpegSegment> segments = JpegSegments(jpeg);
  auto sos = std::find_if(segments.begin(), segments.end(),
                          [](const JpegSegment& s) { return s.marker == 0xDA; });
  EXPECT_NE(sos, segments.end());
  if (sos == segments.end()) return jpeg;
  EXPECT_GT(sos->end - sos->begin, from_end + 100);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> byte(0, 0xFE);
  for (size_t i = sos->end - from_end; i < sos->end - from_end + count; ++i) {
    jpeg[i] = static_cast<char>(byte(rng));
  }
  return jpeg;
}

DecodeRegion StoppingEarly(DecodeRegion region) {
  region.read_to_end = false;
  return region;
}

// A truncated or damaged tail below the region is an error by default; with
// read_to_end false it goes unnoticed and the region is still exact.
TEST(ImageRegionTest, DamageBelowTheRegionIsNoticedUnlessDecodingStopsEarly) {
  const cv::Mat frame = Frame(640, 480);
  const std::string jpeg = Jpeg(frame, 95);
  const FullDecodes intact = Full(jpeg, 640, 480);
  const DecodeRegion top_rows = Region(0, 64, 0, 0);
  const DecodeRegion bottom_rows = Region(400, 480, 0, 0);

  // Cut at 60%: the rows below ~290 are missing.
  const std::string cut = jpeg.substr(0, jpeg.size() * 6 / 10);
  absl::StatusOr<DecodedRegion> strict = DecodeImageRegion(cut, For(640, 480), top_rows);
  EXPECT_EQ(strict.status().message(), "damaged JPEG frame: Premature end of JPEG file");
  EXPECT_TRUE(RegionMatches(cut, For(640, 480), StoppingEarly(top_rows), intact.bgr, 0));
  EXPECT_EQ(DecodeImageRegion(cut, For(640, 480), StoppingEarly(bottom_rows)).status().message(),
            "damaged JPEG frame: Premature end of JPEG file");
  // Only the EOI missing: the same.
  const std::string no_eoi = jpeg.substr(0, jpeg.size() - 2);
  EXPECT_EQ(DecodeImageRegion(no_eoi, For(640, 480), bottom_rows).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(RegionMatches(no_eoi, For(640, 480), StoppingEarly(top_rows), intact.bgr, 0));
  // The frame's last row is in the region: the whole file is read anyway.
  EXPECT_EQ(DecodeImageRegion(no_eoi, For(640, 480), StoppingEarly(bottom_rows)).status().code(),
            absl::StatusCode::kInvalidArgument);

  // Corrupt entropy data at the end: the same.
  const std::string corrupt_tail = WithRandomisedEntropyData(jpeg, 5000, 4000);
  EXPECT_TRUE(
      absl::StartsWith(DecodeImageRegion(corrupt_tail, For(640, 480), top_rows).status().message(),
                       "damaged JPEG frame: Corrupt JPEG data"));
  EXPECT_TRUE(RegionMatches(corrupt_tail, For(640, 480), StoppingEarly(top_rows), intact.bgr, 0));
  // Corrupt entropy data above the region: the skipped rows are
  // entropy-decoded, and reading to the end notices it as DecodeImage does.
  // (Stopping early need not: libjpeg, out of step, mostly notices only when
  // it meets the end marker. Here the region then differs from the intact
  // file's without an error, as the header says.)
  const std::string corrupt_head =
      WithRandomisedEntropyData(jpeg, JpegSegments(jpeg).back().begin - 2000, 4000);
  for (const DecodeRegion& region : {bottom_rows, Region(300, 360, 0, 0)}) {
    SCOPED_TRACE(Describe(region));
    absl::StatusOr<DecodedRegion> refused = DecodeImageRegion(corrupt_head, For(640, 480), region);
    EXPECT_TRUE(
        absl::StartsWith(refused.status().message(), "damaged JPEG frame: Corrupt JPEG data"))
        << refused.status();
  }
  absl::StatusOr<DecodedRegion> unnoticed =
      DecodeImageRegion(corrupt_head, For(640, 480), StoppingEarly(Region(300, 360, 0, 0)));
  if (unnoticed.ok()) {
    EXPECT_FALSE(Identical(unnoticed->Region(), intact.bgr(unnoticed->rect)));
  }

  // accept_damaged: the region of what libjpeg makes of the file, as DecodeImage.
  DecodeOptions lenient = For(640, 480);
  lenient.accept_damaged = true;
  absl::StatusOr<cv::Mat> repaired = DecodeImage(cut, lenient);
  ASSERT_TRUE(repaired.ok()) << repaired.status();
  for (const DecodeRegion& region :
       {top_rows, bottom_rows, Region(100, 300, 17, 600), StoppingEarly(Region(200, 300, 0, 0))}) {
    SCOPED_TRACE(Describe(region));
    EXPECT_TRUE(RegionMatches(cut, lenient, region, *repaired, kMaxExtraJpeg));
  }

  // A progressive file is read whole before its first row: damage anywhere
  // is noticed, however early the region ends.
  const std::string progressive = Jpeg(frame, 95, true);
  const std::string progressive_cut = progressive.substr(0, progressive.size() * 9 / 10);
  EXPECT_EQ(
      DecodeImageRegion(progressive_cut, For(640, 480), StoppingEarly(top_rows)).status().code(),
      absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(DecodeImageRegion(progressive.substr(0, progressive.size() - 2), For(640, 480),
                              StoppingEarly(top_rows))
                .status()
                .code(),
            absl::StatusCode::kInvalidArgument);
}

// ---- Hostile JPEGs ------------------------------------------------------------------

TEST(ImageRegionTest, ScanBombsAreRefusedQuicklyThroughTheRegionPath) {
  const std::string bomb = RepeatedScanBomb(146000);
  const DecodeRegion regions[] = {Region(400, 0, 0, 0, Output::kGray),
                                  StoppingEarly(Region(0, 16, 100, 200, Output::kRed, 2))};
  for (const DecodeRegion& region : regions) {
    SCOPED_TRACE(Describe(region));
    Clock::time_point start = Clock::now();
    absl::StatusOr<DecodedRegion> strict = DecodeImageRegion(bomb, For(640, 480), region);
    EXPECT_LT(MillisecondsSince(start), kFrameBudgetMs);
    EXPECT_TRUE(absl::StartsWith(strict.status().message(),
                                 "damaged JPEG frame: Inconsistent progression sequence"))
        << strict.status();

    DecodeOptions lenient = For(640, 480);
    lenient.accept_damaged = true;
    start = Clock::now();
    absl::StatusOr<DecodedRegion> limited = DecodeImageRegion(bomb, lenient, region);
    EXPECT_LT(MillisecondsSince(start), kFrameBudgetMs);
    EXPECT_EQ(limited.status().message(),
              "the JPEG frame has more than 64 scans, the scan limit (max_progressive_scans)");

    lenient.max_progressive_scans = 1 << 30;
    lenient.cpu_budget = absl::Milliseconds(100);
    start = Clock::now();
    absl::StatusOr<DecodedRegion> timed_out = DecodeImageRegion(bomb, lenient, region);
    EXPECT_LT(MillisecondsSince(start), kFrameBudgetMs);
    EXPECT_EQ(timed_out.status().code(), absl::StatusCode::kResourceExhausted)
        << timed_out.status();
  }

  cv::Mat rgb;
  cv::cvtColor(Frame(640, 480), rgb, cv::COLOR_BGR2RGB);
  const std::string many = LibjpegEncode(rgb, JCS_RGB, ManyScansScript());
  ASSERT_EQ(CountScans(many), 2090);
  const Clock::time_point start = Clock::now();
  absl::StatusOr<DecodedRegion> refused =
      DecodeImageRegion(many, For(640, 480), StoppingEarly(Region(0, 8, 0, 8, Output::kRed)));
  EXPECT_LT(MillisecondsSince(start), kFrameBudgetMs);
  EXPECT_EQ(refused.status().message(),
            "the JPEG frame has more than 64 scans, the scan limit (max_progressive_scans)");
}

TEST(ImageRegionTest, CpuBudgetIsResourceExhaustedOnEveryPath) {
  const cv::Mat frame = Frame(1640, 590);
  DecodeOptions hurried = For(1640, 590);
  hurried.cpu_budget = absl::Nanoseconds(1);
  const DecodeRegion regions[] = {Region(400, 0, 0, 0, Output::kGray),
                                  Region(100, 300, 50, 900, Output::kRed, 2),
                                  StoppingEarly(Region(0, 10, 0, 0, Output::kBgr, 4))};
  for (const std::string& bytes :
       {Jpeg(frame, 95, false), Jpeg(frame, 95, true), Encode(frame, ".png")}) {
    for (const DecodeRegion& region : regions) {
      SCOPED_TRACE(Describe(region));
      absl::StatusOr<DecodedRegion> image = DecodeImageRegion(bytes, hurried, region);
      EXPECT_EQ(image.status().code(), absl::StatusCode::kResourceExhausted) << image.status();
      EXPECT_TRUE(absl::StrContains(image.status().message(), "CPU budget of 1ns"))
          << image.status();
      EXPECT_TRUE(DecodeImageRegion(bytes, For(1640, 590), region).ok());
    }
  }
}

// jpeg_skip_scanlines entropy-decodes the rows it skips without calling
// libjpeg's progress monitor; the data source checks the CPU budget as the
// data is consumed, so a skip over a large frame stops soon after it.
TEST(ImageRegionTest, CpuBudgetStopsASkip) {
  const std::string jpeg = Jpeg(Frame(3840, 2160), 95);
  const DecodeRegion last_row = Region(2159, 0, 0, 0, Output::kGray);
  Clock::time_point start = Clock::now();
  ASSERT_TRUE(DecodeImageRegion(jpeg, For(3840, 2160), last_row).ok());
  const double whole_ms = MillisecondsSince(start);
  DecodeOptions hurried = For(3840, 2160);
  hurried.cpu_budget = absl::Microseconds(static_cast<int64_t>(whole_ms * 1000 / 10));
  start = Clock::now();
  absl::StatusOr<DecodedRegion> stopped = DecodeImageRegion(jpeg, hurried, last_row);
  const double stopped_ms = MillisecondsSince(start);
  EXPECT_EQ(stopped.status().code(), absl::StatusCode::kResourceExhausted) << stopped.status();
  EXPECT_LT(stopped_ms, whole_ms / 2);
  std::printf(
      "%zu-byte 3840x2160 JPEG, last row: %.1f ms of CPU; budget %s: stopped after %.1f ms\n",
      jpeg.size(), whole_ms, absl::FormatDuration(hurried.cpu_budget).c_str(), stopped_ms);
}

// ---- PNG ------------------------------------------------------------------------------

// The oracle for a scaled PNG: each output sample the rounded mean of its
// block's samples inside the image.
cv::Mat BoxMean(const cv::Mat& full, int s) {
  cv::Mat out(CeilDiv(full.rows, s), CeilDiv(full.cols, s), full.type());
  const int channels = full.channels();
  for (int oy = 0; oy < out.rows; ++oy) {
    for (int ox = 0; ox < out.cols; ++ox) {
      for (int c = 0; c < channels; ++c) {
        int sum = 0;
        int n = 0;
        for (int y = oy * s; y < std::min(full.rows, oy * s + s); ++y) {
          for (int x = ox * s; x < std::min(full.cols, ox * s + s); ++x) {
            sum += full.ptr(y)[x * channels + c];
            ++n;
          }
        }
        out.ptr(oy)[ox * channels + c] = static_cast<uchar>((sum + n / 2) / n);
      }
    }
  }
  return out;
}

TEST(ImageRegionTest, PngRegionsMatchTheFullDecode) {
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(1640, 590)}) {
    for (bool colour : {true, false}) {
      const cv::Mat frame =
          colour ? Frame(size.width, size.height) : GreyFrame(size.width, size.height);
      for (bool interlaced : {false, true}) {
        const std::string png = WritePng(PngOf(frame, interlaced));
        const FullDecodes full = Full(png, size.width, size.height);
        ASSERT_FALSE(full.bgr.empty());
        for (int scale : {1, 2, 4}) {
          const FullDecodes scaled{BoxMean(full.bgr, scale), BoxMean(full.grey, scale)};
          const std::vector<DecodeRegion> regions = RegionsOf(size.width, size.height);
          for (size_t i = 0; i < regions.size(); ++i) {
            // Every output of every region at scale 1, one in turn scaled;
            // stopping early in turn.
            for (Output output : kOutputs) {
              if (scale != 1 && output != kOutputs[(i + static_cast<size_t>(scale)) % 3]) continue;
              DecodeRegion region = regions[i];
              region.output = output;
              region.scale_denom = scale;
              region.read_to_end = (i + static_cast<size_t>(output)) % 2 == 0;
              SCOPED_TRACE(absl::StrCat(size.width, "x", size.height, colour ? " colour" : " grey",
                                        interlaced ? " interlaced " : " ", Describe(region)));
              // A PNG region spans every column.
              EXPECT_TRUE(RegionMatches(png, For(size.width, size.height), region,
                                        FullFor(output, scaled.bgr, scaled.grey), size.width));
            }
          }
        }
      }
    }
  }
  // The oracle is area averaging where the blocks divide the frame.
  const cv::Mat frame = Frame(640, 480);
  cv::Mat resized;
  cv::resize(frame, resized, cv::Size(320, 240), 0, 0, cv::INTER_AREA);
  EXPECT_TRUE(Identical(BoxMean(frame, 2), resized));
}

TEST(ImageRegionTest, PngDamageBelowTheRegionIsNoticedUnlessDecodingStopsEarly) {
  const cv::Mat frame = Frame(640, 480);
  for (bool interlaced : {false, true}) {
    SCOPED_TRACE(interlaced ? "interlaced" : "not interlaced");
    const std::string png = WritePng(PngOf(frame, interlaced));
    // Not interlaced, rows below ~430 are missing; interlaced, the last pass
    // (the odd rows, the second half of the data) stops at about the same.
    const std::string cut = png.substr(0, png.size() * 9 / 10);
    const DecodeRegion top_rows = Region(0, 64, 0, 0);
    EXPECT_EQ(DecodeImageRegion(cut, For(640, 480), top_rows).status().message(),
              "truncated PNG frame: the image data ends before the last row");
    EXPECT_TRUE(RegionMatches(cut, For(640, 480), StoppingEarly(top_rows), frame, 640));
    EXPECT_EQ(DecodeImageRegion(cut, For(640, 480), StoppingEarly(Region(460, 0, 0, 0)))
                  .status()
                  .message(),
              "truncated PNG frame: the image data ends before the last row");
    // Interlaced and cut in the first half: no row is final yet.
    if (interlaced) {
      EXPECT_EQ(DecodeImageRegion(png.substr(0, png.size() * 4 / 10), For(640, 480),
                                  StoppingEarly(Region(0, 2, 0, 0)))
                    .status()
                    .message(),
                "truncated PNG frame: the image data ends before the last row");
    }
    // No IEND: damage, unless decoding stops early or damage is accepted.
    const std::string no_end = png.substr(0, png.size() - 12);
    EXPECT_EQ(DecodeImageRegion(no_end, For(640, 480), top_rows).status().message(),
              "truncated PNG frame: no IEND chunk after the image data");
    EXPECT_TRUE(
        RegionMatches(no_end, For(640, 480), StoppingEarly(Region(100, 0, 0, 0)), frame, 640));
    DecodeOptions lenient = For(640, 480);
    lenient.accept_damaged = true;
    EXPECT_TRUE(RegionMatches(no_end, lenient, top_rows, frame, 640));
  }

  // The PNG bomb (a GiB of zeros past the image): refused as damage by
  // default, as by DecodeImage; never read when decoding stops early.
  const std::string bomb = PngBomb(frame, 1024);
  DecodeOptions options = For(640, 480);
  options.cpu_budget = absl::Seconds(30);
  Clock::time_point start = Clock::now();
  EXPECT_EQ(DecodeImageRegion(bomb, options, Region(400, 0, 0, 0, Output::kRed)).status().message(),
            "damaged PNG frame: Extra compressed data in IDAT");
  EXPECT_LT(MillisecondsSince(start), kFrameBudgetMs);
  start = Clock::now();
  EXPECT_TRUE(RegionMatches(bomb, options, StoppingEarly(Region(0, 100, 0, 0)), frame, 640));
  EXPECT_LT(MillisecondsSince(start), kFrameBudgetMs);
}

// ---- Robustness -------------------------------------------------------------------

// Bit flips and cuts of valid files through random regions: never a crash
// (the ASan build runs this), always OK or INVALID_ARGUMENT.
TEST(ImageRegionTest, MutatedFilesFailCleanly) {
  const cv::Mat frame = Frame(96, 64);
  const std::vector<std::string> seeds = {Jpeg(frame, 90, false),
                                          Jpeg(frame, 90, true),
                                          Encode(frame, ".png"),
                                          WritePng(PngOf(frame, true)),
                                          Jpeg(GreyFrame(96, 64), 90, true),
                                          LibjpegEncodeLayout(frame, {2, 1, false, 1, 90})};
  std::mt19937 rng(9);
  const std::vector<DecodeRegion> regions = RandomRegions(96, 64, 50, 3);
  int failures = 0;
  for (int i = 0; i < 600; ++i) {
    std::string bytes = seeds[static_cast<size_t>(i) % seeds.size()];
    const int flips = 1 + static_cast<int>(rng() % 8);
    for (int f = 0; f < flips; ++f) bytes[rng() % bytes.size()] = static_cast<char>(rng());
    if (rng() % 4 == 0) bytes.resize(rng() % bytes.size());
    for (bool accept_damaged : {false, true}) {
      DecodeOptions options = For(96, 64);
      options.accept_damaged = accept_damaged;
      DecodeRegion region = regions[rng() % regions.size()];
      region.scale_denom = 1 << (rng() % 4);
      region.read_to_end = rng() % 2 == 0;
      absl::StatusOr<DecodedRegion> decoded = DecodeImageRegion(bytes, options, region);
      if (decoded.ok()) {
        EXPECT_EQ(decoded->image.size(),
                  cv::Size(CeilDiv(96, region.scale_denom), CeilDiv(64, region.scale_denom)));
        EXPECT_EQ(decoded->rect & cv::Rect(0, 0, decoded->image.cols, decoded->image.rows),
                  decoded->rect);
      } else {
        ++failures;
        EXPECT_EQ(decoded.status().code(), absl::StatusCode::kInvalidArgument) << decoded.status();
        ExpectShortMessage(decoded.status());
      }
    }
  }
  EXPECT_GT(failures, 100);
}

}  // namespace
}  // namespace lane::decode
