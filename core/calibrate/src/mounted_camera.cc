#include "lane/calibrate/mounted_camera.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "lane/calibrate/vanishing_point.h"

namespace lane {
namespace {

// A frame whose lower half differs from the previous one's by less than
// this (mean absolute difference, grey levels, at 1/8 x 1/16 of the size)
// is the same view again: CameraCalibrator's standstill test.
constexpr double kMountedStillLevels = 1.5;

}  // namespace

absl::Status MountedCameraSurvey::AddFrame(const cv::Mat& frame) {
  if (frame.empty() || (frame.type() != CV_8UC3 && frame.type() != CV_8UC1)) {
    return absl::InvalidArgumentError("frames must be 8-bit BGR or grey images");
  }
  if (width_ == 0) {
    width_ = frame.cols;
    height_ = frame.rows;
    CameraModel& c = intrinsics_;
    c.image_width = width_;
    c.image_height = height_;
    c.fu = c.fv = options_.focal_px.value_or(kDefaultFocalPerImageWidth * width_);
    const Eigen::Vector2d pp =
        options_.principal_point.value_or(Eigen::Vector2d(width_ / 2.0, height_ / 2.0));
    c.cu = pp.x();
    c.cv = pp.y();
    c.pitch_deg = pitch_deg_;
    c.yaw_deg = yaw_deg_;
    c.height_m = options_.height_m;
    if (absl::Status s = c.Validate(); !s.ok()) return s;
  } else if (frame.cols != width_ || frame.rows != height_) {
    return absl::InvalidArgumentError(absl::StrCat("frame is ", frame.cols, "x", frame.rows,
                                                   ", the first was ", width_, "x", height_));
  }
  const int index = frames_++;
  const cv::Mat paint = PaintChannel(frame);
  cv::Mat small;
  cv::resize(paint.rowRange(height_ / 2, height_), small,
             cv::Size(std::max(1, width_ / 8), std::max(1, height_ / 16)), 0, 0, cv::INTER_AREA);
  const bool still = !previous_.empty() &&
                     cv::norm(small, previous_, cv::NORM_L1) / static_cast<double>(small.total()) <
                         kMountedStillLevels;
  previous_ = small;
  if (still) {
    ++stationary_;
    return absl::OkStatus();
  }
  road_rows_.Add(paint);
  moving_.push_back(index);
  return absl::OkStatus();
}

absl::StatusOr<CalibrationResult> MountedCameraSurvey::Finish() const {
  if (frames_ == 0) return absl::FailedPreconditionError("no frame was read");
  CalibrationResult r;
  r.mounting_given = true;
  r.camera = intrinsics_;
  r.focal_assumed = !options_.focal_px;
  r.vanishing_point.point = r.camera.VanishingPoint();
  r.vanishing_point.frames_used = static_cast<int>(moving_.size());
  r.first_pass_point = r.vanishing_point.point;
  r.frames = frames_;
  r.frames_stationary = stationary_;
  r.road_bottom_row = road_rows_.RoadBottomRow();
  r.outline = road_rows_.Outline();
  if (options_.road_bottom_row) {
    r.road_bottom_row = std::clamp(*options_.road_bottom_row, 1, height_);
    r.outline = RoadOutline::Flat(r.road_bottom_row, width_);
  }
  r.far_point = r.camera.GroundToImage({0.0, 1e5});
  r.used_frames = moving_;
  absl::StatusOr<GroundView> view = ChooseGroundView(r.camera, options_.lane_width_m, r.outline);
  if (!view.ok()) return view.status();
  r.view = *view;
  return r;
}

}  // namespace lane
