// Encoded frame (JPEG or PNG) -> cv::Mat, with bounded work.
//
// A frame comes from an untrusted client, so its decode must cost what its
// declared size says and no more:
//   * the size is read from the JPEG SOFn / PNG IHDR header and checked
//     against the limits before anything is decoded;
//   * the compressed bytes are capped relative to that size (MaxEncodedBytes);
//   * a progressive JPEG may have at most max_progressive_scans scans;
//   * a PNG is inflated only as far as its rows need (plus at most one row):
//     an IDAT stream that goes on for gigabytes past the image costs nothing;
//   * a CPU-time budget, of the decoding thread's own CPU time, is the
//     backstop for everything else (ThreadCpuClock: time spent waiting for a
//     core does not count, so a busy machine never refuses a valid frame);
//   * damaged data (what libjpeg or libpng report as a warning: corrupt
//     entropy data, a truncated file) is an error unless the caller accepts
//     it.
//
// JPEG goes through libjpeg-turbo and PNG through libpng directly (no
// cv::imdecode); the pixels are those cv::imdecode would give (see
// DecodeImage). Depends on OpenCV core (cv::Mat) and abseil only.
#ifndef LANE_DECODE_IMAGE_DECODER_H_
#define LANE_DECODE_IMAGE_DECODER_H_

#include <cstdint>
#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"

namespace lane::decode {

enum class EncodedFormat { kJpeg, kPng };

// What a header declares, before any decoding.
struct EncodedHeader {
  EncodedFormat format = EncodedFormat::kJpeg;
  int width = 0;   // pixels
  int height = 0;  // pixels
  // Samples per pixel as stored: JPEG the SOFn component count (1 grey, 3
  // colour, 4 CMYK); PNG 1 (grey, palette index), 2 (grey + alpha), 3 (RGB) or
  // 4 (RGBA).
  int channels = 0;
  // Bits per sample: JPEG the SOFn precision (8, or 12 which libjpeg-turbo's
  // 8-bit decoder refuses); PNG 1, 2, 4, 8 or 16.
  int bit_depth = 0;
};

// Format and size from a JPEG (SOFn marker) or PNG (IHDR chunk) header
// without decoding. INVALID_ARGUMENT for anything else or a truncated header.
absl::StatusOr<EncodedHeader> ReadEncodedHeader(absl::string_view bytes);

// The largest encoded frame accepted for `header`: twice the raw size of the
// pixels as stored (height * ceil(width * channels * bit_depth / 8)) plus
// 1 MiB. An honest encoder stays well under it: JPEG of pure noise at quality
// 100 is 0.7x the raw size with 4:2:0 chroma and 1.4x with 4:4:4 (libjpeg's
// standard Huffman tables), and PNG's worst case (incompressible rows) is the
// raw size plus a filter byte per row and 0.1% of deflate framing. The 1 MiB
// leaves room for metadata (EXIF, ICC profiles, text chunks). Anything larger
// can only be padding that costs parse time, so it is refused before
// decoding.
int64_t MaxEncodedBytes(const EncodedHeader& header);
inline constexpr int64_t kEncodedBytesSlack = int64_t{1} << 20;

struct DecodeOptions {
  // Expected frame size, pixels (the camera's). A frame of another size is
  // INVALID_ARGUMENT, refused from its header. Both 0: any size up to
  // max_pixels is accepted (command-line use).
  int width = 0;
  int height = 0;
  // Largest frame accepted at all, width * height pixels, checked on the
  // header before decoding. The default is 4K UHD (3840x2160), the largest
  // camera the detector is meant for; it bounds the output buffer to 25 MB and
  // libjpeg's progressive coefficient buffer to about 50 MB.
  int64_t max_pixels = int64_t{3840} * 2160;
  // Decode to one grey channel (CV_8UC1) instead of BGR (CV_8UC3). JPEG: the
  // Y plane straight from libjpeg (JCS_GRAYSCALE, no colour conversion); PNG:
  // libpng's RGB -> grey with the 0.299/0.587/0.114 weights OpenCV uses (in
  // linear light if the file has gAMA or sRGB, as in cv::imdecode).
  bool gray = false;
  // false: anything libjpeg or libpng reports as a warning is an error
  // (INVALID_ARGUMENT with the library's message): corrupt entropy-coded
  // data, a premature end of the file (libjpeg would fill the rest of the
  // image with grey), an inconsistent progression, a bad CRC in an ancillary
  // PNG chunk, compressed data after the last PNG row. true: such a frame is
  // decoded as well as the library can (what cv::imdecode does); the limits
  // below still apply.
  bool accept_damaged = false;
  // Most scans a JPEG may have (checked as each scan starts, so the scan
  // after the limit is never decoded). libjpeg's standard progression has 10
  // scans for colour and 6 for grey, the scripts of other encoders (mozjpeg's
  // scan optimisation) stay around 10-20; a baseline JPEG has 1, or one per
  // component if they are not interleaved. Each scan is a pass over the
  // coefficients even if it carries almost no data (measured: 70 us for a
  // 12-byte scan at 640x480, so ~2 ms at 4K), and 146,000 such scans fit in
  // 1.7 MB (10 s of decoding). 64 is 3-6x what honest encoders produce and
  // bounds that work to ~5 ms at 640x480 and ~130 ms at 4K.
  int max_progressive_scans = 64;
  // CPU-time budget of one DecodeImage call: the decoding thread's own CPU
  // time (CLOCK_THREAD_CPUTIME_ID) from the call's start, checked by
  // libjpeg's progress monitor (every iMCU row of every scan and every call
  // for output rows), as the input is consumed, and between PNG rows and
  // input slices. Exceeding it is RESOURCE_EXHAUSTED. A backstop: the limits
  // above already bound the work of the known bombs, this catches whatever
  // they miss. Work, not waiting: a bomb costs CPU, while a busy machine or
  // an overloaded server only makes a frame wait for a core, and that must
  // never refuse a valid frame (the wall-clock deadline this replaces did,
  // under load). No wall-clock backstop is kept: a decode runs on its own
  // thread without blocking, so its wall time is its CPU time plus waiting.
  // Measured on a loaded 2-core machine: a noisy 1640x590 frame takes 7 ms
  // (baseline JPEG), 20 ms (progressive JPEG, PNG); a noisy 3840x2160 one
  // 110 ms (baseline) and 300 ms (progressive), so 500 ms passes every
  // honest frame up to 4K; absl::InfiniteDuration() disables it.
  absl::Duration cpu_budget = absl::Milliseconds(500);

  // OK, or INVALID_ARGUMENT naming the first field that makes no sense.
  absl::Status Validate() const;
};

// OK if a width x height frame is acceptable under `options` (not empty, at
// most max_pixels, the expected size if one is set), else INVALID_ARGUMENT
// saying why. DecodeImage applies it to the header; exposed for raw frames.
absl::Status CheckFrameSize(int64_t width, int64_t height, const DecodeOptions& options);

// `bytes` (a JPEG or PNG file) decoded to CV_8UC3 BGR, or CV_8UC1 if
// options.gray, of exactly the expected size (the header's size if none is
// set). The result owns its pixels.
//
// Pixels are byte-identical to cv::imdecode(IMREAD_COLOR or IMREAD_GRAYSCALE,
// IMREAD_IGNORE_ORIENTATION) with the same libjpeg-turbo/libpng, for JPEG
// (grey, YCbCr or RGB; libjpeg's default islow DCT and fancy upsampling) and
// for PNG of every colour type and bit depth (palette and low bit depths
// expanded, 16 bits cut to 8, alpha dropped, as cv::imdecode asks libpng;
// tested on all of them, interlaced or not). Ancillary PNG chunks are
// skipped unread, except gAMA and sRGB for grey output (libpng's RGB -> grey
// uses them); iCCP and cHRM, which cv::imdecode's libpng reads but which do
// not change its output, are skipped. The output differs from cv::imdecode
// only where cv::imdecode accepts a damaged file (accept_damaged: a truncated
// JPEG is filled with grey here, with its last row repeated there). CMYK and
// YCCK JPEGs are refused (no camera sends them).
//
// Errors: INVALID_ARGUMENT for anything wrong with the frame (not JPEG/PNG,
// size, byte cap, scan limit, corrupt or damaged data) or with `options`;
// RESOURCE_EXHAUSTED if the decode used up its CPU budget. Messages are under 200
// characters and never quote the input.
absl::StatusOr<cv::Mat> DecodeImage(absl::string_view bytes, const DecodeOptions& options);

// ---- Region of interest --------------------------------------------------------
//
// What a consumer will read of a frame: a rectangle of it, at a resolution,
// one channel or all three. DecodeImageRegion decodes that and as little else
// as the format allows.
struct DecodeRegion {
  enum class Output {
    kBgr,   // CV_8UC3: DecodeImage's pixels
    kGray,  // CV_8UC1: DecodeImage's with options.gray (JPEG: Y alone)
    kRed,   // CV_8UC1: the R channel of DecodeImage's BGR pixels
  };
  // Rows [top, bottom) and columns [left, right) of the full-size frame;
  // bottom 0 means the frame's height, right 0 its width. Must lie inside
  // the frame and not be empty (INVALID_ARGUMENT otherwise).
  int top = 0;
  int bottom = 0;
  int left = 0;
  int right = 0;
  // 1, 2, 4 or 8: the output is 1/scale_denom of the frame's size, each side
  // rounded up (ceil(width / scale_denom) x ceil(height / scale_denom)).
  // JPEG: libjpeg's DCT scaling, the pixels of cv::imdecode with
  // IMREAD_REDUCED_COLOR_n / IMREAD_REDUCED_GRAYSCALE_n. PNG: the mean of
  // each scale_denom x scale_denom block (of the pixels inside the frame),
  // rounded to nearest.
  int scale_denom = 1;
  Output output = Output::kBgr;
  // What happens to the part of the file below the region's last row.
  //   true: it is read as DecodeImage reads it, so damage anywhere in the
  //     file is refused exactly as there (unless accept_damaged). Baseline
  //     JPEG: entropy-decoded without being transformed (at most two iMCU
  //     rows of it are); PNG: inflated, not stored.
  //   false: decoding stops after the region's last row, and damage
  //     detection is weaker than DecodeImage's, not only below the region:
  //     * a file truncated more than one iMCU row (JPEG; libjpeg may read
  //       that far ahead) or 64 KiB of data (PNG, fed in slices) below the
  //       region's last row decodes without an error, and the region's
  //       pixels are those of the intact file (the libraries decode in
  //       order: data below a row never changes it);
  //     * corrupt data anywhere, inside the region too, may go unnoticed,
  //       the region's pixels then garbage: libjpeg mostly notices corrupt
  //       entropy-coded data only where the decoder, out of step, meets the
  //       scan's end marker, and libpng checks an IDAT chunk's CRC and the
  //       zlib checksum only at their ends.
  //     A progressive JPEG is read whole before its first row whatever this
  //     says, so its damage is noticed as by DecodeImage.
  // Irrelevant when bottom is the frame's height (the usual lane detector
  // region): the whole file is read then. Use false only where damaged
  // frames are acceptable anyway.
  bool read_to_end = true;

  // OK, or INVALID_ARGUMENT naming the first field that makes no sense on
  // its own (the frame size is checked against the header).
  absl::Status Validate() const;
};

struct DecodedRegion {
  // The frame at 1/scale_denom of its size, CV_8UC3 for kBgr, CV_8UC1 else.
  // Only `rect` is written: the pixels outside are unspecified (uninitialised
  // memory, possibly an earlier frame's pixels) and must not be read or sent
  // anywhere. Sampling by frame coordinates needs no translation:
  // image.at<uchar>(y / scale_denom, x / scale_denom).
  cv::Mat image;
  // In image's coordinates: the rectangle decoded. It contains the requested
  // region (scaled: rows floor(top / s) to ceil(bottom / s), the same for
  // columns) and is at most one iMCU (JPEG: 8 to 32 pixels at scale 1) wider
  // on either side, because libjpeg decodes whole iMCU columns (and at
  // least 2 * the largest horizontal sampling factor + 1 of them); a PNG
  // region spans every column. Its rows are the requested ones exactly. Every pixel
  // in it is byte-identical to the same pixel of the full decode of an intact
  // file (DecodeImage at scale 1, libjpeg's scaled decode otherwise; PNG: its
  // box reduction).
  cv::Rect rect;
  // The part of the full-size frame that rect covers: rect * scale_denom,
  // clipped to the frame.
  cv::Rect frame_rect;
  int scale_denom = 1;
  cv::Size frame_size;  // the full-size frame's, from its header

  // The decoded rectangle as a view into image (no copy).
  cv::Mat Region() const { return image(rect); }
};

// Decodes the part of `bytes` (JPEG or PNG) that `region` asks for, with the
// checks, limits, CPU budget and damaged-data handling of DecodeImage (the
// same errors, from the same limits; options.gray must be false or agree
// with region.output == kGray).
//
// JPEG: the iMCU rows above the region are entropy-decoded but not
// transformed (jpeg_skip_scanlines), the columns outside it are not
// transformed (jpeg_crop_scanline), decoding stops after its last row
// (unless read_to_end asks for the tail), kGray transforms only Y. kRed is
// the R channel of libjpeg's RGB output for the region (see the .cc for the
// measured alternative). Baseline files profit fully. A progressive file has
// all of its scans entropy-decoded into the whole coefficient buffer before
// the first row, whatever the region: only the transform (IDCT, upsampling,
// colour conversion) is saved there, a fraction of its cost.
//
// PNG: every row down to the region's last is inflated and unfiltered (PNG
// cannot skip), only the region's rows are stored; an interlaced PNG is read
// to its last pass. Below the region, as read_to_end says.
absl::StatusOr<DecodedRegion> DecodeImageRegion(absl::string_view bytes,
                                                const DecodeOptions& options,
                                                const DecodeRegion& region);

}  // namespace lane::decode

#endif  // LANE_DECODE_IMAGE_DECODER_H_
