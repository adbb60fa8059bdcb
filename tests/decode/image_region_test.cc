// DecodeImageRegion: regions of JPEG frames against the full decode
// (DecodeImage at scale 1, libjpeg's own scaled decode through cv::imdecode
// otherwise), and the regions' validation. Damage, hostile frames, the CPU
// budget and PNG regions are in image_region_damage_test.cc.
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
#include "region_test_util.h"

// clang-format off
// After <cstdio> and <cstddef>: jpeglib.h needs FILE and size_t.
#include <jpeglib.h>
// clang-format on

namespace lane::decode {
namespace {

using namespace lane::testing;              // NOLINT: the frame builders of hostile_frames.h
using namespace lane::decode::test_util;    // NOLINT: decode_test_util.h
using namespace lane::decode::region_test;  // NOLINT: region_test_util.h
using Output = DecodeRegion::Output;

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

}  // namespace
}  // namespace lane::decode
