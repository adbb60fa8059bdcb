// Helpers shared by the decoder's test files.
#ifndef LANE_TESTS_DECODE_DECODE_TEST_UTIL_H_
#define LANE_TESTS_DECODE_DECODE_TEST_UTIL_H_

#include <gtest/gtest.h>

#include <chrono>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "absl/status/status.h"
#include "lane/decode/cpu_clock.h"
#include "lane/decode/image_decoder.h"

namespace lane::decode::test_util {

// Time bounds in these tests are of work, so they are measured in the test
// thread's CPU time, like the decoder's own budget: a loaded machine that
// leaves the thread waiting for a core does not make a refusal look slow.
using Clock = lane::decode::ThreadCpuClock;

// What one hostile frame may cost a worker at most, in CPU time (the
// hardening issue's bound). The refusals take milliseconds; the bound is
// loose so that a sanitized build cannot make the tests flaky. Decoding
// speed itself is measured in bench/, not here.
inline constexpr double kFrameBudgetMs = 1000;

inline double MillisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// cv::imdecode of `bytes` with `flags` (IMREAD_COLOR, IMREAD_GRAYSCALE, the
// IMREAD_REDUCED_* ones), EXIF orientation ignored.
inline cv::Mat CvDecodeWith(const std::string& bytes, int flags) {
  const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data()));
  return cv::imdecode(buffer, flags | cv::IMREAD_IGNORE_ORIENTATION);
}

inline cv::Mat CvDecode(const std::string& bytes, bool gray) {
  return CvDecodeWith(bytes, gray ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR);
}

inline DecodeOptions For(int width, int height, bool gray = false) {
  DecodeOptions options;
  options.width = width;
  options.height = height;
  options.gray = gray;
  return options;
}

inline ::testing::AssertionResult Identical(const cv::Mat& actual, const cv::Mat& expected) {
  if (actual.size() != expected.size() || actual.type() != expected.type()) {
    return ::testing::AssertionFailure()
           << "got " << actual.cols << "x" << actual.rows << " type " << actual.type()
           << ", expected " << expected.cols << "x" << expected.rows << " type " << expected.type();
  }
  cv::Mat diff;
  cv::absdiff(actual.reshape(1), expected.reshape(1), diff);
  const int differing = cv::countNonZero(diff);
  if (differing != 0) {
    double max_diff = 0;
    cv::Point where;
    cv::minMaxLoc(diff, nullptr, &max_diff, nullptr, &where);
    return ::testing::AssertionFailure()
           << differing << " of " << diff.total() << " samples differ, by up to " << max_diff
           << " (at sample column " << where.x << ", row " << where.y << ")";
  }
  return ::testing::AssertionSuccess();
}

// Decodes with DecodeImage and compares with cv::imdecode of the same bytes.
inline ::testing::AssertionResult SameAsOpenCv(const std::string& bytes, int width, int height,
                                               bool gray) {
  absl::StatusOr<cv::Mat> ours = DecodeImage(bytes, For(width, height, gray));
  if (!ours.ok()) return ::testing::AssertionFailure() << ours.status();
  const cv::Mat theirs = CvDecode(bytes, gray);
  if (theirs.empty()) return ::testing::AssertionFailure() << "cv::imdecode failed";
  return Identical(*ours, theirs);
}

inline void ExpectShortMessage(const absl::Status& status) {
  EXPECT_LT(status.message().size(), 200u) << status;
}

}  // namespace lane::decode::test_util

#endif  // LANE_TESTS_DECODE_DECODE_TEST_UTIL_H_
