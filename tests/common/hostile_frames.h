// Frames for the hardening tests, built synthetically: noisy gradients,
// JPEGs with chosen scan scripts (libjpeg directly, for files cv::imencode
// cannot make), PNGs of every kind (libpng directly), and the hostile ones:
// a progressive JPEG whose refinement scan repeats ~146,000 times, a valid
// progression of 2,090 scans, a PNG whose zlib stream runs on for GiBs past
// the image. Used by the decoder's tests and the service's.
#ifndef LANE_TESTS_COMMON_HOSTILE_FRAMES_H_
#define LANE_TESTS_COMMON_HOSTILE_FRAMES_H_

#include <png.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

// clang-format off
// After <cstdio> and <cstddef>: jpeglib.h needs FILE and size_t.
#include <jpeglib.h>
// clang-format on

namespace lane::testing {

// A colour gradient with noise: smooth regions and texture, as a road scene.
cv::Mat Frame(int width, int height, uint64_t seed = 1);
cv::Mat GreyFrame(int width, int height, uint64_t seed = 1);
std::string Encode(const cv::Mat& image, const std::string& ext,
                   const std::vector<int>& params = {});
std::string Jpeg(const cv::Mat& image, int quality = 95, bool progressive = false);

struct JpegSegment {
  unsigned char marker = 0;
  size_t begin = 0;  // the 0xFF of the marker
  size_t end = 0;    // past the segment; for SOS past its entropy-coded data
};

// The marker segments of a JPEG, in order (SOS segments with their data).
std::vector<JpegSegment> JpegSegments(const std::string& jpeg);
int CountScans(const std::string& jpeg);

// `pixels` encoded by libjpeg with an optional scan script.
std::string LibjpegEncode(const cv::Mat& pixels, J_COLOR_SPACE in_color_space,
                          const std::vector<jpeg_scan_info>& scans = {},
                          J_COLOR_SPACE file_color_space = JCS_UNKNOWN, int quality = 90,
                          bool full_chroma = false);
// How LibjpegEncodeLayout lays a JPEG out.
struct JpegLayout {
  // Luma sampling factors, chroma 1x1: 2x2 is 4:2:0 (libjpeg's default),
  // 2x1 4:2:2, 1x2 4:4:0, 4x1 4:1:1, 1x1 4:4:4.
  int luma_h = 2;
  int luma_v = 2;
  bool progressive = false;  // libjpeg's standard progression
  int restart_rows = 0;      // a restart marker every so many MCU rows; 0: none
  int quality = 90;
};
// `image` (BGR CV_8UC3, or grey CV_8UC1: a one-component file) encoded by
// libjpeg as `layout` says.
std::string LibjpegEncodeLayout(const cv::Mat& image, const JpegLayout& layout);
jpeg_scan_info Scan(std::initializer_list<int> components, int ss, int se, int ah, int al);
// A valid progression with 2090 scans.
std::vector<jpeg_scan_info> ManyScansScript();
// A 640x480 progressive JPEG whose smallest refinement scan repeats
// `repeats` times before EOI (146,000 repeats: about 1.7 MB).
std::string RepeatedScanBomb(int repeats);

struct PngImage {
  int width = 0;
  int height = 0;
  int color_type = PNG_COLOR_TYPE_RGB;
  int bit_depth = 8;
  bool interlaced = false;
  std::vector<png_color> palette;
  std::vector<png_byte> palette_alpha;  // tRNS for a palette image
  int gamma = 0;                        // gAMA, 100000 * gamma; 0 for none
  bool srgb = false;                    // an sRGB chunk
  // Packed rows as PNG stores them (big-endian 16-bit samples, RGB order).
  std::vector<std::vector<png_byte>> rows;
};

std::string WritePng(PngImage image);
// `bgr` (CV_8UC3) or grey (CV_8UC1) as an 8-bit PNG, optionally interlaced.
PngImage PngOf(const cv::Mat& image, bool interlaced);
void PutBigEndian32(std::string& out, uint32_t v);
void PutChunk(std::string& out, const char type[5], const std::string& data);
// A valid 8-bit RGB PNG of `bgr` whose zlib stream goes on after the rows
// with `extra_mib` MiB of zeros.
std::string PngBomb(const cv::Mat& bgr, int extra_mib);

// The encoded frame with its header edited to declare width x height (the
// body unchanged): JPEG's baseline SOF0, PNG's IHDR (CRC not fixed: the
// header is read before any decoder sees it).
std::string JpegDeclaring(const std::string& jpeg, uint16_t width, uint16_t height);
std::string PngDeclaring(const std::string& png, uint32_t width, uint32_t height);

}  // namespace lane::testing

#endif  // LANE_TESTS_COMMON_HOSTILE_FRAMES_H_
