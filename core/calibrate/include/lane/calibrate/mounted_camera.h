// A camera of known mounting: `lane calibrate --pitch-deg --yaw-deg` (with
// --height-m and --focal-px). Many fleet cameras' height, pitch, yaw and
// focal length come from the vehicle's drawings; they need no vanishing
// point. A few frames then give only what the drawings do not: the road's
// outline (the hood) for the top view, and the self-check
// (docs/calibration.md, "A camera of known mounting").
#ifndef LANE_CALIBRATE_MOUNTED_CAMERA_H_
#define LANE_CALIBRATE_MOUNTED_CAMERA_H_

#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "lane/calibrate/calibration.h"

namespace lane {

class MountedCameraSurvey {
 public:
  // `options`: height, focal length (or assumed), principal point (or the
  // image centre), lane width, and the hood's row when known
  // (road_bottom_row, else found); its vanishing-point options are unused.
  MountedCameraSurvey(CalibrationOptions options, double pitch_deg, double yaw_deg)
      : options_(std::move(options)), pitch_deg_(pitch_deg), yaw_deg_(yaw_deg) {}

  // Every frame (BGR or grey, all of one size). A frame that repeats the
  // one before (the car stands) is counted and left out.
  absl::Status AddFrame(const cv::Mat& frame);

  // The camera, the road's outline (RoadRowFinder::Outline: the image's
  // bottom with fewer than RoadRowFinder::kMinFrames moving frames), the
  // view by the rule, and the moving frames for the self-check.
  // FAILED_PRECONDITION without a frame; INVALID_ARGUMENT for a camera that
  // makes no sense or sees no road (the message says why).
  absl::StatusOr<CalibrationResult> Finish() const;

 private:
  CalibrationOptions options_;
  double pitch_deg_, yaw_deg_;
  CameraModel intrinsics_;
  int width_ = 0, height_ = 0;
  RoadRowFinder road_rows_;
  cv::Mat previous_;
  int frames_ = 0, stationary_ = 0;
  std::vector<int> moving_;  // indices of the frames that moved
};

}  // namespace lane

#endif  // LANE_CALIBRATE_MOUNTED_CAMERA_H_
