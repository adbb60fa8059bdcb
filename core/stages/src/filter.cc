#include "lane/stages/filter.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"

namespace lane {

absl::Status FilterOptions::Validate() const {
  if (!(marking_width_m > 0 && marking_width_m < 2)) {
    return absl::InvalidArgumentError(
        absl::StrCat("filter.marking_width_m must lie in (0, 2) metres, got ", marking_width_m));
  }
  if (!(segment_length_m > 0 && segment_length_m < 50)) {
    return absl::InvalidArgumentError(
        absl::StrCat("filter.segment_length_m must lie in (0, 50) metres, got ", segment_length_m));
  }
  if (!(min_sigma_x_px > 0 && min_sigma_y_px > 0 && min_sigma_x_px < 50 && min_sigma_y_px < 50)) {
    return absl::InvalidArgumentError("filter.min_sigma_*_px must lie in (0, 50)");
  }
  if (!(kernel_extent_sigmas >= 1 && kernel_extent_sigmas <= 6)) {
    return absl::InvalidArgumentError("filter.kernel_extent_sigmas must lie in [1, 6]");
  }
  if (!std::isfinite(void_level) || void_level > 255 || void_margin_y_px < 0) {
    return absl::InvalidArgumentError(
        "filter.void_level must be a finite number <= 255 and void_margin_y_px >= 0");
  }
  if (!(bar_side_m >= 0 && bar_side_m < 2)) {
    return absl::InvalidArgumentError("filter.bar_side_m must lie in [0, 2) metres");
  }
  if (zero_border_x_px < 0 || zero_border_bottom_px < 0) {
    return absl::InvalidArgumentError("filter.zero_border_*_px must be >= 0");
  }
  return absl::OkStatus();
}

FilterKernels MakeFilterKernels(const FilterOptions& options, double metres_per_px_x,
                                double metres_per_px_y) {
  FilterKernels k;
  k.sigma_x_px = std::max(options.min_sigma_x_px, options.marking_width_m / metres_per_px_x);
  k.sigma_y_px = std::max(options.min_sigma_y_px, options.segment_length_m / metres_per_px_y);
  // Kernels longer than ~4x the IPM would only replicate the border; cap them.
  const int hx = std::min(
      64, std::max(1, static_cast<int>(std::ceil(options.kernel_extent_sigmas * k.sigma_x_px))));
  const int hy = std::min(
      128, std::max(1, static_cast<int>(std::ceil(options.kernel_extent_sigmas * k.sigma_y_px))));

  // Across the lane: f(x) = 1/s^2 exp(-x^2 / 2s^2) (1 - x^2/s^2), the negated
  // second derivative of a Gaussian (paper, section II-B). Truncation leaves a
  // small DC component, removed so flat regions respond with exactly 0; then
  // scaled so the positive lobe sums to 1 (a wide bright bar of contrast C
  // responds with about C).
  k.kx.create(2 * hx + 1, 1, CV_32F);
  const double sx2 = k.sigma_x_px * k.sigma_x_px;
  double sum = 0;
  std::vector<double> fx(2 * hx + 1);
  for (int i = -hx; i <= hx; ++i) {
    const double x2 = static_cast<double>(i) * i;
    fx[i + hx] = (1.0 / sx2) * std::exp(-x2 / (2 * sx2)) * (1.0 - x2 / sx2);
    sum += fx[i + hx];
  }
  const double dc = sum / fx.size();
  double positive = 0;
  for (double& v : fx) {
    v -= dc;
    if (v > 0) positive += v;
  }
  for (int i = 0; i < 2 * hx + 1; ++i) k.kx.at<float>(i) = static_cast<float>(fx[i] / positive);

  // Along the lane: f(y) = exp(-y^2 / 2s^2), normalised to sum 1.
  k.ky.create(2 * hy + 1, 1, CV_32F);
  const double sy2 = k.sigma_y_px * k.sigma_y_px;
  sum = 0;
  for (int i = -hy; i <= hy; ++i) sum += std::exp(-static_cast<double>(i) * i / (2 * sy2));
  for (int i = -hy; i <= hy; ++i) {
    k.ky.at<float>(i + hy) =
        static_cast<float>(std::exp(-static_cast<double>(i) * i / (2 * sy2)) / sum);
  }
  return k;
}

cv::Mat FilterTopView(const cv::Mat& ipm, const FilterKernels& kernels,
                      const FilterOptions& options) {
  CV_Assert(ipm.type() == CV_32FC1);
  // Correlation with replicated borders; both kernels are symmetric. The
  // zeroed borders (zero_border_x_px on each side, zero_border_bottom_px at
  // the bottom) are not filtered: the filter runs on the view's interior as
  // an OpenCV region of interest, which reads the pixels around it as they
  // are (replicating only past the view's own edges), so the interior is
  // what filtering the whole view gives there.
  const int bx = std::min(options.zero_border_x_px, ipm.cols / 2);
  const int by = std::min(options.zero_border_bottom_px, ipm.rows);
  cv::Mat out(ipm.size(), CV_32F);
  const cv::Rect interior(bx, 0, ipm.cols - 2 * bx, ipm.rows - by);
  if (interior.area() > 0) {
    cv::Mat inside = out(interior);
    cv::sepFilter2D(ipm(interior), inside, CV_32F, kernels.kx, kernels.ky, cv::Point(-1, -1), 0.0,
                    cv::BORDER_REPLICATE);
  }
  // Only the borders are zeroed (not the whole image first).
  for (int r = 0; r < out.rows; ++r) {
    float* row = out.ptr<float>(r);
    if (r >= interior.y + interior.height || interior.width <= 0) {
      std::fill(row, row + out.cols, 0.f);
    } else {
      std::fill(row, row + bx, 0.f);
      std::fill(row + out.cols - bx, row + out.cols, 0.f);
    }
  }
  return out;
}

cv::Mat VoidMask(const cv::Mat& ipm, const cv::Mat& invalid, double void_level) {
  CV_Assert(ipm.type() == CV_32FC1 && invalid.type() == CV_8UC1 && ipm.size() == invalid.size());
  if (void_level < 0) return invalid.clone();
  cv::Mat black = ipm <= static_cast<float>(void_level / 255.0);
  cv::bitwise_or(black, invalid, black);
  return black;
}

cv::Mat GrowMask(const cv::Mat& void_mask, int half_x, int half_y) {
  cv::Mat grown;
  const cv::Mat kernel =
      cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * half_x + 1, 2 * half_y + 1));
  cv::dilate(void_mask, grown, kernel, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  return grown;
}

void SuppressSteps(const cv::Mat& ipm, cv::Mat& response, double side_px, int along_px) {
  CV_Assert(ipm.type() == CV_32FC1 && response.type() == CV_32FC1 && ipm.size() == response.size());
  cv::Mat mean;
  cv::boxFilter(ipm, mean, CV_32F, cv::Size(1, 2 * std::max(0, along_px) + 1), cv::Point(-1, -1),
                true, cv::BORDER_REPLICATE);
  const double side = std::max(1.0, side_px);
  const int s0 = static_cast<int>(std::floor(side));
  const float f = static_cast<float>(side - s0);
  const int w = ipm.cols;
  for (int r = 0; r < response.rows; ++r) {
    const float* m = mean.ptr<float>(r);
    float* out = response.ptr<float>(r);
    // The mean at x +- side, linearly interpolated, clamped to the row.
    const auto at = [&](double x) {
      const int x0 = std::clamp(static_cast<int>(std::floor(x)), 0, w - 1);
      const int x1 = std::min(x0 + 1, w - 1);
      const float fx = static_cast<float>(std::clamp(x - std::floor(x), 0.0, 1.0));
      return (1 - fx) * m[x0] + fx * m[x1];
    };
    for (int c = 0; c < w; ++c) {
      if (out[c] <= 0) continue;
      const float left = (1 - f) * m[std::max(0, c - s0)] + f * at(c - s0 - 1);
      const float right = (1 - f) * m[std::min(w - 1, c + s0)] + f * at(c + s0 + 1);
      if (!(m[c] > left && m[c] > right)) out[c] = 0;
    }
  }
}

}  // namespace lane
