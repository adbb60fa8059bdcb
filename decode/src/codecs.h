// The two codecs behind DecodeImage. Internal to lane_decode.
#ifndef LANE_DECODE_SRC_CODECS_H_
#define LANE_DECODE_SRC_CODECS_H_

#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"

namespace lane::decode::internal {

// One decode, after the header checks passed.
struct CodecRequest {
  absl::string_view bytes;
  int width = 0;  // the header's size, already checked
  int height = 0;
  bool gray = false;
  bool accept_damaged = false;
  int max_progressive_scans = 0;
  absl::Time deadline;    // absolute
  absl::Duration budget;  // the option, for the message
};

// Decodes into `out`, preallocated CV_8UC3 or CV_8UC1 of width x height.
absl::Status DecodeJpeg(const CodecRequest& request, cv::Mat& out);
absl::Status DecodePng(const CodecRequest& request, cv::Mat& out);

// Messages from the libraries are bounded by them (libjpeg: JMSG_LENGTH_MAX,
// libpng: PNG_MAX_ERROR_TEXT); this is the part of one quoted in a status, so
// that every message stays under 200 characters.
inline constexpr size_t kMaxLibraryMessage = 120;

// The status for an exceeded deadline.
absl::Status DeadlineExceeded(absl::string_view format, absl::Duration budget);

}  // namespace lane::decode::internal

#endif  // LANE_DECODE_SRC_CODECS_H_
