#include "lane/ipm.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"

namespace lane {

absl::Status IpmOptions::Validate() const {
  if (width < 8 || height < 8 || width > 2048 || height > 2048) {
    return absl::InvalidArgumentError(
        absl::StrCat("ipm size must be within 8..2048 pixels, got ", width, "x", height));
  }
  const double v[] = {roi.left, roi.right, roi.top, roi.bottom, horizon_margin_px};
  for (double x : v) {
    if (!std::isfinite(x)) return absl::InvalidArgumentError("ipm.roi values must be finite");
  }
  if (roi.right <= roi.left || roi.bottom <= roi.top) {
    return absl::InvalidArgumentError(
        absl::StrCat("ipm.roi must have right > left and bottom > top, got left=", roi.left,
                     " right=", roi.right, " top=", roi.top, " bottom=", roi.bottom));
  }
  if (horizon_margin_px < 0) {
    return absl::InvalidArgumentError("ipm.horizon_margin_px must be >= 0");
  }
  return absl::OkStatus();
}

absl::StatusOr<IpmMapping> IpmMapping::Create(const CameraModel& camera,
                                              const IpmOptions& options) {
  if (auto s = camera.Validate(); !s.ok()) return s;
  if (auto s = options.Validate(); !s.ok()) return s;

  IpmMapping m;
  m.camera_ = camera;
  m.options_ = options;

  // Clip the ROI to the image and to below the horizon.
  const double horizon = camera.HorizonRow();
  Roi roi = options.roi;
  roi.left = std::max(roi.left, 0.0);
  roi.right = std::min(roi.right, camera.image_width - 1.0);
  roi.bottom = std::min(roi.bottom, camera.image_height - 1.0);
  roi.top = std::max(roi.top, horizon + options.horizon_margin_px);
  if (roi.right - roi.left < 2 || roi.bottom - roi.top < 2) {
    return absl::InvalidArgumentError(absl::StrCat(
        "ipm.roi (left=", options.roi.left, " right=", options.roi.right, " top=", options.roi.top,
        " bottom=", options.roi.bottom, ") has no usable part inside the ", camera.image_width, "x",
        camera.image_height, " image below the horizon (row ", horizon, " + margin ",
        options.horizon_margin_px, ")"));
  }
  m.roi_ = roi;

  // Ground footprint of the ROI: its corners and the vanishing point's column
  // on its top and bottom rows.
  const double vp_u = std::clamp(camera.VanishingPoint().x(), roi.left, roi.right);
  const Eigen::Vector2d corners[] = {{roi.left, roi.top},     {roi.right, roi.top},
                                     {vp_u, roi.top},         {roi.left, roi.bottom},
                                     {roi.right, roi.bottom}, {vp_u, roi.bottom}};
  m.x_min_ = m.y_min_ = std::numeric_limits<double>::infinity();
  m.x_max_ = m.y_max_ = -std::numeric_limits<double>::infinity();
  for (const auto& c : corners) {
    const Eigen::Vector2d g = camera.ImageToGround(c);
    if (!g.allFinite() || g.y() <= 0) {
      return absl::InvalidArgumentError("ipm.roi maps to points behind the camera");
    }
    m.x_min_ = std::min(m.x_min_, g.x());
    m.x_max_ = std::max(m.x_max_, g.x());
    m.y_min_ = std::min(m.y_min_, g.y());
    m.y_max_ = std::max(m.y_max_, g.y());
  }
  m.mpp_x_ = (m.x_max_ - m.x_min_) / options.width;
  m.mpp_y_ = (m.y_max_ - m.y_min_) / options.height;
  if (!(m.mpp_x_ > 0) || !(m.mpp_y_ > 0)) {
    return absl::InvalidArgumentError("ipm.roi has an empty ground footprint");
  }

  // The per-pixel source coordinates and weights, computed once per
  // calibration.
  const int n = options.width * options.height;
  m.src_x_.assign(n, -1);
  m.src_y_.assign(n, -1);
  m.weights_.assign(n, {0.f, 0.f, 0.f, 0.f});
  m.valid_ = cv::Mat::zeros(options.height, options.width, CV_8U);
  m.valid_count_ = 0;
  const bool bilinear = options.interpolation == Interpolation::kBilinear;
  for (int r = 0; r < options.height; ++r) {
    for (int c = 0; c < options.width; ++c) {
      const Eigen::Vector2d img = m.IpmToImage(Eigen::Vector2d(c, r));
      const bool inside = img.allFinite() && img.x() >= roi.left && img.x() <= roi.right &&
                          img.y() >= roi.top && img.y() <= roi.bottom;
      if (!inside) continue;
      const int i = r * options.width + c;
      if (bilinear) {
        // The ROI lies inside the image, so x0 + 1 and y0 + 1 do too except
        // on the last column/row, where the weight of the outer pixel is 0.
        const int x0 = std::min(static_cast<int>(img.x()), camera.image_width - 2);
        const int y0 = std::min(static_cast<int>(img.y()), camera.image_height - 2);
        const float fx = static_cast<float>(img.x() - x0);
        const float fy = static_cast<float>(img.y() - y0);
        m.src_x_[i] = x0;
        m.src_y_[i] = y0;
        m.weights_[i] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
      } else {
        m.src_x_[i] = static_cast<int>(std::lround(img.x()));
        m.src_y_[i] = static_cast<int>(std::lround(img.y()));
        m.weights_[i] = {1.f, 0.f, 0.f, 0.f};
      }
      m.valid_.at<uint8_t>(r, c) = 255;
      ++m.valid_count_;
    }
  }
  if (m.valid_count_ == 0) return absl::InvalidArgumentError("ipm.roi maps to no IPM pixel");
  cv::bitwise_not(m.valid_, m.invalid_);
  return m;
}

cv::Mat IpmMapping::Apply(const cv::Mat& image, int channel) const {
  CV_Assert(image.depth() == CV_8U && image.cols == camera_.image_width &&
            image.rows == camera_.image_height && channel >= 0 && channel < image.channels());
  cv::Mat out(options_.height, options_.width, CV_32F);
  const int cn = image.channels();
  const size_t step = image.step[0];
  const uint8_t* base = image.data + channel;
  float* dst = out.ptr<float>(0);  // continuous: freshly allocated
  const int n = options_.width * options_.height;
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    if (src_x_[i] < 0) continue;
    const uint8_t* p = base + src_y_[i] * step + src_x_[i] * cn;
    const auto& w = weights_[i];
    const float v =
        (w[0] * p[0] + w[1] * p[cn] + w[2] * p[step] + w[3] * p[step + cn]) * (1.f / 255.f);
    dst[i] = v;
    sum += v;
  }
  const float mean = static_cast<float>(sum / valid_count_);
  for (int i = 0; i < n; ++i) {
    if (src_x_[i] < 0) dst[i] = mean;
  }
  return out;
}

Eigen::Vector2d IpmMapping::IpmToGround(const Eigen::Vector2d& ipm) const {
  return {x_min_ + (ipm.x() + 0.5) * mpp_x_, y_max_ - (ipm.y() + 0.5) * mpp_y_};
}

Eigen::Vector2d IpmMapping::GroundToIpm(const Eigen::Vector2d& ground) const {
  return {(ground.x() - x_min_) / mpp_x_ - 0.5, (y_max_ - ground.y()) / mpp_y_ - 0.5};
}

Eigen::Vector2d IpmMapping::IpmToImage(const Eigen::Vector2d& ipm) const {
  return camera_.GroundToImage(IpmToGround(ipm));
}

Eigen::Vector2d IpmMapping::ImageToIpm(const Eigen::Vector2d& image) const {
  return GroundToIpm(camera_.ImageToGround(image));
}

size_t IpmMapping::MemoryBytes() const {
  return src_x_.capacity() * sizeof(int) + src_y_.capacity() * sizeof(int) +
         weights_.capacity() * sizeof(weights_[0]) + valid_.total() * valid_.elemSize() +
         invalid_.total() * invalid_.elemSize();
}

}  // namespace lane
