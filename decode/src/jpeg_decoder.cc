// JPEG through libjpeg-turbo's libjpeg API.
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

enum class Failure {
  kNone,
  kError,       // libjpeg's error_exit: message[] holds libjpeg's message
  kDamaged,     // a libjpeg warning and !accept_damaged: message[] likewise
  kScanLimit,   // more than max_scans scans
  kDeadline,    // the deadline passed
  kColorSpace,  // not grey, YCbCr or RGB (color_space holds it)
  kUnexpected,  // libjpeg's idea of the image differs from the header's
  kNoProgress,  // jpeg_read_scanlines returned no rows
};

struct JpegState {
  jpeg_decompress_struct cinfo;
  jpeg_error_mgr error;
  jpeg_progress_mgr progress;
  std::jmp_buf jump;

  // Inputs.
  const unsigned char* data;
  size_t size;
  unsigned char* out;  // height rows of stride bytes
  size_t stride;
  int width;
  int height;
  bool gray;
  bool accept_damaged;
  int max_scans;
  absl::Time deadline;
  long max_memory;  // bytes, libjpeg's max_memory_to_use

  // Outcome.
  Failure failure;
  int color_space;
  char message[JMSG_LENGTH_MAX];
};
static_assert(std::is_trivially_destructible_v<JpegState>,
              "JpegState is left by longjmp: no destructors");

JpegState* StateOf(j_common_ptr cinfo) { return static_cast<JpegState*>(cinfo->client_data); }

[[noreturn]] void Fail(JpegState* state, Failure failure) {
  if (state->failure == Failure::kNone) state->failure = failure;
  std::longjmp(state->jump, 1);
}

// error_exit: an error libjpeg cannot continue after.
[[noreturn]] void OnErrorExit(j_common_ptr cinfo) {
  JpegState* state = StateOf(cinfo);
  if (state->failure == Failure::kNone) (*cinfo->err->format_message)(cinfo, state->message);
  Fail(state, Failure::kError);
}

// emit_message: level -1 is a warning (damaged data libjpeg works around),
// 0 and up are trace messages. Nothing is ever printed.
void OnEmitMessage(j_common_ptr cinfo, int msg_level) {
  if (msg_level >= 0) return;
  ++cinfo->err->num_warnings;
  JpegState* state = StateOf(cinfo);
  if (state->accept_damaged) return;
  if (state->failure == Failure::kNone) (*cinfo->err->format_message)(cinfo, state->message);
  Fail(state, Failure::kDamaged);
}

void OnOutputMessage(j_common_ptr /*cinfo*/) {}

// Called before each iMCU row of each scan libjpeg consumes (progressive and
// other multi-scan files) and before each jpeg_read_scanlines.
void OnProgress(j_common_ptr cinfo) {
  JpegState* state = StateOf(cinfo);
  // Installed on a decompressor only, whose struct starts with the common fields.
  const auto* decompress = reinterpret_cast<j_decompress_ptr>(cinfo);
  // input_scan_number counts the SOS markers read, so the first call after
  // scan max_scans + 1 has started refuses it before any of it is decoded.
  if (decompress->input_scan_number > state->max_scans) Fail(state, Failure::kScanLimit);
  if (absl::Now() > state->deadline) Fail(state, Failure::kDeadline);
}

constexpr int kRowsPerCall = 16;

// May leave by longjmp (through Fail or libjpeg's error_exit).
void DecodeSteps(JpegState* state) {
  j_decompress_ptr cinfo = &state->cinfo;
  jpeg_create_decompress(cinfo);
  cinfo->mem->max_memory_to_use = state->max_memory;
  cinfo->progress = &state->progress;
  jpeg_mem_src(cinfo, state->data, static_cast<unsigned long>(state->size));
  jpeg_read_header(cinfo, TRUE);
  if (static_cast<int>(cinfo->image_width) != state->width ||
      static_cast<int>(cinfo->image_height) != state->height) {
    Fail(state, Failure::kUnexpected);
  }
  switch (cinfo->jpeg_color_space) {
    case JCS_GRAYSCALE:
    case JCS_YCbCr:
    case JCS_RGB:
      break;
    default:
      state->color_space = static_cast<int>(cinfo->jpeg_color_space);
      Fail(state, Failure::kColorSpace);
  }
  // As cv::imdecode: libjpeg's default DCT (islow), fancy upsampling and
  // block smoothing; BGR straight from libjpeg-turbo, grey from Y alone.
  cinfo->out_color_space = state->gray ? JCS_GRAYSCALE : JCS_EXT_BGR;
  jpeg_start_decompress(cinfo);
  if (static_cast<int>(cinfo->output_width) != state->width ||
      static_cast<int>(cinfo->output_height) != state->height ||
      cinfo->output_components != (state->gray ? 1 : 3)) {
    Fail(state, Failure::kUnexpected);
  }
  JSAMPROW rows[kRowsPerCall];
  while (cinfo->output_scanline < cinfo->output_height) {
    const int first = static_cast<int>(cinfo->output_scanline);
    const int count = std::min(kRowsPerCall, state->height - first);
    for (int i = 0; i < count; ++i) rows[i] = state->out + (first + i) * state->stride;
    if (jpeg_read_scanlines(cinfo, rows, static_cast<JDIMENSION>(count)) == 0) {
      Fail(state, Failure::kNoProgress);
    }
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

absl::Status DecodeJpeg(const CodecRequest& request, cv::Mat& out) {
  JpegState state{};
  state.data = reinterpret_cast<const unsigned char*>(request.bytes.data());
  state.size = request.bytes.size();
  state.out = out.data;
  state.stride = out.step[0];
  state.width = request.width;
  state.height = request.height;
  state.gray = request.gray;
  state.accept_damaged = request.accept_damaged;
  state.max_scans = request.max_progressive_scans;
  state.deadline = request.deadline;
  // A progressive (or other multi-scan) file keeps every DCT coefficient in
  // memory until its last scan: 2 bytes per sample, so at most 6 bytes per
  // pixel for three full-resolution components. 8 per pixel plus 16 MiB of
  // working memory is enough for any honest file and stops libjpeg from
  // allocating more ("Backing store not supported" then).
  state.max_memory = static_cast<long>(int64_t{8} * request.width * request.height + (16 << 20));
  if (RunJpeg(&state)) return absl::OkStatus();

  switch (state.failure) {
    case Failure::kDamaged:
      return absl::InvalidArgumentError(
          absl::StrCat("damaged JPEG frame: ", LibraryMessage(state.message)));
    case Failure::kScanLimit:
      return absl::InvalidArgumentError(
          absl::StrCat("the JPEG frame has more than ", state.max_scans,
                       " scans, the scan limit (max_progressive_scans)"));
    case Failure::kDeadline:
      return DeadlineExceeded("JPEG", request.budget);
    case Failure::kColorSpace:
      return absl::InvalidArgumentError(
          absl::StrCat("JPEG frames in libjpeg colour space ", state.color_space,
                       " (CMYK, YCCK or unknown) are not supported: send grey, YCbCr or RGB"));
    case Failure::kUnexpected:
    case Failure::kNoProgress:
      return absl::InvalidArgumentError("the JPEG frame decoded to an unexpected image");
    case Failure::kError:
    case Failure::kNone:
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
