#include "lane/stages/two_lanes.h"

#include <algorithm>
#include <cmath>

namespace lane {

absl::Status TwoLaneOptions::Validate() const {
  if (!(search_half_width_m > 0 && search_half_width_m < 20)) {
    return absl::InvalidArgumentError("two_lanes.search_half_width_m must lie in (0, 20) metres");
  }
  if (!(lane_width_m > 0 && lane_width_m < 20 && lane_width_sigma_m > 0)) {
    return absl::InvalidArgumentError(
        "two_lanes.lane_width_m must lie in (0, 20) metres and lane_width_sigma_m be > 0");
  }
  if (!(min_pair_score >= 0 && min_pair_score <= 1)) {
    return absl::InvalidArgumentError("two_lanes.min_pair_score must lie in [0, 1]");
  }
  return absl::OkStatus();
}

ColumnBand EgoBand(double camera_col, double metres_per_px_x, int cols,
                   const TwoLaneOptions& options) {
  const double half = options.search_half_width_m / metres_per_px_x;
  ColumnBand band;
  band.begin = std::clamp(static_cast<int>(std::ceil(camera_col - half)), 0, cols);
  band.end = std::clamp(static_cast<int>(std::floor(camera_col + half)) + 1, 0, cols);
  return band;
}

void KeepBand(const ColumnBand& band, cv::Mat& image) {
  if (band.begin > 0) image.colRange(0, band.begin).setTo(0);
  if (band.end < image.cols) image.colRange(band.end, image.cols).setTo(0);
}

std::vector<ColumnPeak> SelectEgoPair(const std::vector<ColumnPeak>& peaks, double camera_col,
                                      double metres_per_px_x, const TwoLaneOptions& options) {
  if (peaks.size() < 2) return peaks;
  double best = -1;
  std::vector<ColumnPeak> chosen;
  for (size_t i = 0; i < peaks.size(); ++i) {
    for (size_t j = i + 1; j < peaks.size(); ++j) {
      if (!(peaks[i].x < camera_col && peaks[j].x > camera_col)) continue;
      const double d = (peaks[j].x - peaks[i].x) * metres_per_px_x - options.lane_width_m;
      const double s = options.lane_width_sigma_m;
      const double width_score = std::exp(-d * d / (2 * s * s));
      if (width_score < options.min_pair_score) continue;
      const double score = width_score * (peaks[i].value + peaks[j].value);
      if (score > best) {
        best = score;
        chosen = {peaks[i], peaks[j]};
      }
    }
  }
  if (chosen.empty()) {
    chosen = {*std::max_element(
        peaks.begin(), peaks.end(),
        [](const ColumnPeak& a, const ColumnPeak& b) { return a.value < b.value; })};
  }
  return chosen;
}

}  // namespace lane
