#include "lane/threshold.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"

namespace lane {

absl::Status ThresholdOptions::Validate() const {
  if (!(quantile >= 0.0 && quantile < 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("threshold.quantile must lie in [0, 1), got ", quantile));
  }
  return absl::OkStatus();
}

float Quantile(std::vector<float>& values, double q) {
  if (values.empty()) return 0.f;
  q = std::clamp(q, 0.0, 1.0);
  const double pos = q * (values.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(pos));
  const double frac = pos - lo;
  std::nth_element(values.begin(), values.begin() + lo, values.end());
  const float v_lo = values[lo];
  if (frac == 0.0 || lo + 1 >= values.size()) return v_lo;
  const float v_hi = *std::min_element(values.begin() + lo + 1, values.end());
  return static_cast<float>(v_lo + frac * (v_hi - v_lo));
}

float ApplyQuantileThreshold(cv::Mat& image, double q) {
  CV_Assert(image.type() == CV_32FC1);
  // Negative responses are dropped first; they make up the bulk of the
  // pixels, so the quantile is computed over the positive values only and
  // the rank shifted by the number of zeros.
  thread_local std::vector<float> positives;
  positives.clear();
  const size_t n = image.total();
  for (int r = 0; r < image.rows; ++r) {
    float* row = image.ptr<float>(r);
    for (int c = 0; c < image.cols; ++c) {
      if (row[c] > 0.f) {
        positives.push_back(row[c]);
      } else {
        row[c] = 0.f;
      }
    }
  }
  const size_t zeros = n - positives.size();
  if (positives.empty()) return 0.f;
  const double pos = std::clamp(q, 0.0, 1.0) * (n - 1);
  float threshold = 0.f;
  if (pos >= static_cast<double>(zeros)) {
    // Rank within the positives: same interpolation as Quantile().
    const double rank = pos - zeros;
    const size_t lo = static_cast<size_t>(std::floor(rank));
    const double frac = rank - lo;
    std::nth_element(positives.begin(), positives.begin() + lo, positives.end());
    const float v_lo = positives[lo];
    threshold = v_lo;
    if (frac > 0 && lo + 1 < positives.size()) {
      const float v_hi = *std::min_element(positives.begin() + lo + 1, positives.end());
      threshold = static_cast<float>(v_lo + frac * (v_hi - v_lo));
    }
  } else if (pos > zeros - 1.0) {
    // Interpolating between the last zero and the smallest positive.
    const float v_hi = *std::min_element(positives.begin(), positives.end());
    threshold = static_cast<float>((pos - (zeros - 1.0)) * v_hi);
  }
  if (threshold > 0.f) {
    for (int r = 0; r < image.rows; ++r) {
      float* row = image.ptr<float>(r);
      for (int c = 0; c < image.cols; ++c) {
        if (row[c] < threshold) row[c] = 0.f;
      }
    }
  }
  return threshold;
}

}  // namespace lane
