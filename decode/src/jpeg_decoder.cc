// JPEG through libjpeg-turbo's libjpeg API.
//
// A region is decoded with libjpeg-turbo's partial decoding: the rows above
// it are skipped (jpeg_skip_scanlines: entropy-decoded, not transformed;
// for a progressive file, whose coefficients are all in memory by then,
// nothing at all), the columns outside it are cropped (jpeg_crop_scanline:
// not transformed, though still entropy-decoded) and decoding stops after its
// last row unless the request reads to the end.
//
// Measured with libjpeg-turbo 2.1.5 (tests assert it): skipping leaves the
// rows below unchanged, since libjpeg itself decodes the context rows fancy
// upsampling needs; cropping changes exactly one column at an edge of the crop
// that is not the frame's (the chroma sample beyond it is missing, so h2v1
// and h2v2 fancy upsampling treat it as the image's edge), and every column
// if it leaves a component 2 samples wide or less (libjpeg-turbo then
// upsamples without the fancy filter). So the crop asked of libjpeg is one
// column wider than the request on either side and at least 2 *
// max_h_samp_factor + 1 wide, and the extra column is left out of the
// rectangle reported.
//
// Red output is the R of libjpeg's RGB output for the region, taken from a
// few rows of scratch. The alternative, raw data (jpeg_read_raw_data: Y and
// Cr, then R = Y + 1.402 (Cr - 128) with libjpeg's fancy upsampling and
// rounding done here), was measured and is slower (2026-12-01, 16 rendered
// 640x480 frames at q90, thread CPU time, best of 9): libjpeg refuses
// jpeg_skip_scanlines and jpeg_crop_scanline in raw mode (they need
// DSTATE_SCANNING), so every row of every component is transformed, and
// that alone, before any upsampling, costs 740 us against 780-800 us for
// the whole red region of rows 200..480 here (full BGR decode: 925-975 us,
// grey region 630 us). Skipping the rows and Cb in raw mode takes clearing
// jpeg_component_info::component_needed, which jpeglib.h declares private:
// 643 us before upsampling, so at best ~10% faster with a hand-vectorised
// fancy upsampler, on a private field. Not done.
//
// libjpeg reports errors by calling error_exit, which must not return; ours
// longjmps back to RunJpeg. A longjmp skips destructors, so everything the
// decode touches between the setjmp and its end lives in one trivially
// destructible JpegState, and the functions it may leave by longjmp
// (DecodeSteps and the callbacks) hold nothing with a destructor.
#include <algorithm>
#include <csetjmp>
#include <cstddef>
#include <cstdio>
#include <opencv2/core/hal/intrin.hpp>
#include <type_traits>

#include "absl/strings/str_cat.h"
#include "codecs.h"

// clang-format off
// After <cstdio> and <cstddef> (jpeglib.h needs FILE and size_t but does not
// include them), jerror.h after jpeglib.h.
#include <jpeglib.h>
#include <jerror.h>
// clang-format on

namespace lane::decode::internal {
namespace {

enum class JpegFailure {
  kNone,
  kError,       // libjpeg's error_exit: message[] holds libjpeg's message
  kDamaged,     // a libjpeg warning and !accept_damaged: message[] likewise
  kScanLimit,   // more than max_scans scans
  kBudget,      // the CPU budget was used up
  kColorSpace,  // not grey, YCbCr or RGB (color_space holds it)
  kUnexpected,  // libjpeg's idea of the image differs from the header's
  kNoProgress,  // jpeg_read_scanlines returned no rows
};

struct JpegState {
  jpeg_decompress_struct cinfo;
  jpeg_error_mgr error;
  jpeg_progress_mgr progress;
  std::jmp_buf jump;

  jpeg_source_mgr source;
  size_t fed;  // bytes of data handed to libjpeg so far

  // Inputs.
  const unsigned char* data;
  size_t size;
  unsigned char* out;  // out_height rows of stride bytes
  size_t stride;
  int width;  // the header's
  int height;
  int scale_denom;
  int out_width;  // the output's: the frame's size / scale_denom, rounded up
  int out_height;
  Output output;
  int top;  // the region, output coordinates
  int bottom;
  int left;
  int right;
  bool read_to_end;
  bool accept_damaged;
  int max_scans;
  CpuBudget* budget;
  long max_memory;  // bytes, libjpeg's max_memory_to_use

  // Outcome.
  int decoded_left;  // columns [decoded_left, decoded_right) were written
  int decoded_right;
  JpegFailure failure;
  int color_space;
  char message[JMSG_LENGTH_MAX];
};
static_assert(std::is_trivially_destructible_v<JpegState>,
              "JpegState is left by longjmp: no destructors");

JpegState* StateOf(j_common_ptr cinfo) { return static_cast<JpegState*>(cinfo->client_data); }

[[noreturn]] void Fail(JpegState* state, JpegFailure failure) {
  if (state->failure == JpegFailure::kNone) state->failure = failure;
  std::longjmp(state->jump, 1);
}

// error_exit: an error libjpeg cannot continue after.
[[noreturn]] void OnErrorExit(j_common_ptr cinfo) {
  JpegState* state = StateOf(cinfo);
  if (state->failure == JpegFailure::kNone) (*cinfo->err->format_message)(cinfo, state->message);
  Fail(state, JpegFailure::kError);
}

// emit_message: level -1 is a warning (damaged data libjpeg works around),
// 0 and up are trace messages. Nothing is ever printed.
void OnEmitMessage(j_common_ptr cinfo, int msg_level) {
  if (msg_level >= 0) return;
  ++cinfo->err->num_warnings;
  JpegState* state = StateOf(cinfo);
  if (state->accept_damaged) return;
  if (state->failure == JpegFailure::kNone) (*cinfo->err->format_message)(cinfo, state->message);
  Fail(state, JpegFailure::kDamaged);
}

void OnOutputMessage(j_common_ptr /*cinfo*/) {}

void CheckBudget(JpegState* state) {
  if (state->budget->Exceeded()) Fail(state, JpegFailure::kBudget);
}

// Called before each iMCU row of each scan libjpeg consumes (progressive and
// other multi-scan files) and before each jpeg_read_scanlines.
void OnProgress(j_common_ptr cinfo) {
  JpegState* state = StateOf(cinfo);
  // Installed on a decompressor only, whose struct starts with the common fields.
  const auto* decompress = reinterpret_cast<j_decompress_ptr>(cinfo);
  // input_scan_number counts the SOS markers read, so the first call after
  // scan max_scans + 1 has started refuses it before any of it is decoded.
  if (decompress->input_scan_number > state->max_scans) Fail(state, JpegFailure::kScanLimit);
  CheckBudget(state);
}

// ---- Source: the data in memory, handed over in slices --------------------------
//
// As jpeg_mem_src, but kJpegFeedBytes at a time, so that the CPU budget is checked
// as the data is consumed: jpeg_skip_scanlines entropy-decodes the rows it
// skips without calling the progress monitor. The slices are large enough
// that libjpeg-turbo's Huffman decoder rarely leaves its fast path, which
// wants a few KiB of data ahead.
constexpr size_t kJpegFeedBytes = 256 << 10;

void OnInitSource(j_decompress_ptr /*cinfo*/) {}
void OnTermSource(j_decompress_ptr /*cinfo*/) {}

boolean OnFillInput(j_decompress_ptr cinfo) {
  JpegState* state = StateOf(reinterpret_cast<j_common_ptr>(cinfo));
  CheckBudget(state);
  if (state->fed < state->size) {
    const size_t count = std::min(kJpegFeedBytes, state->size - state->fed);
    state->source.next_input_byte = state->data + state->fed;
    state->source.bytes_in_buffer = count;
    state->fed += count;
    return TRUE;
  }
  // The data ended before libjpeg expected it to: a warning (a truncated
  // file), then a fake EOI, as jpeg_mem_src does.
  static constexpr JOCTET kEndOfImage[2] = {0xFF, JPEG_EOI};
  WARNMS(cinfo, JWRN_JPEG_EOF);
  state->source.next_input_byte = kEndOfImage;
  state->source.bytes_in_buffer = sizeof kEndOfImage;
  return TRUE;
}

void OnSkipInput(j_decompress_ptr cinfo, long count) {
  JpegState* state = StateOf(reinterpret_cast<j_common_ptr>(cinfo));
  if (count <= 0) return;
  auto remaining = static_cast<size_t>(count);
  while (remaining > state->source.bytes_in_buffer) {
    remaining -= state->source.bytes_in_buffer;
    const bool at_end = state->fed >= state->size;
    OnFillInput(cinfo);
    if (at_end) return;  // the fake EOI is next
  }
  state->source.next_input_byte += remaining;
  state->source.bytes_in_buffer -= remaining;
}

// ---- Decoding -------------------------------------------------------------------

constexpr int kRowsPerCall = 16;
constexpr int kScratchOffset = 8;  // bytes: a row aligned to 8, not 16

// R from RGB pixels. A plain loop over every third byte is not vectorised at
// -O2 and cost more than the region saves (0.35 ms for 640x280); OpenCV's
// cv::hal::split8u is, but writes non-temporal stores to aligned rows.
void TakeRed(const JSAMPLE* rgb, unsigned char* red, int pixels) {
  int x = 0;
#if CV_SIMD
  constexpr int kLanes = cv::v_uint8::nlanes;
  for (; x + kLanes <= pixels; x += kLanes) {
    cv::v_uint8 r;
    cv::v_uint8 g;
    cv::v_uint8 b;
    cv::v_load_deinterleave(rgb + 3 * x, r, g, b);
    cv::v_store(red + x, r);
  }
#endif
  for (; x < pixels; ++x) red[x] = rgb[3 * x];
}

// DecodeSteps' parts. Each may leave by longjmp (through Fail or libjpeg's
// error_exit); they hold nothing that needs a destructor.

// The header read and checked, the output chosen, the decompressor started.
// As cv::imdecode: libjpeg's default DCT (islow), fancy upsampling and block
// smoothing; BGR straight from libjpeg-turbo, grey from Y alone. Red: from a
// grey file the grey itself, else the R of libjpeg's RGB, through a few rows
// of scratch. Returns whether red goes through RGB.
bool StartDecode(JpegState* state) {
  j_decompress_ptr cinfo = &state->cinfo;
  jpeg_create_decompress(cinfo);
  cinfo->mem->max_memory_to_use = state->max_memory;
  cinfo->progress = &state->progress;
  state->source.init_source = OnInitSource;
  state->source.fill_input_buffer = OnFillInput;
  state->source.skip_input_data = OnSkipInput;
  state->source.resync_to_restart = jpeg_resync_to_restart;
  state->source.term_source = OnTermSource;
  cinfo->src = &state->source;
  jpeg_read_header(cinfo, TRUE);
  if (static_cast<int>(cinfo->image_width) != state->width ||
      static_cast<int>(cinfo->image_height) != state->height) {
    Fail(state, JpegFailure::kUnexpected);
  }
  switch (cinfo->jpeg_color_space) {
    case JCS_GRAYSCALE:
    case JCS_YCbCr:
    case JCS_RGB:
      break;
    default:
      state->color_space = static_cast<int>(cinfo->jpeg_color_space);
      Fail(state, JpegFailure::kColorSpace);
  }
  const bool grey_file = cinfo->jpeg_color_space == JCS_GRAYSCALE;
  const bool via_rgb = state->output == Output::kRed && !grey_file;
  const int components = state->output == Output::kBgr ? 3 : 1;
  cinfo->out_color_space = state->output == Output::kBgr ? JCS_EXT_BGR
                           : via_rgb                     ? JCS_EXT_RGB
                                                         : JCS_GRAYSCALE;
  cinfo->scale_num = 1;
  cinfo->scale_denom = static_cast<unsigned int>(state->scale_denom);
  jpeg_start_decompress(cinfo);
  if (static_cast<int>(cinfo->output_width) != state->out_width ||
      static_cast<int>(cinfo->output_height) != state->out_height ||
      cinfo->output_components != (via_rgb ? 3 : components)) {
    Fail(state, JpegFailure::kUnexpected);
  }
  return via_rgb;
}

// Columns: one more on either side than asked, where the frame has one (see
// the top of the file), and at least 2 * max_h_samp_factor + 1: with a
// component 2 samples wide or less libjpeg-turbo falls back from fancy to
// plain upsampling, which changes every pixel. libjpeg then rounds the start
// down to an iMCU. Sets decoded_left/right; returns the first column libjpeg
// writes.
int CropColumns(JpegState* state) {
  j_decompress_ptr cinfo = &state->cinfo;
  int crop_first = 0;
  state->decoded_left = 0;
  state->decoded_right = state->out_width;
  int begin = std::max(0, state->left - 1);
  int end = std::min(state->out_width, state->right + 1);
  const int min_width = 2 * cinfo->max_h_samp_factor + 1;
  if (end - begin < min_width) {
    end = std::min(state->out_width, begin + min_width);
    begin = std::max(0, end - min_width);
  }
  if (begin > 0 || end < state->out_width) {
    auto x = static_cast<JDIMENSION>(begin);
    auto count = static_cast<JDIMENSION>(end - begin);
    jpeg_crop_scanline(cinfo, &x, &count);
    crop_first = static_cast<int>(x);
    const int crop_end = crop_first + static_cast<int>(count);
    if (crop_first > state->left || crop_end < state->right || crop_end > state->out_width ||
        static_cast<int>(cinfo->output_width) != crop_end - crop_first) {
      Fail(state, JpegFailure::kUnexpected);
    }
    state->decoded_left = crop_first == 0 ? 0 : crop_first + 1;
    state->decoded_right = crop_end == state->out_width ? crop_end : crop_end - 1;
  }
  return crop_first;
}

// Scratch rows: the RGB of a red region; the last row of the frame when
// reading to the end. None when neither is needed.
JSAMPARRAY ScratchRows(JpegState* state, bool via_rgb) {
  j_decompress_ptr cinfo = &state->cinfo;
  if (!via_rgb && !(state->read_to_end && state->bottom < state->out_height)) return nullptr;
  const auto row_width = static_cast<int>(cinfo->output_width);  // after the crop
  JSAMPARRAY scratch = (*cinfo->mem->alloc_sarray)(
      reinterpret_cast<j_common_ptr>(cinfo), JPOOL_IMAGE,
      static_cast<JDIMENSION>(row_width * cinfo->output_components + kScratchOffset), kRowsPerCall);
  // libjpeg-turbo's SIMD colour conversion writes a 32-byte aligned row with
  // non-temporal stores, which TakeRed would then wait for (0.15 ms at
  // 640x280, as much again as the transform of the region saves), and
  // alloc_sarray's rows are aligned: the scratch rows are moved off it.
  for (int i = 0; i < kRowsPerCall; ++i) scratch[i] += kScratchOffset;
  return scratch;
}

// Rows [top, bottom) into the output, from its column `first_column` on.
void ReadRegionRows(JpegState* state, bool via_rgb, unsigned char* first_column,
                    JSAMPARRAY scratch) {
  j_decompress_ptr cinfo = &state->cinfo;
  const auto row_width = static_cast<int>(cinfo->output_width);
  if (state->top > 0) {
    const auto skip = static_cast<JDIMENSION>(state->top);
    if (jpeg_skip_scanlines(cinfo, skip) != skip) Fail(state, JpegFailure::kNoProgress);
    CheckBudget(state);
  }
  JSAMPROW rows[kRowsPerCall];
  while (static_cast<int>(cinfo->output_scanline) < state->bottom) {
    const int first = static_cast<int>(cinfo->output_scanline);
    const int count = std::min(kRowsPerCall, state->bottom - first);
    for (int i = 0; i < count; ++i) {
      rows[i] =
          via_rgb ? scratch[i] : first_column + static_cast<size_t>(first + i) * state->stride;
    }
    const auto got =
        static_cast<int>(jpeg_read_scanlines(cinfo, rows, static_cast<JDIMENSION>(count)));
    if (got == 0) Fail(state, JpegFailure::kNoProgress);
    if (via_rgb) {
      for (int i = 0; i < got; ++i) {
        TakeRed(scratch[i], first_column + static_cast<size_t>(first + i) * state->stride,
                row_width);
      }
    }
  }
}

void DecodeSteps(JpegState* state) {
  j_decompress_ptr cinfo = &state->cinfo;
  const bool via_rgb = StartDecode(state);
  const int components = state->output == Output::kBgr ? 3 : 1;
  const int crop_first = CropColumns(state);
  unsigned char* const first_column =
      state->out + static_cast<size_t>(crop_first) * static_cast<size_t>(components);
  JSAMPARRAY scratch = ScratchRows(state, via_rgb);
  ReadRegionRows(state, via_rgb, first_column, scratch);
  if (state->bottom < state->out_height) {
    // Stopping early: jpeg_destroy_decompress aborts.
    if (!state->read_to_end) return;
    // The rest, down to EOI: skipped up to the last row, which is read so
    // that libjpeg consumes the data (skipping to the very end would only
    // declare the end reached).
    const auto rest = static_cast<JDIMENSION>(state->out_height - state->bottom);
    if (rest > 1 && jpeg_skip_scanlines(cinfo, rest - 1) != rest - 1) {
      Fail(state, JpegFailure::kNoProgress);
    }
    if (jpeg_read_scanlines(cinfo, scratch, 1) != 1) Fail(state, JpegFailure::kNoProgress);
  }
  // Reads the rest up to EOI (a single-scan file's trailing markers): bounded
  // by the byte cap; a warning there (garbage, a truncated tail) still counts.
  jpeg_finish_decompress(cinfo);
}

// True if the image was decoded; else state->failure says why.
bool RunJpeg(JpegState* state) {
  state->cinfo.err = jpeg_std_error(&state->error);
  state->error.error_exit = OnErrorExit;
  state->error.emit_message = OnEmitMessage;
  state->error.output_message = OnOutputMessage;
  state->cinfo.client_data = state;
  state->progress.progress_monitor = OnProgress;
  if (setjmp(state->jump) != 0) {
    // Safe on a struct jpeg_create_decompress never filled: it is zeroed.
    jpeg_destroy_decompress(&state->cinfo);
    return false;
  }
  DecodeSteps(state);
  jpeg_destroy_decompress(&state->cinfo);
  return true;
}

absl::string_view LibraryMessage(const char* message) {
  return absl::string_view(message).substr(0, kMaxLibraryMessage);
}

}  // namespace

absl::Status DecodeJpeg(const CodecRequest& request, cv::Mat& out, cv::Rect& decoded) {
  JpegState state{};
  state.data = reinterpret_cast<const unsigned char*>(request.bytes.data());
  state.size = request.bytes.size();
  state.out = out.data;
  state.stride = out.step[0];
  state.width = request.width;
  state.height = request.height;
  state.scale_denom = request.scale_denom;
  state.out_width = out.cols;
  state.out_height = out.rows;
  state.output = request.output;
  state.top = request.top;
  state.bottom = request.bottom;
  state.left = request.left;
  state.right = request.right;
  state.read_to_end = request.read_to_end;
  state.accept_damaged = request.accept_damaged;
  state.max_scans = request.max_progressive_scans;
  state.budget = request.budget;
  // A progressive (or other multi-scan) file keeps every DCT coefficient in
  // memory until its last scan: 2 bytes per sample, so at most 6 bytes per
  // pixel for three full-resolution components. 8 per pixel plus 16 MiB of
  // working memory is enough for any honest file and stops libjpeg from
  // allocating more ("Backing store not supported" then).
  state.max_memory = static_cast<long>(int64_t{8} * request.width * request.height + (16 << 20));
  if (RunJpeg(&state)) {
    decoded = cv::Rect(state.decoded_left, request.top, state.decoded_right - state.decoded_left,
                       request.bottom - request.top);
    return absl::OkStatus();
  }

  switch (state.failure) {
    case JpegFailure::kDamaged:
      return absl::InvalidArgumentError(
          absl::StrCat("damaged JPEG frame: ", LibraryMessage(state.message)));
    case JpegFailure::kScanLimit:
      return absl::InvalidArgumentError(
          absl::StrCat("the JPEG frame has more than ", state.max_scans,
                       " scans, the scan limit (max_progressive_scans)"));
    case JpegFailure::kBudget:
      return BudgetExceeded("JPEG", request.budget->budget());
    case JpegFailure::kColorSpace:
      return absl::InvalidArgumentError(
          absl::StrCat("JPEG frames in libjpeg colour space ", state.color_space,
                       " (CMYK, YCCK or unknown) are not supported: send grey, YCbCr or RGB"));
    case JpegFailure::kUnexpected:
    case JpegFailure::kNoProgress:
      return absl::InvalidArgumentError("the JPEG frame decoded to an unexpected image");
    case JpegFailure::kError:
    case JpegFailure::kNone:
      break;
  }
  if (state.error.msg_code == JERR_NO_BACKING_STORE) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the JPEG frame needs more than ", state.max_memory >> 20, " MiB of decoder memory"));
  }
  return absl::InvalidArgumentError(
      absl::StrCat("cannot decode the JPEG frame: ", LibraryMessage(state.message)));
}

}  // namespace lane::decode::internal
