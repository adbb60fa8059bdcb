#include "lane/stages/line_detection.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

#include "absl/strings/str_cat.h"

namespace lane {

absl::Status HoughOptions::Validate() const {
  if (!(smooth_sigma_px >= 0 && smooth_sigma_px <= 20)) {
    return absl::InvalidArgumentError("hough.smooth_sigma_px must lie in [0, 20]");
  }
  if (!(min_peak >= 0 && std::isfinite(min_peak))) {
    return absl::InvalidArgumentError("hough.min_peak must be >= 0");
  }
  if (!(group_distance_m >= 0 && group_distance_m < 20)) {
    return absl::InvalidArgumentError("hough.group_distance_m must lie in [0, 20) metres");
  }
  return absl::OkStatus();
}

std::vector<double> ColumnProfile(const cv::Mat& thresholded, double smooth_sigma_px) {
  CV_Assert(thresholded.type() == CV_32FC1);
  const int w = thresholded.cols;
  std::vector<double> sums(w, 0.0);
  for (int r = 0; r < thresholded.rows; ++r) {
    const float* row = thresholded.ptr<float>(r);
    for (int c = 0; c < w; ++c) sums[c] += row[c];
  }
  for (double& s : sums) s /= thresholded.rows;
  if (smooth_sigma_px <= 0) return sums;
  // Gaussian smoothing with replicated ends.
  const int h = std::max(1, static_cast<int>(std::ceil(3 * smooth_sigma_px)));
  std::vector<double> k(2 * h + 1);
  double ks = 0;
  for (int i = -h; i <= h; ++i) {
    ks += k[i + h] = std::exp(-0.5 * i * i / (smooth_sigma_px * smooth_sigma_px));
  }
  std::vector<double> out(w, 0.0);
  for (int c = 0; c < w; ++c) {
    double acc = 0;
    for (int i = -h; i <= h; ++i) acc += k[i + h] * sums[std::clamp(c + i, 0, w - 1)];
    out[c] = acc / ks;
  }
  return out;
}

std::vector<ColumnPeak> FindColumnPeaks(const std::vector<double>& profile, double min_peak,
                                        double group_px) {
  std::vector<ColumnPeak> peaks;
  const int n = static_cast<int>(profile.size());
  for (int i = 1; i + 1 < n; ++i) {
    const double l = profile[i - 1], c = profile[i], r = profile[i + 1];
    if (c > l && c > r && c >= min_peak && c > 0) {
      // Parabola through the peak and its neighbours.
      const double denom = l - 2 * c + r;
      const double offset = denom < 0 ? 0.5 * (l - r) / denom : 0.0;
      peaks.push_back({i + std::clamp(offset, -0.5, 0.5), c - 0.25 * (l - r) * offset});
    }
  }
  if (peaks.empty() && n > 0) {
    const int i =
        static_cast<int>(std::max_element(profile.begin(), profile.end()) - profile.begin());
    if (profile[i] >= min_peak && profile[i] > 0)
      peaks.push_back({static_cast<double>(i), profile[i]});
  }
  // Grouping: strongest first; a peak within group_px of a kept one is merged
  // into it.
  std::sort(peaks.begin(), peaks.end(),
            [](const ColumnPeak& a, const ColumnPeak& b) { return a.value > b.value; });
  std::vector<ColumnPeak> kept;
  for (const auto& p : peaks) {
    bool near = false;
    for (const auto& k : kept) near = near || std::abs(k.x - p.x) < group_px;
    if (!near) kept.push_back(p);
  }
  std::sort(kept.begin(), kept.end(),
            [](const ColumnPeak& a, const ColumnPeak& b) { return a.x < b.x; });
  return kept;
}

}  // namespace lane
