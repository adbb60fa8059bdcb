#include "lane/decode/image_decoder.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "codecs.h"

namespace lane::decode {
namespace {

uint32_t BigEndian16(const unsigned char* p) { return (uint32_t{p[0]} << 8) | p[1]; }

uint32_t BigEndian32(const unsigned char* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}

// SOF0..SOF15, which are C0..CF except DHT (C4), JPG (C8) and DAC (CC).
bool IsStartOfFrame(unsigned char marker) {
  return marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
}

absl::StatusOr<EncodedHeader> ReadJpegHeader(const unsigned char* data, size_t size) {
  size_t pos = 2;  // after SOI
  while (pos < size) {
    if (data[pos] != 0xFF) return absl::InvalidArgumentError("corrupt JPEG: expected a marker");
    while (pos < size && data[pos] == 0xFF) ++pos;  // fill bytes
    if (pos >= size) break;
    const unsigned char marker = data[pos++];
    // Markers without a length: TEM, RSTn, SOI.
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8)) continue;
    if (marker == 0xD9 || marker == 0xDA) {
      return absl::InvalidArgumentError("corrupt JPEG: no frame header before the image data");
    }
    if (pos + 2 > size) break;
    const uint32_t length = BigEndian16(data + pos);
    if (length < 2) return absl::InvalidArgumentError("corrupt JPEG: bad segment length");
    if (IsStartOfFrame(marker)) {
      // Length (2), precision (1), height (2), width (2), components (1).
      if (pos + 8 > size) break;
      EncodedHeader header;
      header.format = EncodedFormat::kJpeg;
      header.bit_depth = data[pos + 2];
      header.height = static_cast<int>(BigEndian16(data + pos + 3));
      header.width = static_cast<int>(BigEndian16(data + pos + 5));
      header.channels = data[pos + 7];
      return header;
    }
    pos += length;
  }
  return absl::InvalidArgumentError("corrupt JPEG: truncated before the frame header");
}

absl::StatusOr<EncodedHeader> ReadPngHeader(const unsigned char* data, size_t size) {
  // Signature (8), IHDR length (4), "IHDR" (4), width (4), height (4), bit
  // depth (1), colour type (1).
  if (size < 26 || absl::string_view(reinterpret_cast<const char*>(data) + 12, 4) != "IHDR") {
    return absl::InvalidArgumentError("corrupt PNG: no IHDR header");
  }
  const uint32_t width = BigEndian32(data + 16);
  const uint32_t height = BigEndian32(data + 20);
  if (width > (1u << 30) || height > (1u << 30)) {
    return absl::InvalidArgumentError("corrupt PNG: absurd size");
  }
  EncodedHeader header;
  header.format = EncodedFormat::kPng;
  header.width = static_cast<int>(width);
  header.height = static_cast<int>(height);
  header.bit_depth = data[24];
  switch (data[25]) {
    case 0:  // grey
    case 3:  // palette
      header.channels = 1;
      break;
    case 4:  // grey + alpha
      header.channels = 2;
      break;
    case 2:  // RGB
      header.channels = 3;
      break;
    case 6:  // RGBA
      header.channels = 4;
      break;
    default:
      return absl::InvalidArgumentError("corrupt PNG: unknown colour type");
  }
  if (header.bit_depth != 1 && header.bit_depth != 2 && header.bit_depth != 4 &&
      header.bit_depth != 8 && header.bit_depth != 16) {
    return absl::InvalidArgumentError("corrupt PNG: bad bit depth");
  }
  return header;
}

const char* FormatName(EncodedFormat format) {
  return format == EncodedFormat::kJpeg ? "JPEG" : "PNG";
}

}  // namespace

namespace internal {

absl::Status BudgetExceeded(absl::string_view format, absl::Duration budget) {
  return absl::ResourceExhaustedError(absl::StrCat("decoding the ", format,
                                                   " frame used more than its CPU budget of ",
                                                   absl::FormatDuration(budget)));
}

}  // namespace internal

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
  return absl::InvalidArgumentError("encoded frame is neither JPEG nor PNG");
}

int64_t MaxEncodedBytes(const EncodedHeader& header) {
  // A corrupt JPEG header may claim up to 255 components or 255 bits; no
  // decodable file has more than 4 and 16.
  const int64_t channels = std::clamp(header.channels, 1, 4);
  const int64_t bit_depth = std::clamp(header.bit_depth, 1, 16);
  const int64_t row_bits = int64_t{header.width} * channels * bit_depth;
  const int64_t raw = int64_t{header.height} * ((row_bits + 7) / 8);
  return 2 * raw + kEncodedBytesSlack;
}

absl::Status DecodeOptions::Validate() const {
  if (width < 0 || height < 0 || (width == 0) != (height == 0)) {
    return absl::InvalidArgumentError(absl::StrCat("DecodeOptions: width x height ", width, "x",
                                                   height, " must both be 0 or both positive"));
  }
  if (max_pixels <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("DecodeOptions: max_pixels ", max_pixels, " must be positive"));
  }
  if (int64_t{width} * height > max_pixels) {
    return absl::InvalidArgumentError(absl::StrCat("DecodeOptions: the expected size ", width, "x",
                                                   height, " exceeds max_pixels ", max_pixels));
  }
  if (max_progressive_scans < 1) {
    return absl::InvalidArgumentError(absl::StrCat("DecodeOptions: max_progressive_scans ",
                                                   max_progressive_scans, " must be at least 1"));
  }
  if (cpu_budget <= absl::ZeroDuration()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "DecodeOptions: cpu_budget ", absl::FormatDuration(cpu_budget), " must be positive"));
  }
  return absl::OkStatus();
}

absl::Status CheckFrameSize(int64_t width, int64_t height, const DecodeOptions& options) {
  if (width <= 0 || height <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("frame has an empty size ", width, "x", height));
  }
  constexpr int64_t kHuge = int64_t{1} << 31;  // beyond any header; the product could overflow
  if (width >= kHuge || height >= kHuge) {
    return absl::InvalidArgumentError(absl::StrCat("frame is ", width, "x", height,
                                                   ", more than the limit of ", options.max_pixels,
                                                   " pixels (--max_frame_pixels)"));
  }
  if (width * height > options.max_pixels) {
    return absl::InvalidArgumentError(absl::StrCat(
        "frame is ", width, "x", height, " = ", width * height, " pixels, more than the limit of ",
        options.max_pixels, " (--max_frame_pixels)"));
  }
  if (options.width != 0 && (width != options.width || height != options.height)) {
    return absl::InvalidArgumentError(absl::StrCat("frame is ", width, "x", height,
                                                   " but the session's camera delivers ",
                                                   options.width, "x", options.height));
  }
  return absl::OkStatus();
}

namespace {

// The checks DecodeImage and DecodeImageRegion share, on the options and the
// header: the header, or why the frame is refused before decoding.
absl::StatusOr<EncodedHeader> CheckedHeader(absl::string_view bytes, const DecodeOptions& options) {
  if (bytes.empty()) return absl::InvalidArgumentError("encoded frame is empty");
  absl::StatusOr<EncodedHeader> header = ReadEncodedHeader(bytes);
  if (!header.ok()) return header.status();
  if (absl::Status s = CheckFrameSize(header->width, header->height, options); !s.ok()) return s;
  const int64_t max_bytes = MaxEncodedBytes(*header);
  if (static_cast<int64_t>(bytes.size()) > max_bytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("the ", FormatName(header->format), " frame is ", bytes.size(),
                     " bytes, more than the ", max_bytes, " allowed for ", header->width, "x",
                     header->height, " (twice the raw size + 1 MiB)"));
  }
  return header;
}

internal::CodecRequest RequestFor(absl::string_view bytes, const EncodedHeader& header,
                                  const DecodeOptions& options, internal::CpuBudget* budget) {
  internal::CodecRequest request;
  request.bytes = bytes;
  request.width = header.width;
  request.height = header.height;
  request.output = options.gray ? internal::Output::kGray : internal::Output::kBgr;
  request.accept_damaged = options.accept_damaged;
  request.max_progressive_scans = options.max_progressive_scans;
  request.budget = budget;
  request.scale_denom = 1;
  request.top = 0;
  request.bottom = header.height;
  request.left = 0;
  request.right = header.width;
  request.read_to_end = true;
  return request;
}

absl::Status RunCodec(const EncodedHeader& header, const internal::CodecRequest& request,
                      cv::Mat& out, cv::Rect& decoded) {
  return header.format == EncodedFormat::kJpeg ? internal::DecodeJpeg(request, out, decoded)
                                               : internal::DecodePng(request, out, decoded);
}

int CeilDiv(int a, int b) { return (a + b - 1) / b; }

}  // namespace

absl::StatusOr<cv::Mat> DecodeImage(absl::string_view bytes, const DecodeOptions& options) {
  internal::CpuBudget budget(options.cpu_budget);
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  absl::StatusOr<EncodedHeader> header = CheckedHeader(bytes, options);
  if (!header.ok()) return header.status();
  const internal::CodecRequest request = RequestFor(bytes, *header, options, &budget);
  cv::Mat image(header->height, header->width, options.gray ? CV_8UC1 : CV_8UC3);
  cv::Rect decoded;
  if (absl::Status s = RunCodec(*header, request, image, decoded); !s.ok()) return s;
  return image;
}

absl::Status DecodeRegion::Validate() const {
  if (top < 0 || bottom < 0 || (bottom != 0 && bottom <= top)) {
    return absl::InvalidArgumentError(absl::StrCat("DecodeRegion: rows [", top, ", ", bottom,
                                                   ") are not a non-empty range (bottom 0: all)"));
  }
  if (left < 0 || right < 0 || (right != 0 && right <= left)) {
    return absl::InvalidArgumentError(absl::StrCat("DecodeRegion: columns [", left, ", ", right,
                                                   ") are not a non-empty range (right 0: all)"));
  }
  if (scale_denom != 1 && scale_denom != 2 && scale_denom != 4 && scale_denom != 8) {
    return absl::InvalidArgumentError(
        absl::StrCat("DecodeRegion: scale_denom ", scale_denom, " must be 1, 2, 4 or 8"));
  }
  switch (output) {
    case Output::kBgr:
    case Output::kGray:
    case Output::kRed:
      return absl::OkStatus();
  }
  return absl::InvalidArgumentError("DecodeRegion: unknown output");
}

absl::StatusOr<DecodedRegion> DecodeImageRegion(absl::string_view bytes,
                                                const DecodeOptions& options,
                                                const DecodeRegion& region) {
  internal::CpuBudget budget(options.cpu_budget);
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (absl::Status s = region.Validate(); !s.ok()) return s;
  if (options.gray && region.output != DecodeRegion::Output::kGray) {
    return absl::InvalidArgumentError(
        "DecodeOptions.gray asks for grey but the DecodeRegion for another output");
  }
  absl::StatusOr<EncodedHeader> header = CheckedHeader(bytes, options);
  if (!header.ok()) return header.status();
  const int width = header->width;
  const int height = header->height;
  const int bottom = region.bottom == 0 ? height : region.bottom;
  const int right = region.right == 0 ? width : region.right;
  if (region.top >= height || bottom > height || region.left >= width || right > width) {
    return absl::InvalidArgumentError(
        absl::StrCat("the region, rows [", region.top, ", ", bottom, ") and columns [", region.left,
                     ", ", right, "), is not inside the ", width, "x", height, " frame"));
  }

  const int s = region.scale_denom;
  internal::CodecRequest request = RequestFor(bytes, *header, options, &budget);
  switch (region.output) {
    case DecodeRegion::Output::kBgr:
      request.output = internal::Output::kBgr;
      break;
    case DecodeRegion::Output::kGray:
      request.output = internal::Output::kGray;
      break;
    case DecodeRegion::Output::kRed:
      request.output = internal::Output::kRed;
      break;
  }
  request.scale_denom = s;
  request.top = region.top / s;
  request.bottom = CeilDiv(bottom, s);
  request.left = region.left / s;
  request.right = CeilDiv(right, s);
  request.read_to_end = region.read_to_end;

  DecodedRegion result;
  result.scale_denom = s;
  result.frame_size = cv::Size(width, height);
  result.image.create(CeilDiv(height, s), CeilDiv(width, s),
                      region.output == DecodeRegion::Output::kBgr ? CV_8UC3 : CV_8UC1);
  if (absl::Status st = RunCodec(*header, request, result.image, result.rect); !st.ok()) return st;
  const cv::Rect& r = result.rect;
  const int x0 = r.x * s;
  const int y0 = r.y * s;
  result.frame_rect = cv::Rect(x0, y0, std::min(width, (r.x + r.width) * s) - x0,
                               std::min(height, (r.y + r.height) * s) - y0);
  return result;
}

}  // namespace lane::decode
