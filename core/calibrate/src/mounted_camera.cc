#include "lane/calibrate/mounted_camera.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "absl/strings/str_cat.h"
#include "frame_intake.h"
#include "lane/calibrate/vanishing_point.h"

namespace lane {

absl::Status MountedCameraSurvey::AddFrame(const cv::Mat& frame) {
  if (absl::Status s = calibrate_internal::CheckCalibrationFrame(frame, width_, height_); !s.ok()) {
    return s;
  }
  if (width_ == 0) {
    width_ = frame.cols;
    height_ = frame.rows;
    intrinsics_ = calibrate_internal::StartingCamera(options_, width_, height_);
    intrinsics_.pitch_deg = pitch_deg_;
    intrinsics_.yaw_deg = yaw_deg_;
    if (absl::Status s = intrinsics_.Validate(); !s.ok()) return s;
  }
  const int index = frames_++;
  const cv::Mat paint = PaintChannel(frame);
  cv::Mat small = calibrate_internal::StandstillThumbnail(paint);
  const bool still = calibrate_internal::SameView(small, previous_);
  previous_ = std::move(small);
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
