// SyntheticOptions::static_overlay: structure fixed to the camera.
#include <algorithm>
#include <iterator>
#include <opencv2/imgproc.hpp>

#include "scene.h"

namespace lane::synthetic_internal {
void DrawStaticOverlay(cv::Mat& img) {
  CV_Assert(img.type() == CV_8UC3);
  // The card, drawn flat: dark blue, with a barcode (a parking permit or a
  // toll tag): bright upright bars of 1-1.5 and gaps of 3-4.5 units, a unit
  // being 1/640 of the image width.
  const int w = std::max(16, static_cast<int>(0.22 * img.cols));
  const int h = std::max(8, static_cast<int>(0.09 * img.rows));
  cv::Mat card(h, w, CV_8UC3, cv::Scalar(140, 60, 20));
  const double unit = img.cols / 640.0;
  static constexpr double kBars[] = {1.0, 1.5, 1.0, 1.0, 1.5, 1.0, 1.5, 1.5, 1.0, 1.0, 1.5, 1.0};
  static constexpr double kGaps[] = {3.0, 4.5, 3.0, 4.5, 3.0, 3.0, 4.5, 3.0, 4.5, 3.0, 3.0, 4.5};
  double x = 0.08 * w;
  for (size_t k = 0; x < 0.92 * w; k = (k + 1) % std::size(kBars)) {
    const double bar = std::max(2.0, kBars[k] * 2 * unit);
    cv::rectangle(card, cv::Point2d(x, 0.12 * h), cv::Point2d(x + bar - 1, 0.88 * h),
                  {235, 255, 230}, cv::FILLED);
    x += bar + kGaps[k] * 2 * unit;
  }
  // Seen in the raked windscreen: the top edge narrower, so the bars meet
  // about four card heights above the card.
  const float inset = 0.1f * static_cast<float>(w);
  const cv::Point2f flat[] = {{0, 0},
                              {static_cast<float>(w), 0},
                              {0, static_cast<float>(h)},
                              {static_cast<float>(w), static_cast<float>(h)}};
  const float left = static_cast<float>(static_cast<int>(0.66 * img.cols));
  const float top = static_cast<float>(static_cast<int>(0.64 * img.rows));
  const cv::Point2f seen[] = {
      {left + inset, top}, {left + w - inset, top}, {left, top + h}, {left + w, top + h}};
  const cv::Mat warp = cv::getPerspectiveTransform(flat, seen);
  cv::Mat reflection(img.size(), CV_8UC3, cv::Scalar(0, 0, 0));
  cv::Mat cover(img.size(), CV_8UC1, cv::Scalar(0));
  cv::warpPerspective(card, reflection, warp, img.size(), cv::INTER_LINEAR, cv::BORDER_TRANSPARENT);
  cv::warpPerspective(cv::Mat(h, w, CV_8UC1, cv::Scalar(255)), cover, warp, img.size(),
                      cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  // A reflection adds its light to the scene seen through the glass.
  for (int r = 0; r < img.rows; ++r) {
    const uint8_t* c = cover.ptr<uint8_t>(r);
    const cv::Vec3b* add = reflection.ptr<cv::Vec3b>(r);
    cv::Vec3b* out = img.ptr<cv::Vec3b>(r);
    for (int u = 0; u < img.cols; ++u) {
      if (c[u] == 0) continue;
      const float a = c[u] / 255.0f;
      for (int k = 0; k < 3; ++k) {
        out[u][k] =
            cv::saturate_cast<uint8_t>(out[u][k] * (1.0f - 0.3f * a) + 0.6f * a * add[u][k]);
      }
    }
  }
}

}  // namespace lane::synthetic_internal
