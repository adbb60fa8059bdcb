// What both calibrations (CameraCalibrator, calibration.cc; MountedCameraSurvey,
// mounted_camera.cc) do with each frame they are given: check it, start the
// camera from the first one, and tell a standstill from driving.
#ifndef LANE_CALIBRATE_FRAME_INTAKE_H_
#define LANE_CALIBRATE_FRAME_INTAKE_H_

#include <algorithm>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "lane/calibrate/calibration.h"

namespace lane::calibrate_internal {

// OK when `frame` is an 8-bit BGR or grey image of the first frame's size
// (`width` 0: this is the first frame).
inline absl::Status CheckCalibrationFrame(const cv::Mat& frame, int width, int height) {
  if (frame.empty() || (frame.type() != CV_8UC3 && frame.type() != CV_8UC1)) {
    return absl::InvalidArgumentError("frames must be 8-bit BGR or grey images");
  }
  if (width != 0 && (frame.cols != width || frame.rows != height)) {
    return absl::InvalidArgumentError(absl::StrCat("frame is ", frame.cols, "x", frame.rows,
                                                   ", the first was ", width, "x", height));
  }
  return absl::OkStatus();
}

// The camera of width x height frames before its mounting is known: the
// given focal length (or kDefaultFocalPerImageWidth x the width, square
// pixels), the given principal point (or the image centre) and height;
// pitch and yaw 0.
inline CameraModel StartingCamera(const CalibrationOptions& options, int width, int height) {
  CameraModel c;
  c.image_width = width;
  c.image_height = height;
  c.fu = c.fv = options.focal_px.value_or(kDefaultFocalPerImageWidth * width);
  const Eigen::Vector2d pp =
      options.principal_point.value_or(Eigen::Vector2d(width / 2.0, height / 2.0));
  c.cu = pp.x();
  c.cv = pp.y();
  c.pitch_deg = 0;
  c.yaw_deg = 0;
  c.height_m = options.height_m;
  return c;
}

// A frame whose lower half differs from the previous one's by less than
// this (mean absolute difference, grey levels, at 1/8 x 1/16 of the size)
// is the same view again: the car stands.
inline constexpr double kStandstillLevels = 1.5;

// The lower half of a frame's paint channel at 1/8 x 1/16 of its size, for
// SameView.
inline cv::Mat StandstillThumbnail(const cv::Mat& paint) {
  cv::Mat small;
  cv::resize(paint.rowRange(paint.rows / 2, paint.rows), small,
             cv::Size(std::max(1, paint.cols / 8), std::max(1, paint.rows / 16)), 0, 0,
             cv::INTER_AREA);
  return small;
}

// Whether two frames' thumbnails show the same view (`previous` empty: no
// frame before).
inline bool SameView(const cv::Mat& thumbnail, const cv::Mat& previous) {
  return !previous.empty() &&
         cv::norm(thumbnail, previous, cv::NORM_L1) / static_cast<double>(thumbnail.total()) <
             kStandstillLevels;
}

}  // namespace lane::calibrate_internal

#endif  // LANE_CALIBRATE_FRAME_INTAKE_H_
