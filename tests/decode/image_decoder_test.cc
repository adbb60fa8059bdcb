// The bounded decoder (lane/decode/image_decoder.h): headers, options and
// size checks, JPEG frames against cv::imdecode, damage, scan bombs and the
// CPU budget; PNG frames are in image_decoder_png_test.cc.
#include "lane/decode/image_decoder.h"

#include <gtest/gtest.h>
#include <png.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <csetjmp>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "decode_test_util.h"
#include "hostile_frames.h"

// clang-format off
// After <cstdio> and <cstddef>: jpeglib.h needs FILE and size_t.
#include <jpeglib.h>
// clang-format on

namespace lane::decode {
namespace {

using namespace lane::testing;            // NOLINT: the frame builders of hostile_frames.h
using namespace lane::decode::test_util;  // NOLINT: decode_test_util.h

// ---- Headers, options, size checks --------------------------------------------

TEST(ImageDecoderTest, ReadsJpegAndPngHeaders) {
  absl::StatusOr<EncodedHeader> jpeg = ReadEncodedHeader(Jpeg(Frame(64, 48)));
  ASSERT_TRUE(jpeg.ok()) << jpeg.status();
  EXPECT_EQ(jpeg->format, EncodedFormat::kJpeg);
  EXPECT_EQ(jpeg->width, 64);
  EXPECT_EQ(jpeg->height, 48);
  EXPECT_EQ(jpeg->channels, 3);
  EXPECT_EQ(jpeg->bit_depth, 8);
  absl::StatusOr<EncodedHeader> grey_jpeg = ReadEncodedHeader(Jpeg(GreyFrame(20, 10)));
  ASSERT_TRUE(grey_jpeg.ok()) << grey_jpeg.status();
  EXPECT_EQ(grey_jpeg->channels, 1);

  absl::StatusOr<EncodedHeader> png = ReadEncodedHeader(Encode(Frame(33, 17), ".png"));
  ASSERT_TRUE(png.ok()) << png.status();
  EXPECT_EQ(png->format, EncodedFormat::kPng);
  EXPECT_EQ(png->width, 33);
  EXPECT_EQ(png->height, 17);
  EXPECT_EQ(png->channels, 3);
  EXPECT_EQ(png->bit_depth, 8);
  cv::Mat rgba16(5, 7, CV_16UC4, cv::Scalar(1000, 2000, 3000, 65535));
  absl::StatusOr<EncodedHeader> png16 = ReadEncodedHeader(Encode(rgba16, ".png"));
  ASSERT_TRUE(png16.ok()) << png16.status();
  EXPECT_EQ(png16->channels, 4);
  EXPECT_EQ(png16->bit_depth, 16);

  EXPECT_FALSE(ReadEncodedHeader("").ok());
  EXPECT_FALSE(ReadEncodedHeader("GIF89a......").ok());
  EXPECT_FALSE(ReadEncodedHeader(Jpeg(Frame(64, 48)).substr(0, 30)).ok());
  EXPECT_FALSE(ReadEncodedHeader(Encode(Frame(8, 8), ".png").substr(0, 20)).ok());
}

TEST(ImageDecoderTest, OptionsAreValidated) {
  EXPECT_TRUE(DecodeOptions{}.Validate().ok());
  EXPECT_TRUE(For(640, 480).Validate().ok());
  DecodeOptions bad = For(640, 0);
  EXPECT_EQ(bad.Validate().code(), absl::StatusCode::kInvalidArgument);
  bad = For(-1, -1);
  EXPECT_FALSE(bad.Validate().ok());
  bad = For(640, 480);
  bad.max_pixels = 1000;
  EXPECT_NE(bad.Validate().message().find("max_pixels"), absl::string_view::npos);
  bad = For(640, 480);
  bad.max_progressive_scans = 0;
  EXPECT_NE(bad.Validate().message().find("max_progressive_scans"), absl::string_view::npos);
  bad = For(640, 480);
  bad.cpu_budget = absl::ZeroDuration();
  EXPECT_NE(bad.Validate().message().find("cpu_budget"), absl::string_view::npos);
  // DecodeImage refuses bad options before looking at the frame.
  EXPECT_EQ(DecodeImage(Jpeg(Frame(64, 48)), bad).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(ImageDecoderTest, WrongSizeAndHugeFramesAreRefusedFromTheHeader) {
  // Everything after the frame header is destroyed: a refusal with the size
  // message shows nothing was decoded.
  std::string jpeg = Jpeg(Frame(160, 120));
  const size_t sos = jpeg.find("\xFF\xDA");
  ASSERT_NE(sos, std::string::npos);
  std::fill(jpeg.begin() + static_cast<std::ptrdiff_t>(sos), jpeg.end(), '\0');
  absl::StatusOr<cv::Mat> wrong = DecodeImage(jpeg, For(320, 240));
  EXPECT_EQ(wrong.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(wrong.status().message(), "frame is 160x120 but the session's camera delivers 320x240");

  std::string png = Encode(Frame(160, 120), ".png");
  std::fill(png.begin() + 33, png.end(), '\0');  // after IHDR
  EXPECT_EQ(DecodeImage(png, For(320, 240)).status().message(),
            "frame is 160x120 but the session's camera delivers 320x240");

  // A header claiming 60000x60000 (a decompression bomb).
  const std::string bomb = lane::testing::JpegDeclaring(Jpeg(Frame(64, 48)), 60000, 60000);
  DecodeOptions any;  // no expected size: only the pixel limit applies
  absl::StatusOr<cv::Mat> refused = DecodeImage(bomb, any);
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(refused.status().message(),
            "frame is 60000x60000 = 3600000000 pixels, more than the limit of 8294400 "
            "(--max_frame_pixels)");

  EXPECT_EQ(CheckFrameSize(0, 10, any).message(), "frame has an empty size 0x10");
  EXPECT_FALSE(CheckFrameSize(int64_t{1} << 40, int64_t{1} << 40, any).ok());  // no overflow
  EXPECT_TRUE(CheckFrameSize(1920, 1080, any).ok());
  EXPECT_TRUE(CheckFrameSize(640, 480, For(640, 480)).ok());
}

TEST(ImageDecoderTest, NoExpectedSizeAcceptsAnySize) {
  const std::string jpeg = Jpeg(Frame(97, 31));
  absl::StatusOr<cv::Mat> image = DecodeImage(jpeg, DecodeOptions{});
  ASSERT_TRUE(image.ok()) << image.status();
  EXPECT_TRUE(Identical(*image, CvDecode(jpeg, false)));
}

TEST(ImageDecoderTest, NotAnImageIsInvalidArgument) {
  for (const std::string& bytes :
       {std::string(), std::string("not an image at all"), std::string("\xFF\xD8\xFF", 3),
        std::string("\x89PNG\r\n\x1A\n")}) {
    absl::StatusOr<cv::Mat> image = DecodeImage(bytes, For(64, 48));
    EXPECT_EQ(image.status().code(), absl::StatusCode::kInvalidArgument);
    ExpectShortMessage(image.status());
  }
}

// ---- The byte cap -------------------------------------------------------------

TEST(ImageDecoderTest, ByteCapFollowsTheDeclaredSize) {
  EncodedHeader header;
  header.width = 640;
  header.height = 480;
  header.channels = 3;
  header.bit_depth = 8;
  EXPECT_EQ(MaxEncodedBytes(header), 2 * 640 * 480 * 3 + (1 << 20));
  header.channels = 1;
  header.bit_depth = 1;  // 80 bytes a row
  EXPECT_EQ(MaxEncodedBytes(header), 2 * 80 * 480 + (1 << 20));

  // Padding after EOI beyond the cap: refused before decoding.
  std::string padded = Jpeg(Frame(64, 48));
  ASSERT_TRUE(DecodeImage(padded, For(64, 48)).ok());
  padded.append(size_t{2} << 20, '\0');
  absl::StatusOr<cv::Mat> refused = DecodeImage(padded, For(64, 48));
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(refused.status().message().find("twice the raw size"), absl::string_view::npos)
      << refused.status();
  ExpectShortMessage(refused.status());

  // What an honest encoder produces from noise at quality 100 is well inside
  // (under the raw size, as the header's comment says).
  cv::Mat noise(480, 640, CV_8UC3);
  cv::randu(noise, 0, 256);
  for (bool progressive : {false, true}) {
    const std::string jpeg = Jpeg(noise, 100, progressive);
    EXPECT_LT(jpeg.size(), size_t{640 * 480 * 3});
    EXPECT_TRUE(DecodeImage(jpeg, For(640, 480)).ok());
  }
  // 4:4:4 at quality 100, the largest JPEG libjpeg makes of it: 1.4x.
  cv::Mat rgb_noise;
  cv::cvtColor(noise, rgb_noise, cv::COLOR_BGR2RGB);
  const std::string full = LibjpegEncode(rgb_noise, JCS_RGB, {}, JCS_UNKNOWN, 100, true);
  EXPECT_GT(full.size(), size_t{640 * 480 * 3});
  EXPECT_LT(full.size(), size_t{640 * 480 * 3} * 3 / 2);
  EXPECT_TRUE(SameAsOpenCv(full, 640, 480, false));
  const std::string png = Encode(noise, ".png");
  EXPECT_LT(static_cast<int64_t>(png.size()), MaxEncodedBytes(*ReadEncodedHeader(png)));
  EXPECT_TRUE(SameAsOpenCv(png, 640, 480, false));
}

// ---- JPEG pixels --------------------------------------------------------------

TEST(ImageDecoderTest, JpegIsByteIdenticalToOpenCv) {
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(1640, 590)}) {
    const cv::Mat frame = Frame(size.width, size.height);
    for (bool progressive : {false, true}) {
      const std::string jpeg = Jpeg(frame, 95, progressive);
      EXPECT_EQ(CountScans(jpeg), progressive ? 10 : 1);
      for (bool gray : {false, true}) {
        SCOPED_TRACE(absl::StrCat(size.width, "x", size.height, progressive ? " progressive" : "",
                                  gray ? " grey" : " colour"));
        EXPECT_TRUE(SameAsOpenCv(jpeg, size.width, size.height, gray));
      }
    }
  }
}

TEST(ImageDecoderTest, GreyAndRgbJpegsAreByteIdenticalToOpenCv) {
  for (bool progressive : {false, true}) {
    const std::string grey = Jpeg(GreyFrame(640, 480), 90, progressive);
    EXPECT_EQ(CountScans(grey), progressive ? 6 : 1);
    EXPECT_TRUE(SameAsOpenCv(grey, 640, 480, false));
    EXPECT_TRUE(SameAsOpenCv(grey, 640, 480, true));
  }
  // An RGB JPEG: the samples stored as RGB, no YCbCr transform.
  cv::Mat rgb;
  cv::cvtColor(Frame(320, 240), rgb, cv::COLOR_BGR2RGB);
  const std::string jpeg = LibjpegEncode(rgb, JCS_RGB, {}, /*file_color_space=*/JCS_RGB);
  ASSERT_FALSE(jpeg.empty());
  EXPECT_TRUE(SameAsOpenCv(jpeg, 320, 240, false));
  EXPECT_TRUE(SameAsOpenCv(jpeg, 320, 240, true));
}

TEST(ImageDecoderTest, CmykJpegIsRefused) {
  cv::Mat cmyk(48, 64, CV_8UC4, cv::Scalar(10, 200, 30, 40));
  const std::string jpeg = LibjpegEncode(cmyk, JCS_CMYK);
  ASSERT_FALSE(jpeg.empty());
  absl::StatusOr<cv::Mat> image = DecodeImage(jpeg, For(64, 48));
  EXPECT_EQ(image.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(image.status().message().find("not supported"), absl::string_view::npos)
      << image.status();
}

// ---- Damaged JPEGs -------------------------------------------------------------

TEST(ImageDecoderTest, TruncatedJpegIsInvalidArgument) {
  const std::string jpeg = Jpeg(Frame(640, 480));
  const std::string half = jpeg.substr(0, jpeg.size() / 2);
  // What the service did before: cv::imdecode returns an image, half grey.
  EXPECT_FALSE(CvDecode(half, false).empty());

  absl::StatusOr<cv::Mat> image = DecodeImage(half, For(640, 480));
  EXPECT_EQ(image.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(image.status().message(), "damaged JPEG frame: Premature end of JPEG file");

  for (bool progressive : {false, true}) {
    const std::string p = Jpeg(Frame(640, 480), 95, progressive);
    EXPECT_EQ(DecodeImage(p.substr(0, p.size() / 2), For(640, 480, true)).status().code(),
              absl::StatusCode::kInvalidArgument);
    // Even a missing EOI alone is damage.
    EXPECT_EQ(DecodeImage(p.substr(0, p.size() - 2), For(640, 480)).status().code(),
              absl::StatusCode::kInvalidArgument);
  }

  // accept_damaged: what libjpeg makes of it, as cv::imdecode.
  DecodeOptions lenient = For(640, 480);
  lenient.accept_damaged = true;
  absl::StatusOr<cv::Mat> repaired = DecodeImage(half, lenient);
  ASSERT_TRUE(repaired.ok()) << repaired.status();
  // libjpeg's memory source ends the data with a fake EOI, so the missing
  // part is mid-grey; cv::imdecode's source manager gives a different fill
  // (the last row repeated), so only the decoded part is compared.
  const cv::Mat theirs = CvDecode(half, false);
  EXPECT_TRUE(Identical(repaired->rowRange(0, 160), theirs.rowRange(0, 160)));
  EXPECT_TRUE(Identical(repaired->row(479), cv::Mat(1, 640, CV_8UC3, cv::Scalar::all(128))));
}

TEST(ImageDecoderTest, RandomisedEntropyDataIsInvalidArgumentUnlessAccepted) {
  std::string jpeg = Jpeg(Frame(640, 480));
  std::vector<JpegSegment> segments = JpegSegments(jpeg);
  auto sos = std::find_if(segments.begin(), segments.end(),
                          [](const JpegSegment& s) { return s.marker == 0xDA; });
  ASSERT_NE(sos, segments.end());
  const size_t data_begin = sos->begin + 2 +
                            ((size_t{static_cast<unsigned char>(jpeg[sos->begin + 2])} << 8) |
                             static_cast<unsigned char>(jpeg[sos->begin + 3]));
  ASSERT_GT(sos->end, data_begin + 10000);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> byte(0, 0xFE);  // no 0xFF: no markers
  for (size_t i = data_begin; i < data_begin + 10000; ++i) jpeg[i] = static_cast<char>(byte(rng));
  // What the service did before: cv::imdecode returns an image.
  EXPECT_FALSE(CvDecode(jpeg, false).empty());

  absl::StatusOr<cv::Mat> image = DecodeImage(jpeg, For(640, 480));
  EXPECT_EQ(image.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(absl::StartsWith(image.status().message(), "damaged JPEG frame: Corrupt JPEG data"))
      << image.status();
  ExpectShortMessage(image.status());

  DecodeOptions lenient = For(640, 480);
  lenient.accept_damaged = true;
  absl::StatusOr<cv::Mat> repaired = DecodeImage(jpeg, lenient);
  ASSERT_TRUE(repaired.ok()) << repaired.status();
  EXPECT_TRUE(Identical(*repaired, CvDecode(jpeg, false)));
}

// ---- Scan bombs ----------------------------------------------------------------

TEST(ImageDecoderTest, RepeatedScanBombIsRefusedQuickly) {
  const std::string bomb = RepeatedScanBomb(146000);
  EXPECT_GT(CountScans(bomb), 146000);
  EXPECT_LT(static_cast<int64_t>(bomb.size()), MaxEncodedBytes(*ReadEncodedHeader(bomb)))
      << "the byte cap alone does not stop it";

  // Repeating a refinement scan is an inconsistent progression, which libjpeg
  // reports as a warning: refused as damaged at the first repeat.
  Clock::time_point start = Clock::now();
  absl::StatusOr<cv::Mat> strict = DecodeImage(bomb, For(640, 480));
  const double strict_ms = MillisecondsSince(start);
  EXPECT_EQ(strict.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(absl::StartsWith(strict.status().message(),
                               "damaged JPEG frame: Inconsistent progression sequence"))
      << strict.status();
  EXPECT_LT(strict_ms, kFrameBudgetMs);

  // Damage accepted, so only the scan limit stops it.
  DecodeOptions lenient = For(640, 480);
  lenient.accept_damaged = true;
  start = Clock::now();
  absl::StatusOr<cv::Mat> limited = DecodeImage(bomb, lenient);
  const double limited_ms = MillisecondsSince(start);
  EXPECT_EQ(limited.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(limited.status().message(),
            "the JPEG frame has more than 64 scans, the scan limit (max_progressive_scans)");
  EXPECT_LT(limited_ms, kFrameBudgetMs);
  std::printf(
      "repeated-scan bomb (%zu bytes, %d scans): refused in %.2f ms (damaged), %.2f ms "
      "(scan limit)\n",
      bomb.size(), CountScans(bomb), strict_ms, limited_ms);

  // Without the limit the CPU budget is the backstop.
  lenient.max_progressive_scans = 1 << 30;
  lenient.cpu_budget = absl::Milliseconds(100);
  start = Clock::now();
  absl::StatusOr<cv::Mat> timed_out = DecodeImage(bomb, lenient);
  const double timed_out_ms = MillisecondsSince(start);
  EXPECT_EQ(timed_out.status().code(), absl::StatusCode::kResourceExhausted) << timed_out.status();
  EXPECT_LT(timed_out_ms, kFrameBudgetMs);
}

TEST(ImageDecoderTest, ValidProgressionWithThousandsOfScansIsRefusedQuickly) {
  const std::vector<jpeg_scan_info> script = ManyScansScript();
  ASSERT_EQ(script.size(), 2090u);
  cv::Mat rgb;
  cv::cvtColor(Frame(640, 480), rgb, cv::COLOR_BGR2RGB);
  const std::string jpeg = LibjpegEncode(rgb, JCS_RGB, script);
  ASSERT_FALSE(jpeg.empty());
  ASSERT_EQ(CountScans(jpeg), 2090);

  const Clock::time_point start = Clock::now();
  absl::StatusOr<cv::Mat> refused = DecodeImage(jpeg, For(640, 480));
  const double refused_ms = MillisecondsSince(start);
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(refused.status().message(),
            "the JPEG frame has more than 64 scans, the scan limit (max_progressive_scans)");
  EXPECT_LT(refused_ms, kFrameBudgetMs);

  // The file is valid: with a limit above its scan count it decodes, without
  // a single warning, to what cv::imdecode gives.
  DecodeOptions generous = For(640, 480);
  generous.max_progressive_scans = 2090;
  generous.cpu_budget = absl::Seconds(30);
  const Clock::time_point full_start = Clock::now();
  absl::StatusOr<cv::Mat> full = DecodeImage(jpeg, generous);
  const double full_ms = MillisecondsSince(full_start);
  ASSERT_TRUE(full.ok()) << full.status();
  EXPECT_TRUE(Identical(*full, CvDecode(jpeg, false)));
  generous.max_progressive_scans = 2089;
  EXPECT_EQ(DecodeImage(jpeg, generous).status().code(), absl::StatusCode::kInvalidArgument);
  std::printf("2090-scan JPEG (%zu bytes): refused in %.2f ms, decoded in full in %.1f ms\n",
              jpeg.size(), refused_ms, full_ms);
}

// ---- The CPU budget ------------------------------------------------------------

TEST(ImageDecoderTest, CpuBudgetIsResourceExhausted) {
  const cv::Mat frame = Frame(1640, 590);
  DecodeOptions hurried = For(1640, 590);
  hurried.cpu_budget = absl::Nanoseconds(1);
  for (const std::string& bytes :
       {Jpeg(frame, 95, false), Jpeg(frame, 95, true), Encode(frame, ".png")}) {
    absl::StatusOr<cv::Mat> image = DecodeImage(bytes, hurried);
    EXPECT_EQ(image.status().code(), absl::StatusCode::kResourceExhausted) << image.status();
    EXPECT_NE(image.status().message().find("CPU budget of 1ns"), absl::string_view::npos)
        << image.status();
    EXPECT_TRUE(DecodeImage(bytes, For(1640, 590)).ok());
  }
}

}  // namespace
}  // namespace lane::decode
