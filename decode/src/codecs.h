// The two codecs behind DecodeImage and DecodeImageRegion. Internal to
// lane_decode.
#ifndef LANE_DECODE_SRC_CODECS_H_
#define LANE_DECODE_SRC_CODECS_H_

#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"
#include "cpu_budget.h"

namespace lane::decode::internal {

enum class Output { kBgr, kGray, kRed };

// One decode, after the header checks passed.
struct CodecRequest {
  absl::string_view bytes;
  int width = 0;  // the header's size, already checked
  int height = 0;
  Output output = Output::kBgr;
  bool accept_damaged = false;
  int max_progressive_scans = 0;
  CpuBudget* budget = nullptr;  // the decode's CPU time; checked as it goes

  // The region, in the coordinates of the output (the frame scaled by
  // 1/scale_denom, each side rounded up), already checked: 0 <= top < bottom
  // <= the output's height, the same for the columns. DecodeImage: the
  // whole frame at scale 1.
  int scale_denom = 1;
  int top = 0;
  int bottom = 0;
  int left = 0;
  int right = 0;
  bool read_to_end = true;
};

// Decodes into `out`, preallocated CV_8UC3 (kBgr) or CV_8UC1 of the output's
// size, and sets `decoded` to the rectangle written (it contains the
// request's; outside it `out` is untouched).
absl::Status DecodeJpeg(const CodecRequest& request, cv::Mat& out, cv::Rect& decoded);
absl::Status DecodePng(const CodecRequest& request, cv::Mat& out, cv::Rect& decoded);

// Messages from the libraries are bounded by them (libjpeg: JMSG_LENGTH_MAX,
// libpng: PNG_MAX_ERROR_TEXT); this is the part of one quoted in a status, so
// that every message stays under 200 characters.
inline constexpr size_t kMaxLibraryMessage = 120;

// The status for a decode that used up its CPU budget.
absl::Status BudgetExceeded(absl::string_view format, absl::Duration budget);

}  // namespace lane::decode::internal

#endif  // LANE_DECODE_SRC_CODECS_H_
