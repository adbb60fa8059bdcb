#include "lane/postprocess/marking_check.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace lane {
namespace {

// Image pixels per metre across the road along image row through `p`.
double RowPixelsPerMetre(const CameraModel& camera, const Eigen::Vector2d& p) {
  const Eigen::Vector2d g = camera.ImageToGround(p);
  if (!g.allFinite() || g.y() <= 0) return 0;
  const Eigen::Vector2d q = camera.GroundToImage(g + Eigen::Vector2d(1, 0));
  return q.allFinite() ? std::abs(q.x() - p.x()) : 0;
}

}  // namespace

BarWidthReport MeasureBarWidths(const Bezier& spline, const ChannelView& image,
                                const CameraModel& camera, const BarWidthOptions& o) {
  BarWidthReport report;
  const bool is_float = image.image.depth() == CV_32F;
  const double scale = is_float ? 1.0 / 255.0 : 1.0;
  std::vector<double> widths;
  std::vector<float> row, sorted;
  for (int i = 0; i < o.samples; ++i) {
    const Eigen::Vector2d p = spline.Eval((i + 0.5) / o.samples);
    if (!image.Inside(p.x(), p.y())) continue;
    const double ppm = RowPixelsPerMetre(camera, p);
    if (!(ppm > 0)) continue;
    const int half = std::max(3, static_cast<int>(std::lround(o.window_m * ppm)));
    const int y = static_cast<int>(std::lround(p.y()));
    const int cx = static_cast<int>(std::lround(p.x()));
    const int x0 = std::max(0, cx - half), x1 = std::min(image.cols() - 1, cx + half);
    if (x1 - x0 < 4) continue;
    row.resize(x1 - x0 + 1);
    for (int x = x0; x <= x1; ++x) row[x - x0] = image.At(x, y);
    // Background: the profile's median (road covers most of it).
    sorted = row;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double background = sorted[sorted.size() / 2];
    // The peak near the spline.
    const int search = std::max(1, static_cast<int>(std::lround(o.search_m * ppm)));
    int peak = -1;
    for (int x = std::max(x0, cx - search); x <= std::min(x1, cx + search); ++x) {
      if (peak < 0 || row[x - x0] > row[peak - x0]) peak = x;
    }
    if (peak < 0) continue;
    const double contrast = row[peak - x0] - background;
    if (contrast < o.min_contrast * scale) continue;  // a gap: flat road
    ++report.structured;
    // Full width at half the contrast: both sides must drop below it.
    const double level = background + 0.5 * contrast;
    int left = peak, right = peak;
    while (left > x0 && row[left - x0] >= level) --left;
    while (right < x1 && row[right - x0] >= level) ++right;
    if (row[left - x0] >= level || row[right - x0] >= level) continue;  // a step or wider
    const double width_m = (right - left - 1) / ppm;
    widths.push_back(width_m);
    if (width_m <= o.max_width_m) ++report.narrow_bars;
  }
  if (!widths.empty()) {
    std::nth_element(widths.begin(), widths.begin() + widths.size() / 2, widths.end());
    report.median_width_m = widths[widths.size() / 2];
  }
  return report;
}

double MedianRedness(const Bezier& spline, const cv::Mat& bgr, const ChannelView& view,
                     double search_px, int samples) {
  if (bgr.channels() != 3 || bgr.depth() != CV_8U) return std::nan("");
  std::vector<double> redness;
  const int s = std::max(1, static_cast<int>(std::lround(search_px)));
  for (int i = 0; i < samples; ++i) {
    const Eigen::Vector2d p = spline.Eval((i + 0.5) / samples);
    const int y = static_cast<int>(std::lround(p.y()));
    const int cx = static_cast<int>(std::lround(p.x()));
    if (!view.Inside(cx, y)) continue;
    int best = -1;
    for (int x = std::max(0, cx - s); x <= std::min(bgr.cols - 1, cx + s); ++x) {
      if (best < 0 || view.At(x, y) > view.At(best, y)) best = x;
    }
    const cv::Vec3b c = bgr.at<cv::Vec3b>(y, best);
    if (c[2] < 40) continue;
    redness.push_back((static_cast<double>(c[2]) - c[1]) / c[2]);
  }
  if (redness.empty()) return std::nan("");
  std::nth_element(redness.begin(), redness.begin() + redness.size() / 2, redness.end());
  return redness[redness.size() / 2];
}

}  // namespace lane
