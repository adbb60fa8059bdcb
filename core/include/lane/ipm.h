// Inverse perspective mapping: a top view of a region of the road.
//
// The mapping is computed once per calibration (IpmMapping::Create) and then
// applied to every frame with a single cv::remap.
#ifndef LANE_IPM_H_
#define LANE_IPM_H_

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/statusor.h"
#include "lane/camera.h"

namespace lane {

// A rectangle in image pixels. right and bottom are inclusive coordinates.
struct Roi {
  double left = 100;
  double right = 460;
  double top = 220;
  double bottom = 350;
};

enum class Interpolation { kNearest, kBilinear };

struct IpmOptions {
  // Size of the top view in pixels. 160x120 as in the paper: small enough for
  // real time, large enough for a 10 cm marking to cover ~1 pixel.
  int width = 160;
  int height = 120;
  // Region of the image that is mapped. It is clipped to the image and to
  // `horizon_margin_px` below the horizon.
  Roi roi;
  // How far below the horizon the ROI must start, pixels. Rows nearer the
  // horizon map to ground points that are absurdly far away.
  double horizon_margin_px = 10.0;
  Interpolation interpolation = Interpolation::kBilinear;

  absl::Status Validate() const;
};

// The precomputed mapping between a camera's image and its top view.
// IPM pixel (col, row): row 0 is the farthest row, column 0 the leftmost.
class IpmMapping {
 public:
  // INVALID_ARGUMENT for a bad camera, bad options, or an ROI that has no
  // part inside the image and below the horizon.
  static absl::StatusOr<IpmMapping> Create(const CameraModel& camera, const IpmOptions& options);

  // Top view of channel `channel` of an 8-bit image (1 or 3 channels) of the
  // camera's size, as CV_32F with values in [0, 1]. Only the top view's
  // pixels are read, so no full-frame channel copy is made. Pixels whose
  // source falls outside the ROI are set to the mean of the others (as in the
  // reference implementation).
  cv::Mat Apply(const cv::Mat& image, int channel = 0) const;

  // Conversions between IPM pixels, image pixels and ground metres.
  Eigen::Vector2d IpmToGround(const Eigen::Vector2d& ipm) const;
  Eigen::Vector2d GroundToIpm(const Eigen::Vector2d& ground) const;
  Eigen::Vector2d IpmToImage(const Eigen::Vector2d& ipm) const;
  Eigen::Vector2d ImageToIpm(const Eigen::Vector2d& image) const;

  // Ground size of one IPM pixel, metres: across the road (x) and along it (y).
  double metres_per_px_x() const { return mpp_x_; }
  double metres_per_px_y() const { return mpp_y_; }
  // Ground extent of the top view, metres.
  double x_min() const { return x_min_; }
  double x_max() const { return x_max_; }
  double y_min() const { return y_min_; }
  double y_max() const { return y_max_; }
  // The ROI after clipping to the image and the horizon.
  const Roi& roi() const { return roi_; }
  const CameraModel& camera() const { return camera_; }
  const IpmOptions& options() const { return options_; }
  int width() const { return options_.width; }
  int height() const { return options_.height; }
  // CV_8U, 255 where the IPM pixel's source lies inside the ROI.
  const cv::Mat& valid_mask() const { return valid_; }
  // Its complement.
  const cv::Mat& invalid_mask() const { return invalid_; }

  // Bytes held by the precomputed mapping (grows with the top view's size).
  size_t MemoryBytes() const;

 private:
  IpmMapping() = default;

  CameraModel camera_;
  IpmOptions options_;
  Roi roi_;
  double x_min_ = 0, x_max_ = 0, y_min_ = 0, y_max_ = 0;
  double mpp_x_ = 0, mpp_y_ = 0;
  // Per IPM pixel (row-major): the source pixel's top-left neighbour and the
  // four bilinear weights (nearest: one weight of 1). Invalid pixels have
  // src_x_ = -1. Applied by a plain loop that reads one channel in place.
  std::vector<int> src_x_, src_y_;
  std::vector<std::array<float, 4>> weights_;
  cv::Mat valid_;
  cv::Mat invalid_;
  int valid_count_ = 0;
};

}  // namespace lane

#endif  // LANE_IPM_H_
