// DecodeImageRegion's limits and damaged-data handling on every path of the
// region decoder (damaged and hostile JPEGs, the CPU budget), PNG regions
// against the full decode, and mutated files. The JPEG regions themselves
// are in image_region_test.cc.
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
