#include "lane/stages/threshold.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"

namespace lane {

absl::Status ThresholdOptions::Validate() const {
  if (!(transverse_max_fraction > 0 && transverse_max_fraction <= 10) ||
      !(transverse_margin_m >= 0 && transverse_margin_m < 20)) {
    return absl::InvalidArgumentError(
        "threshold.transverse_max_fraction must lie in (0, 10] and transverse_margin_m in "
        "[0, 20) m");
  }
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

namespace {

// Floats [b, e), for range-for loops.
struct FloatSpan {
  const float* b;
  const float* e;
  const float* begin() const { return b; }
  const float* end() const { return e; }
};

// The k-th and (k+1)-th smallest (0-based) of `values`, all > 0 and <= vmax,
// found through one histogram so that only the bins holding them need a
// selection. `second` is only computed when asked for (k + 1 < size).
void KthPositives(FloatSpan values, size_t k, float vmax, bool want_second, float* first,
                  float* second) {
  constexpr int kBins = 256;
  const float scale = kBins / vmax;
  // Four histograms, value k into histogram k % 4, then added: neighbouring
  // pixels often share a bin, and one histogram's increments of the same
  // counter would wait on each other.
  int part[4][kBins + 1] = {};
  const size_t n = values.e - values.b;
  size_t i = 0;
  const auto bin_of = [&](float v) { return std::min(kBins, static_cast<int>(v * scale)); };
  for (; i + 4 <= n; i += 4) {
    ++part[0][bin_of(values.b[i])];
    ++part[1][bin_of(values.b[i + 1])];
    ++part[2][bin_of(values.b[i + 2])];
    ++part[3][bin_of(values.b[i + 3])];
  }
  for (; i < n; ++i) ++part[0][bin_of(values.b[i])];
  int counts[kBins + 1];
  for (int b = 0; b <= kBins; ++b) counts[b] = part[0][b] + part[1][b] + part[2][b] + part[3][b];
  size_t below = 0;
  int bin = 0;
  while (below + counts[bin] <= k) below += counts[bin++];
  thread_local std::vector<float> in_bin;
  in_bin.clear();
  for (float v : values) {
    if (bin_of(v) == bin) in_bin.push_back(v);
  }
  std::nth_element(in_bin.begin(), in_bin.begin() + (k - below), in_bin.end());
  *first = in_bin[k - below];
  if (!want_second) return;
  if (k + 1 - below < in_bin.size()) {
    // In the same bin: the smallest of those above the k-th.
    *second = *std::min_element(in_bin.begin() + (k + 1 - below), in_bin.end());
    return;
  }
  // The smallest value of the next non-empty bin.
  int next = bin + 1;
  while (counts[next] == 0) ++next;
  float smallest = vmax;
  for (float v : values) {
    if (bin_of(v) == next) smallest = std::min(smallest, v);
  }
  *second = smallest;
}

}  // namespace

float ApplyQuantileThreshold(cv::Mat& image, double q) {
  return ApplyQuantileThreshold(image, image, q);
}

float ApplyQuantileThreshold(const cv::Mat& in, cv::Mat& image, double q) {
  CV_Assert(in.type() == CV_32FC1);
  if (image.data != in.data) image.create(in.size(), CV_32FC1);
  // Negative responses are dropped first; they make up the bulk of the
  // pixels, so the quantile is computed over the positive values only, with
  // the rank shifted by the number of zeros.
  // Without branches: about half the filter's responses are positive, in
  // no order a branch predictor could follow. A row is first clamped at 0
  // (a select; it vectorises); then every value is written at the end of the
  // kept ones and kept only if positive, so the positives keep their order.
  // The maximum over all values is that over the positives (it starts at 0),
  // taken in four running maxima (max is exact in any order), so that the
  // comparisons do not wait on each other.
  thread_local std::vector<float> positives;  // grows to the largest image, never shrinks
  const size_t n = image.total();
  if (positives.size() < n) positives.resize(n);
  size_t kept = 0;
  float m0 = 0.f, m1 = 0.f, m2 = 0.f, m3 = 0.f;
  for (int r = 0; r < image.rows; ++r) {
    const float* src = in.ptr<float>(r);
    float* row = image.ptr<float>(r);
    float* out = positives.data();
    for (int c = 0; c < image.cols; ++c) row[c] = src[c] > 0.f ? src[c] : 0.f;
    const auto keep = [&](float v, float& running_max) {
      out[kept] = v;
      kept += v > 0.f;
      running_max = std::max(running_max, v);
    };
    int c = 0;
    for (; c + 4 <= image.cols; c += 4) {
      keep(row[c], m0);
      keep(row[c + 1], m1);
      keep(row[c + 2], m2);
      keep(row[c + 3], m3);
    }
    for (; c < image.cols; ++c) keep(row[c], m0);
  }
  const float vmax = std::max(std::max(m0, m1), std::max(m2, m3));
  const float* first_positive = positives.data();
  const float* end_positive = first_positive + kept;
  const size_t zeros = n - kept;
  if (kept == 0) return 0.f;
  const double pos = std::clamp(q, 0.0, 1.0) * (n - 1);
  float threshold = 0.f;
  if (pos >= static_cast<double>(zeros)) {
    // Rank within the positives; interpolated as in Quantile().
    const double rank = pos - zeros;
    const size_t lo = static_cast<size_t>(std::floor(rank));
    const double frac = rank - lo;
    const bool interpolate = frac > 0 && lo + 1 < kept;
    float v_lo = 0, v_hi = 0;
    KthPositives({first_positive, end_positive}, lo, vmax, interpolate, &v_lo, &v_hi);
    threshold = v_lo;
    if (interpolate) threshold = static_cast<float>(v_lo + frac * (v_hi - v_lo));
  } else if (pos > zeros - 1.0) {
    // Interpolating between the last zero and the smallest positive.
    const float v_hi = *std::min_element(first_positive, end_positive);
    threshold = static_cast<float>((pos - (zeros - 1.0)) * v_hi);
  }
  if (threshold > 0.f) {
    for (int r = 0; r < image.rows; ++r) {
      float* row = image.ptr<float>(r);
      for (int c = 0; c < image.cols; ++c) row[c] = row[c] < threshold ? 0.f : row[c];  // a select
    }
  }
  return threshold;
}

int SuppressTransverseRows(cv::Mat& image, const cv::Mat& valid, double max_fraction,
                           int margin_rows) {
  CV_Assert(image.type() == CV_32FC1 && valid.type() == CV_8UC1 && image.size() == valid.size());
  std::vector<bool> transverse(image.rows, false);
  int found = 0;
  for (int r = 0; r < image.rows; ++r) {
    const float* v = image.ptr<float>(r);
    const uint8_t* m = valid.ptr<uint8_t>(r);
    // Two plain counting loops (each vectorises; one mixing the types does not).
    int kept = 0, width = 0;
    for (int c = 0; c < image.cols; ++c) width += m[c] != 0;
    for (int c = 0; c < image.cols; ++c) kept += v[c] > 0.f;
    if (width > 0 && kept > max_fraction * width) {
      transverse[r] = true;
      ++found;
    }
  }
  if (found == 0) return 0;
  for (int r = 0; r < image.rows; ++r) {
    if (!transverse[r]) continue;
    const int a = std::max(0, r - margin_rows), b = std::min(image.rows - 1, r + margin_rows);
    image.rowRange(a, b + 1).setTo(0);
  }
  return found;
}

}  // namespace lane
