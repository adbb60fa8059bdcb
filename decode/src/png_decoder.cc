// PNG through libpng's progressive ("push") reader.
//
// Why not png_read_row/png_read_image: when the sequential reader finishes
// the last row it drains the rest of the zlib stream (png_read_finish_IDAT
// inflates until the stream ends), so IDAT data that inflates to gigabytes
// beyond the image costs seconds. The push reader inflates into one row at a
// time and stops at the first byte past the last row ("Extra compressed data
// in IDAT"); what follows is only CRC-checked, at memory speed, and the byte
// cap bounds that. png_read_end is never called.
//
// A region: every row down to the region's last is still inflated and
// unfiltered (each row's filter refers to the one above), only the region's
// rows are stored, and unless the request reads to the end no more input is
// fed after the slice (kPngFeedBytes) in which the last pass delivered the
// region's last row. Red output and scaling go through a full-resolution BGR
// or grey copy of the region's rows, reduced afterwards.
//
// libpng reports errors through our error callback, which longjmps to the
// setjmp in RunPng (png_jmpbuf). Everything the decode touches between the
// two lives in one trivially destructible PngState, and the functions it may
// leave by longjmp hold nothing with a destructor.
#include <png.h>

#include <algorithm>
#include <csetjmp>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <vector>

#include "absl/strings/str_cat.h"
#include "codecs.h"

namespace lane::decode::internal {
namespace {

enum class PngFailure {
  kNone,
  kError,       // libpng's error: message[] holds libpng's message
  kDamaged,     // a libpng warning and !accept_damaged: message[] likewise
  kBudget,      // the CPU budget was used up
  kUnexpected,  // libpng's idea of the image differs from the header's
};

struct PngState {
  png_structp png;
  png_infop info;

  // Inputs.
  const unsigned char* data;
  size_t size;
  unsigned char* out;  // height rows of stride bytes, full resolution
  size_t stride;
  int width;
  int height;
  bool gray;
  int first_row;  // rows [first_row, end_row) are stored
  int end_row;
  bool read_to_end;
  bool accept_damaged;
  CpuBudget* budget;

  // Progress.
  bool interlaced;
  bool rows_done;    // the last row of the last pass was delivered
  bool region_done;  // end_row - 1 of the last pass was delivered
  bool end_seen;     // IEND was read

  // Outcome.
  PngFailure failure;
  char message[kMaxLibraryMessage + 1];
};
static_assert(std::is_trivially_destructible_v<PngState>,
              "PngState is left by longjmp: no destructors");

// Input is fed to libpng in slices of this size, the CPU budget checked
// between them (the rows' own checks do not see CRC-only skipping).
constexpr size_t kPngFeedBytes = 64 << 10;
// Largest non-IDAT chunk libpng accepts without a warning (so, unless
// accept_damaged, at all): PLTE is 768 bytes; everything else is ignored,
// but libpng's push reader buffers a chunk whole before skipping it.
constexpr png_alloc_size_t kMaxChunkBytes = 1 << 20;
// Ancillary chunks kept in libpng's list (sPLT, unknown): none are wanted.
constexpr png_uint_32 kMaxCachedChunks = 32;

PngState* StateOf(png_structp png) { return static_cast<PngState*>(png_get_error_ptr(png)); }

void Record(PngState* state, PngFailure failure, const char* message) {
  if (state->failure != PngFailure::kNone) return;
  state->failure = failure;
  std::strncpy(state->message, message, kMaxLibraryMessage);
  state->message[kMaxLibraryMessage] = '\0';
}

// Must not return (libpng would print the message and then longjmp).
[[noreturn]] void OnError(png_structp png, png_const_charp message) {
  Record(StateOf(png), PngFailure::kError, message);
  png_longjmp(png, 1);
}

void OnWarning(png_structp png, png_const_charp message) {
  PngState* state = StateOf(png);
  if (state->accept_damaged) return;
  Record(state, PngFailure::kDamaged, message);
  png_error(png, message);  // does not return
}

[[noreturn]] void Fail(png_structp png, PngFailure failure) {
  Record(StateOf(png), failure, "");
  png_error(png, "");
}

void CheckBudget(png_structp png, const PngState* state) {
  if (state->budget->Exceeded()) Fail(png, PngFailure::kBudget);
}

// After the chunks before the first IDAT: the output transformations.
void OnInfo(png_structp png, png_infop info) {
  PngState* state = StateOf(png);
  png_uint_32 width = 0;
  png_uint_32 height = 0;
  int bit_depth = 0;
  int color_type = 0;
  int interlace = 0;
  png_get_IHDR(png, info, &width, &height, &bit_depth, &color_type, &interlace, nullptr, nullptr);
  if (width != static_cast<png_uint_32>(state->width) ||
      height != static_cast<png_uint_32>(state->height)) {
    Fail(png, PngFailure::kUnexpected);
  }
  // What cv::imdecode asks of libpng: palette -> RGB and grey < 8 bits -> 8
  // (png_set_expand; it also turns tRNS into alpha, which is then dropped, so
  // the colours are the same), 16 bits -> 8 by dropping the low byte, no
  // alpha, BGR order or grey by the 0.299/0.587 weights.
  png_set_expand(png);
  png_set_strip_16(png);
  png_set_strip_alpha(png);
  const bool colour = (color_type & PNG_COLOR_MASK_COLOR) != 0;
  if (state->gray) {
    if (colour) png_set_rgb_to_gray(png, PNG_ERROR_ACTION_NONE, 0.299, 0.587);
  } else if (colour) {
    png_set_bgr(png);
  } else {
    png_set_gray_to_rgb(png);
  }
  state->interlaced = interlace != PNG_INTERLACE_NONE;
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  const png_byte channels = state->gray ? 1 : 3;
  if (png_get_channels(png, info) != channels || png_get_bit_depth(png, info) != 8 ||
      png_get_rowbytes(png, info) != static_cast<size_t>(state->width) * channels) {
    Fail(png, PngFailure::kUnexpected);
  }
}

// Each row of each pass. With interlace handling libpng delivers every image
// row in every pass (new_row is null for a row the pass does not touch) and
// the seventh pass (6) is always the last, so (height - 1, last pass) is the
// final call.
void OnRow(png_structp png, png_bytep new_row, png_uint_32 row, int pass) {
  PngState* state = StateOf(png);
  CheckBudget(png, state);
  if (row >= static_cast<png_uint_32>(state->height)) Fail(png, PngFailure::kUnexpected);
  const bool stored = row >= static_cast<png_uint_32>(state->first_row) &&
                      row < static_cast<png_uint_32>(state->end_row);
  if (new_row != nullptr && stored) {
    png_progressive_combine_row(png, state->out + row * state->stride, new_row);
  }
  const int last_pass = state->interlaced ? 6 : 0;
  if (pass != last_pass) return;
  if (row + 1 == static_cast<png_uint_32>(state->height)) state->rows_done = true;
  // Not png_process_data_pause: called here, in the middle of an IDAT chunk,
  // libpng 1.6.39 then subtracts the chunk from the buffer size the pause
  // zeroed, and runs on through memory. DecodeSteps stops feeding instead.
  if (row + 1 == static_cast<png_uint_32>(state->end_row)) state->region_done = true;
}

void OnEnd(png_structp png, png_infop /*info*/) { StateOf(png)->end_seen = true; }

// May leave by longjmp (through png_error).
void DecodeSteps(PngState* state) {
  png_structp png = state->png;
  png_set_progressive_read_fn(png, state, OnInfo, OnRow, OnEnd);
  png_set_user_limits(png, static_cast<png_uint_32>(state->width),
                      static_cast<png_uint_32>(state->height));
  png_set_chunk_cache_max(png, kMaxCachedChunks);
  png_set_chunk_malloc_max(png, kMaxChunkBytes);
  // Every chunk but IHDR, PLTE, tRNS, IDAT and IEND is skipped unread: text
  // and iCCP (compressed, so bombs of their own), EXIF, and so on. Grey
  // output keeps gAMA and sRGB: libpng's RGB -> grey is done in linear light
  // when the file states its gamma, as in cv::imdecode.
  png_set_keep_unknown_chunks(png, PNG_HANDLE_CHUNK_NEVER, nullptr, -1);
  if (state->gray) {
    static constexpr png_byte kGammaChunks[] = "gAMA\0sRGB";
    png_set_keep_unknown_chunks(png, PNG_HANDLE_CHUNK_AS_DEFAULT, kGammaChunks, 2);
  }
  size_t pos = 0;
  while (pos < state->size && !state->end_seen && (state->read_to_end || !state->region_done)) {
    const size_t count = std::min(kPngFeedBytes, state->size - pos);
    // libpng only reads the buffer; its API predates const.
    png_process_data(png, state->info, const_cast<png_bytep>(state->data + pos), count);
    pos += count;
    CheckBudget(png, state);
  }
}

// True if libpng went through the data without an error; else
// state->failure says why.
bool RunPng(PngState* state) {
  state->png = png_create_read_struct(PNG_LIBPNG_VER_STRING, state, OnError, OnWarning);
  if (state->png == nullptr) {
    Record(state, PngFailure::kError, "out of memory");
    return false;
  }
  state->info = png_create_info_struct(state->png);
  if (state->info == nullptr) {
    png_destroy_read_struct(&state->png, nullptr, nullptr);
    Record(state, PngFailure::kError, "out of memory");
    return false;
  }
  if (setjmp(png_jmpbuf(state->png)) != 0) {
    png_destroy_read_struct(&state->png, &state->info, nullptr);
    return false;
  }
  DecodeSteps(state);
  png_destroy_read_struct(&state->png, &state->info, nullptr);
  return true;
}

// The R channel of BGR rows [first, end) of `bgr`, into `red`.
void TakeRed(const cv::Mat& bgr, int first, int end, cv::Mat& red) {
  for (int y = first; y < end; ++y) {
    const unsigned char* in = bgr.ptr(y);
    unsigned char* r = red.ptr(y);
    for (int x = 0; x < bgr.cols; ++x) r[x] = in[3 * x + 2];
  }
}

// `full` rows [first, end) (full resolution) reduced by `scale` into `out`
// rows [first / scale, ceil(end / scale)): each output sample the mean of
// the samples of its scale x scale block inside the image, rounded to
// nearest. `first` is a multiple of scale, and `end` too unless it is the
// image's height.
void BoxReduce(const cv::Mat& full, int first, int end, int scale, cv::Mat& out) {
  const int channels = full.channels();
  const int out_cols = out.cols;
  std::vector<uint32_t> sums(static_cast<size_t>(out_cols) * channels);
  for (int oy = first / scale; oy * scale < end; ++oy) {
    std::fill(sums.begin(), sums.end(), 0);
    const int y_end = std::min(end, (oy + 1) * scale);
    for (int y = oy * scale; y < y_end; ++y) {
      const unsigned char* in = full.ptr(y);
      for (int x = 0; x < full.cols; ++x) {
        for (int c = 0; c < channels; ++c) {
          sums[static_cast<size_t>(x / scale) * channels + c] += in[x * channels + c];
        }
      }
    }
    const int rows = y_end - oy * scale;
    unsigned char* o = out.ptr(oy);
    for (int ox = 0; ox < out_cols; ++ox) {
      const int cols = std::min(full.cols, (ox + 1) * scale) - ox * scale;
      const uint32_t count = static_cast<uint32_t>(rows * cols);
      for (int c = 0; c < channels; ++c) {
        const size_t i = static_cast<size_t>(ox) * channels + c;
        o[i] = static_cast<unsigned char>((sums[i] + count / 2) / count);
      }
    }
  }
}

}  // namespace

absl::Status DecodePng(const CodecRequest& request, cv::Mat& out, cv::Rect& decoded) {
  // Rows [first, end) of the full-resolution image hold the output's rows
  // [request.top, request.bottom).
  const int scale = request.scale_denom;
  const int first = request.top * scale;
  const int end = std::min(request.height, request.bottom * scale);
  const bool gray = request.output == Output::kGray;
  // Where libpng's rows go: `out` itself, or a full-resolution copy of the
  // rows for red output (BGR) and scaling.
  cv::Mat work;
  if (request.output == Output::kRed || scale != 1) {
    work.create(request.height, request.width, gray ? CV_8UC1 : CV_8UC3);
  } else {
    work = out;
  }

  PngState state{};
  state.data = reinterpret_cast<const unsigned char*>(request.bytes.data());
  state.size = request.bytes.size();
  state.out = work.data;
  state.stride = work.step[0];
  state.width = request.width;
  state.height = request.height;
  state.gray = gray;
  state.first_row = first;
  state.end_row = end;
  state.read_to_end = request.read_to_end;
  state.accept_damaged = request.accept_damaged;
  state.budget = request.budget;
  if (!RunPng(&state)) {
    switch (state.failure) {
      case PngFailure::kDamaged:
        return absl::InvalidArgumentError(absl::StrCat("damaged PNG frame: ", state.message));
      case PngFailure::kBudget:
        return BudgetExceeded("PNG", request.budget->budget());
      case PngFailure::kUnexpected:
        return absl::InvalidArgumentError("the PNG frame decoded to an unexpected image");
      case PngFailure::kError:
      case PngFailure::kNone:
        break;
    }
    return absl::InvalidArgumentError(absl::StrCat("cannot decode the PNG frame: ", state.message));
  }
  if (!(request.read_to_end ? state.rows_done : state.region_done)) {
    return absl::InvalidArgumentError(
        "truncated PNG frame: the image data ends before the last row");
  }
  if (request.read_to_end && !state.end_seen && !state.accept_damaged) {
    return absl::InvalidArgumentError("truncated PNG frame: no IEND chunk after the image data");
  }

  if (request.output == Output::kRed) {
    cv::Mat red = scale == 1 ? out : cv::Mat(request.height, request.width, CV_8UC1);
    TakeRed(work, first, end, red);
    work = red;
  }
  if (scale != 1) BoxReduce(work, first, end, scale, out);
  decoded = cv::Rect(0, request.top, out.cols, request.bottom - request.top);
  return absl::OkStatus();
}

}  // namespace lane::decode::internal
