#include "frame_decoder.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "status_map.h"

namespace lane::server {
namespace {

uint32_t ReadBigEndian16(const unsigned char* p) { return (uint32_t{p[0]} << 8) | p[1]; }

uint32_t ReadBigEndian32(const unsigned char* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}

bool IsStartOfFrame(unsigned char marker) {
  // SOF0..SOF15 except DHT (C4), JPG (C8) and DAC (CC).
  return marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
}

absl::StatusOr<EncodedHeader> ReadJpegHeader(const unsigned char* data, size_t size) {
  size_t pos = 2;  // after SOI
  while (pos < size) {
    if (data[pos] != 0xFF) return InvalidFrame("corrupt JPEG: expected a marker");
    while (pos < size && data[pos] == 0xFF) ++pos;  // fill bytes
    if (pos >= size) break;
    const unsigned char marker = data[pos++];
    // Markers without a length.
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8)) continue;
    if (marker == 0xD9 || marker == 0xDA) {
      return InvalidFrame("corrupt JPEG: no frame header before the image data");
    }
    if (pos + 2 > size) break;
    const uint32_t length = ReadBigEndian16(data + pos);
    if (length < 2) return InvalidFrame("corrupt JPEG: bad segment length");
    if (IsStartOfFrame(marker)) {
      if (pos + 7 > size) break;
      EncodedHeader header;
      header.format = EncodedFormat::kJpeg;
      header.height = static_cast<int>(ReadBigEndian16(data + pos + 3));
      header.width = static_cast<int>(ReadBigEndian16(data + pos + 5));
      return header;
    }
    pos += length;
  }
  return InvalidFrame("corrupt JPEG: truncated before the frame header");
}

absl::StatusOr<EncodedHeader> ReadPngHeader(const unsigned char* data, size_t size) {
  // Signature (8), IHDR length (4), "IHDR" (4), width (4), height (4).
  if (size < 24 || absl::string_view(reinterpret_cast<const char*>(data) + 12, 4) != "IHDR") {
    return InvalidFrame("corrupt PNG: no IHDR header");
  }
  const uint32_t width = ReadBigEndian32(data + 16);
  const uint32_t height = ReadBigEndian32(data + 20);
  if (width > (1u << 30) || height > (1u << 30)) return InvalidFrame("corrupt PNG: absurd size");
  EncodedHeader header;
  header.format = EncodedFormat::kPng;
  header.width = static_cast<int>(width);
  header.height = static_cast<int>(height);
  return header;
}

absl::Status CheckSize(int64_t width, int64_t height, const DecodeOptions& options) {
  if (width <= 0 || height <= 0) {
    return InvalidFrame(absl::StrCat("frame has an empty size ", width, "x", height));
  }
  if (width * height > options.max_pixels) {
    return InvalidFrame(absl::StrCat("frame is ", width, "x", height, " = ", width * height,
                                     " pixels, more than the limit of ", options.max_pixels,
                                     " (--max_frame_pixels)"));
  }
  if (width != options.width || height != options.height) {
    return InvalidFrame(absl::StrCat("frame is ", width, "x", height,
                                     " but the session's camera delivers ", options.width, "x",
                                     options.height));
  }
  return absl::OkStatus();
}

absl::StatusOr<cv::Mat> DecodeEncoded(const std::string& bytes, const DecodeOptions& options) {
  absl::StatusOr<EncodedHeader> header = ReadEncodedHeader(bytes);
  if (!header.ok()) return header.status();
  if (absl::Status s = CheckSize(header->width, header->height, options); !s.ok()) return s;
  // A header over the request's bytes: no copy.
  const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data()));
  const int flags =
      (options.gray ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR) | cv::IMREAD_IGNORE_ORIENTATION;
  cv::Mat image;
  try {
    image = cv::imdecode(buffer, flags);
  } catch (const cv::Exception& e) {
    return InvalidFrame(absl::StrCat("cannot decode the frame: ", e.what()));
  }
  const char* name = header->format == EncodedFormat::kJpeg ? "JPEG" : "PNG";
  if (image.empty()) return InvalidFrame(absl::StrCat("cannot decode the ", name, " frame"));
  if (image.cols != options.width || image.rows != options.height || image.depth() != CV_8U) {
    return InvalidFrame(absl::StrCat("the ", name, " frame decoded to an unexpected image"));
  }
  return image;
}

absl::StatusOr<cv::Mat> DecodeRaw(const v1::RawImage& raw, const DecodeOptions& options) {
  int bytes_per_pixel = 0;
  int type = 0;
  switch (raw.pixel_format()) {
    case v1::PIXEL_FORMAT_BGR8:
    case v1::PIXEL_FORMAT_RGB8:
      bytes_per_pixel = 3;
      type = CV_8UC3;
      break;
    case v1::PIXEL_FORMAT_GRAY8:
      bytes_per_pixel = 1;
      type = CV_8UC1;
      break;
    default:
      return InvalidFrame(absl::StrCat("raw frame: unsupported pixel_format ", raw.pixel_format()));
  }
  const int64_t width = raw.width();
  const int64_t height = raw.height();
  if (absl::Status s = CheckSize(width, height, options); !s.ok()) {
    return InvalidFrame(absl::StrCat("raw ", s.message()));
  }
  const int64_t row_bytes = width * bytes_per_pixel;
  const int64_t stride = raw.stride() == 0 ? row_bytes : int64_t{raw.stride()};
  if (stride < row_bytes) {
    return InvalidFrame(absl::StrCat("raw frame: stride ", stride, " is less than width * ",
                                     bytes_per_pixel, " = ", row_bytes, " bytes"));
  }
  const int64_t size = static_cast<int64_t>(raw.data().size());
  const int64_t min_size = stride * (height - 1) + row_bytes;
  const int64_t max_size = stride * height;
  if (size < min_size || size > max_size) {
    return InvalidFrame(absl::StrCat("raw frame: ", size, " bytes of data, expected ",
                                     min_size == max_size ? "" : absl::StrCat(min_size, " to "),
                                     max_size, " for ", width, "x", height, " with stride ",
                                     stride));
  }
  // A header over the request's bytes: no copy.
  cv::Mat image(static_cast<int>(height), static_cast<int>(width), type,
                const_cast<char*>(raw.data().data()), static_cast<size_t>(stride));
  if (raw.pixel_format() == v1::PIXEL_FORMAT_RGB8) {
    cv::Mat converted;
    cv::cvtColor(image, converted, options.gray ? cv::COLOR_RGB2GRAY : cv::COLOR_RGB2BGR);
    return converted;
  }
  return image;
}

}  // namespace

absl::StatusOr<EncodedHeader> ReadEncodedHeader(absl::string_view bytes) {
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const size_t size = bytes.size();
  if (size >= 3 && data[0] == 0xFF && data[1] == 0xD8 && data[2] == 0xFF) {
    return ReadJpegHeader(data, size);
  }
  static constexpr unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (size >= 8 && std::equal(kPngSignature, kPngSignature + 8, data)) {
    return ReadPngHeader(data, size);
  }
  return InvalidFrame("encoded frame is neither JPEG nor PNG");
}

absl::StatusOr<cv::Mat> DecodeFrame(const v1::FrameRequest& request, const DecodeOptions& options) {
  switch (request.image_case()) {
    case v1::FrameRequest::kEncoded:
      if (request.encoded().empty()) return InvalidFrame("encoded frame is empty");
      return DecodeEncoded(request.encoded(), options);
    case v1::FrameRequest::kRaw:
      return DecodeRaw(request.raw(), options);
    default:
      return InvalidFrame("the request carries no image (set encoded or raw)");
  }
}

}  // namespace lane::server
