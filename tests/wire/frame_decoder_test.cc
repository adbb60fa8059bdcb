#include "wire/frame_decoder.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "hostile_frames.h"
#include "road_frames.h"

namespace lane::wire {
namespace {

using lane::testing::EncodeJpeg;
using lane::testing::EncodePng;

cv::Mat Pattern(int w, int h) {
  cv::Mat m(h, w, CV_8UC3);
  cv::randu(m, 0, 255);
  return m;
}

DecodeOptions For(int w, int h) {
  DecodeOptions o;
  o.width = w;
  o.height = h;
  return o;
}

TEST(FrameDecoderTest, ReadsJpegAndPngHeaders) {
  absl::StatusOr<EncodedHeader> jpeg = ReadEncodedHeader(EncodeJpeg(Pattern(64, 48)));
  ASSERT_TRUE(jpeg.ok()) << jpeg.status();
  EXPECT_EQ(jpeg->format, EncodedFormat::kJpeg);
  EXPECT_EQ(jpeg->width, 64);
  EXPECT_EQ(jpeg->height, 48);
  absl::StatusOr<EncodedHeader> png = ReadEncodedHeader(EncodePng(Pattern(33, 17)));
  ASSERT_TRUE(png.ok()) << png.status();
  EXPECT_EQ(png->format, EncodedFormat::kPng);
  EXPECT_EQ(png->width, 33);
  EXPECT_EQ(png->height, 17);

  EXPECT_FALSE(ReadEncodedHeader("").ok());
  EXPECT_FALSE(ReadEncodedHeader("GIF89a......").ok());
  EXPECT_FALSE(ReadEncodedHeader(EncodeJpeg(Pattern(64, 48)).substr(0, 30)).ok());
  EXPECT_FALSE(ReadEncodedHeader(EncodePng(Pattern(8, 8)).substr(0, 20)).ok());
}

TEST(FrameDecoderTest, DecodesJpegInColourOrGrey) {
  v1::FrameRequest request;
  request.set_encoded(EncodeJpeg(Pattern(64, 48)));
  absl::StatusOr<cv::Mat> colour = DecodeFrame(request, For(64, 48));
  ASSERT_TRUE(colour.ok()) << colour.status();
  EXPECT_EQ(colour->type(), CV_8UC3);
  DecodeOptions grey = For(64, 48);
  grey.gray = true;
  absl::StatusOr<cv::Mat> g = DecodeFrame(request, grey);
  ASSERT_TRUE(g.ok());
  EXPECT_EQ(g->type(), CV_8UC1);
  EXPECT_EQ(g->size(), cv::Size(64, 48));
}

TEST(FrameDecoderTest, RefusesWrongSizeAndHugeFramesBeforeDecoding) {
  v1::FrameRequest request;
  request.set_encoded(EncodeJpeg(Pattern(64, 48)));
  absl::StatusOr<cv::Mat> wrong = DecodeFrame(request, For(640, 480));
  EXPECT_EQ(wrong.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(wrong.status().message().find("64x48"), absl::string_view::npos);

  // A header that claims 60000x60000 (a decompression bomb): refused on the
  // header alone.
  const std::string bomb = lane::testing::JpegDeclaring(EncodeJpeg(Pattern(64, 48)), 60000, 60000);
  request.set_encoded(bomb);
  DecodeOptions options = For(64, 48);
  options.max_pixels = 1920 * 1080;
  absl::StatusOr<cv::Mat> refused = DecodeFrame(request, options);
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(refused.status().message().find("max_frame_pixels"), absl::string_view::npos);
}

TEST(FrameDecoderTest, CorruptDataIsInvalidArgument) {
  v1::FrameRequest request;
  request.set_encoded("not an image at all");
  EXPECT_EQ(DecodeFrame(request, For(64, 48)).status().code(), absl::StatusCode::kInvalidArgument);
  request.set_encoded(EncodePng(Pattern(64, 48)).substr(0, 60));  // header intact, data cut
  EXPECT_EQ(DecodeFrame(request, For(64, 48)).status().code(), absl::StatusCode::kInvalidArgument);
  request.clear_image();
  EXPECT_EQ(DecodeFrame(request, For(64, 48)).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(FrameDecoderTest, RawFramesWithStrides) {
  const cv::Mat bgr = Pattern(10, 4);
  v1::FrameRequest request;
  v1::RawImage* raw = request.mutable_raw();
  raw->set_width(10);
  raw->set_height(4);
  raw->set_pixel_format(v1::PIXEL_FORMAT_BGR8);
  raw->set_stride(32);
  std::string data(32 * 4, '\0');
  for (int y = 0; y < 4; ++y) std::memcpy(&data[y * 32], bgr.ptr(y), 30);
  raw->set_data(data);

  absl::StatusOr<cv::Mat> image = DecodeFrame(request, For(10, 4));
  ASSERT_TRUE(image.ok()) << image.status();
  // No copy: the image points into the request.
  EXPECT_EQ(reinterpret_cast<const char*>(image->data), request.raw().data().data());
  EXPECT_EQ(cv::norm(*image, bgr, cv::NORM_INF), 0);

  // The last row may omit its padding.
  raw->mutable_data()->resize(32 * 3 + 30);
  EXPECT_TRUE(DecodeFrame(request, For(10, 4)).ok());
  raw->mutable_data()->resize(32 * 3 + 29);
  EXPECT_FALSE(DecodeFrame(request, For(10, 4)).ok());
  raw->mutable_data()->resize(32 * 4 + 1);
  EXPECT_FALSE(DecodeFrame(request, For(10, 4)).ok());
  raw->set_data(data);

  raw->set_stride(29);  // less than a row of 30 bytes
  EXPECT_EQ(DecodeFrame(request, For(10, 4)).status().code(), absl::StatusCode::kInvalidArgument);
  raw->set_stride(32);
  EXPECT_FALSE(DecodeFrame(request, For(12, 4)).ok());  // size mismatch
  raw->set_pixel_format(v1::PIXEL_FORMAT_UNSPECIFIED);
  EXPECT_FALSE(DecodeFrame(request, For(10, 4)).ok());

  // RGB is converted; GRAY8 is passed through.
  raw->set_pixel_format(v1::PIXEL_FORMAT_RGB8);
  absl::StatusOr<cv::Mat> from_rgb = DecodeFrame(request, For(10, 4));
  ASSERT_TRUE(from_rgb.ok());
  EXPECT_EQ(from_rgb->at<cv::Vec3b>(0, 0)[0], bgr.at<cv::Vec3b>(0, 0)[2]);
  raw->set_pixel_format(v1::PIXEL_FORMAT_GRAY8);
  raw->set_stride(0);
  raw->set_data(std::string(40, '\x10'));
  absl::StatusOr<cv::Mat> grey = DecodeFrame(request, For(10, 4));
  ASSERT_TRUE(grey.ok());
  EXPECT_EQ(grey->type(), CV_8UC1);
}

}  // namespace
}  // namespace lane::wire
