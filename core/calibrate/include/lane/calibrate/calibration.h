// Auto-calibration: a camera's pitch and yaw from the road's vanishing
// point, the rows that show road, a top view for the result, and the slow
// online refinement a session runs on its own detections
// (docs/calibration.md).
//
// Only the ground-to-image homography matters to the detector. On a flat,
// straight road the lanes meet at the vanishing point (u0, v0), and with the
// project's convention (camera.h)
//   pitch = atan((cv - v0) / fv),   yaw = atan((cu - u0) cos(pitch) / fu).
// The camera height sets the metric scale and is given. The focal length is
// given or assumed: at a fixed vanishing point it only scales distances
// along the road.
#ifndef LANE_CALIBRATION_H_
#define LANE_CALIBRATION_H_

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <deque>
#include <opencv2/core.hpp>
#include <optional>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "lane/calibrate/self_check.h"
#include "lane/calibrate/static_structure.h"
#include "lane/calibrate/vanishing_point.h"
#include "lane/detector/detector.h"
#include "lane/geometry/camera.h"
#include "lane/geometry/ground_view_rule.h"
#include "lane/geometry/ipm.h"

namespace lane {

// A systematic term added (in quadrature) to the bootstrap interval of
// `lane calibrate`'s vanishing point, degrees (95 %): the bias the spread
// across frames cannot show. On 50 rendered cameras in clutter (seed 777,
// not the test's) the estimate sat 0.8 px (0.12 deg) above the truth on
// average (slight curves that pass the curve test lift every frame's point
// alike); this term brought the interval's coverage from 40 to 49 of 50.
inline constexpr double kSystematicIntervalDeg = 0.15;

// Focal length assumed when none is given: 0.61 x the image width, a 79°
// horizontal field of view, typical of dash cameras (the CULane camera's
// workable 1000 px at 1640 px).
inline constexpr double kDefaultFocalPerImageWidth = 0.61;

// `intrinsics` (focal lengths, principal point, height, image size) with the
// pitch and yaw that put the vanishing point at `vp`.
CameraModel CameraFromVanishingPoint(const CameraModel& intrinsics, const Eigen::Vector2d& vp);

// The rows of a fixed camera's frames that show road: the car's own hood
// (and any mount in front of the lens) stays still while the road moves, so
// its pixels barely change over a drive. Feed frames (any size-consistent
// 8-bit images) of one camera; RoadBottomRow is the first row below the road
// across the image as a whole, Outline the same per column (a hood rises
// towards the image's centre).
class RoadRowFinder {
 public:
  void Add(const cv::Mat& frame);
  int frames() const { return frames_; }
  // The image height when fewer than kMinFrames frames were added or no
  // still band was found.
  int RoadBottomRow() const;
  // Per column: the first row below the road, from the bottom up the first
  // rows whose temporal spread reaches half the road's level, in bands of
  // kBandColumns columns at 1/kScale (median over 5 bands, linear between
  // the bands' centres). Empty (the image's bottom) when fewer than
  // kMinFrames frames were added.
  RoadOutline Outline() const;
  // Per-row temporal spread (median over the row of the per-pixel standard
  // deviation, grey levels), top to bottom, at 1/kScale of the rows.
  std::vector<double> RowSpread() const;

  static constexpr int kMinFrames = 8;
  static constexpr int kScale = 4;
  static constexpr int kBandColumns = 4;

 private:
  // The road's spread: the median row spread of the image's lower half
  // above its last eighth (road in every mounting seen so far).
  double RoadLevel(const std::vector<double>& row_spread) const;

  cv::Mat mean_, m2_;  // CV_64F, Welford's running moments
  int frames_ = 0;
  int height_ = 0, width_ = 0;
};

// The top view for a camera (docs/config.md, "Choosing a ground view"), by
// the rule of lane/geometry/ground_view_rule.h for `lane_width_m` lanes,
// with the road ending at `outline` (empty: the image's bottom).
// INVALID_ARGUMENT when no road shows below the horizon.
absl::StatusOr<GroundView> ChooseGroundView(const CameraModel& camera, double lane_width_m,
                                            const RoadOutline& outline);

// `lane calibrate`'s estimate from frames of ordinary driving, in two passes
// over the same frames:
//   1. marking segments below 45 % of the image height at four fixed bar
//      widths, and the still rows at the bottom (RoadRowFinder): a first
//      vanishing point, whose row is the horizon for pass 2;
//   2. segments from just below that horizon to the road's last row, with
//      the bar width each row's distance implies: per-frame points, curved
//      frames and frames without markings left out, a robust mean.
struct CalibrationOptions {
  double height_m = 1.5;
  // Square pixels of this focal length; unset: kDefaultFocalPerImageWidth.
  std::optional<double> focal_px;
  // Unset: the image centre.
  std::optional<Eigen::Vector2d> principal_point;
  double lane_width_m = 3.5;
  // The first image row below the road (a hood), when known; else found
  // by RoadRowFinder.
  std::optional<int> road_bottom_row;
  VanishingPointOptions vanishing_point;
  // Structure fixed to the camera (a reflection, a sticker, an overlay):
  // found over pass 1's moving frames; its segments get no vote in either
  // pass, and its rectangles on the road's rows are the written config's
  // ipm.static_mask (static_structure.h).
  StaticStructureOptions static_structure;
};

struct CalibrationResult {
  CameraModel camera;
  // Pitch and yaw were given (MountedCameraSurvey, lane/calibrate/
  // mounted_camera.h): no vanishing point was estimated, `vanishing_point`
  // is the camera's own and its interval 0.
  bool mounting_given = false;
  CombinedVanishingPoint vanishing_point;
  Eigen::Vector2d first_pass_point = Eigen::Vector2d::Zero();
  bool focal_assumed = false;
  int frames = 0;              // frames of pass 2
  int frames_no_markings = 0;  // left out: fewer than two consistent markings
  // Left out: markings that meet further than prior_gate_deg from pass 1's
  // point. More of these than used frames refuses the estimate.
  int frames_elsewhere = 0;
  int frames_curved = 0;      // left out: near and far markings disagree
  int frames_stationary = 0;  // left out: the same view as the frame before
  int segments = 0;           // segments supporting the used frames' points
  int static_segments = 0;    // segments of both passes left out as static structure
  // The static structure's rectangles that reach into the rows a top view
  // may read (from the horizon + IpmOptions::horizon_margin_px down to
  // road_bottom_row): a config's ipm.static_mask.
  std::vector<Roi> static_mask;
  int road_bottom_row = 0;  // first row below the road (hood), or the height
  // Per column, the first row below the road (RoadRowFinder::Outline, or
  // flat at --road-bottom-row); the view's rule uses it.
  RoadOutline outline;
  GroundView view;
  // Far ground point (0, 1e5 m) projected by the camera, for the check
  // against the vanishing point.
  Eigen::Vector2d far_point = Eigen::Vector2d::Zero();
  // 95 % interval half-widths of the point (BootstrapInterval), and the
  // same in degrees of pitch and yaw.
  Eigen::Vector2d interval_px = Eigen::Vector2d::Zero();
  double pitch_interval_deg = 0, yaw_interval_deg = 0;
  // Pass-2 frames (0-based, in the order given) whose points were kept:
  // the frames the self-check runs on.
  std::vector<int> used_frames;
};

// Pass 1 as it ended, also when the estimate is refused later (overlays):
// its point, the segments that supported it and those left out as static
// structure, each with its frame (0-based, in the order given).
struct FirstPassReport {
  Eigen::Vector2d point = Eigen::Vector2d::Zero();
  std::vector<std::pair<int, ImageSegment>> support;
  std::vector<std::pair<int, ImageSegment>> static_segments;
  StaticStructure static_structure;
};

class CameraCalibrator {
 public:
  explicit CameraCalibrator(CalibrationOptions options)
      : options_(std::move(options)), static_finder_(options_.static_structure) {}

  // Pass 1, every frame (BGR or grey, all of one size).
  absl::Status AddFirstPass(const cv::Mat& frame);
  // Between the passes; FAILED_PRECONDITION when no frame showed markings.
  absl::Status FinishFirstPass();
  // Pass 2, the same frames again; the frame's point and segments, for
  // overlays.
  absl::StatusOr<FrameVanishingPoint> AddSecondPass(const cv::Mat& frame,
                                                    std::vector<ImageSegment>* segments = nullptr);
  // FAILED_PRECONDITION when fewer than kMinFramesUsed frames of pass 2
  // gave a point, or when more frames' markings met away from pass 1's
  // point than at it.
  absl::StatusOr<CalibrationResult> Finish() const;
  static constexpr int kMinFramesUsed = 3;

  // The camera before pitch and yaw: focal length, principal point, height
  // and size (valid after the first frame).
  const CameraModel& intrinsics() const { return intrinsics_; }
  // Valid after FinishFirstPass succeeded.
  const FirstPassReport& first_pass() const { return first_pass_; }

 private:
  MarkingSegmentOptions SecondPassSegments() const;
  cv::Rect2d SearchBounds() const;

  CalibrationOptions options_;
  CameraModel intrinsics_;
  bool focal_assumed_ = false;
  int width_ = 0, height_ = 0;
  RoadRowFinder road_rows_;
  StaticStructureFinder static_finder_;
  FirstPassReport first_pass_;
  int static_segments_ = 0;
  std::vector<std::vector<ImageSegment>> first_segments_;
  Eigen::Vector2d first_point_ = Eigen::Vector2d::Zero();
  int road_bottom_ = 0;
  RoadOutline outline_;
  bool first_done_ = false;
  cv::Mat previous_;
  std::vector<bool> stationary_;
  int second_frames_ = 0, stationary_count_ = 0;
  std::vector<Eigen::Vector2d> points_;
  std::vector<int> point_frames_;  // pass-2 index of each point
  int frames_ = 0, no_markings_ = 0, curved_ = 0, segments_ = 0;
  std::vector<Eigen::Vector2d> elsewhere_points_;  // kElsewhere frames' own points
};

// The self-check of an estimate (self_check.h) before it is written: the
// detector, with the estimated camera, its ground view and the built-in
// settings (all lanes), on the frames whose points were used.
class CalibrationSelfCheck {
 public:
  // Lane pairs count when `lane_width_m` apart, widened to 2.5-4.5 m.
  static absl::StatusOr<CalibrationSelfCheck> Create(const CalibrationResult& result,
                                                     double lane_width_m);
  absl::Status AddFrame(const cv::Mat& frame);
  LaneGeometryReport Report() const { return check_.Report(); }

 private:
  CalibrationSelfCheck(Detector detector, LaneGeometryCheckOptions options)
      : detector_(std::move(detector)), check_(options) {}
  Detector detector_;
  LaneGeometryCheck check_;
};

// Lane pairs `lane_width_m` apart, widened to the default 2.5-4.5 m.
LaneGeometryCheckOptions GeometryCheckForWidth(double lane_width_m);

// The chords on the ground of a frame's lanes (Lane::ground, or the image
// control points mapped through `camera` when given: a candidate camera).
std::vector<GroundChord> LaneChords(const std::vector<Lane>& lanes);
std::vector<GroundChord> LaneChords(const std::vector<std::array<Eigen::Vector2d, 2>>& image_ends,
                                    const CameraModel& camera);

// A session's slow refinement of pitch and yaw from its own detections.
//
// Frames with at least two lanes that are straight in the image (their
// control points within max_bend_px of the chord) and not parallel give a
// vanishing point; the estimate moves a fraction `gain` of the way to it,
// at most max_step_deg per frame, and never further than max_drift_deg
// from the camera it started with. When the estimate has moved
// rederive_deg from the camera the detector uses, Observe says so and the
// caller rebuilds the detector (and its top view) with camera(). A
// candidate that fails the self-check on the recent frames' lanes is not
// adopted (refused(), last_refusal()).
struct OnlineCalibrationOptions {
  double max_bend_px = 2.0;
  double min_spread_deg = 10.0;
  // A frame whose point is further than this (angle seen from the camera)
  // from the estimate is an outlier and ignored.
  double gate_deg = 4.0;
  double gain = 0.05;
  double max_step_deg = 0.05;
  double max_drift_deg = 5.0;
  double rederive_deg = 0.2;
  // Before a new estimate is adopted, the last `check_frames` frames'
  // lanes, mapped to the ground through it, must pass `check`
  // (self_check.h), or at least improve on the camera in use (as many lane
  // pairs, smaller heading plus divergence); otherwise the detector keeps
  // its camera and the refusal is counted. 0: no check.
  int check_frames = 30;
  LaneGeometryCheckOptions check;
};

class OnlineCalibrator {
 public:
  OnlineCalibrator(const CameraModel& initial, OnlineCalibrationOptions options = {});

  // One frame's lanes (image control points). True when camera() has moved
  // at least rederive_deg from the camera of the last true (or the initial
  // one): the caller then rebuilds its detector with camera().
  bool Observe(const std::vector<Lane>& lanes);

  CameraModel camera() const;  // the current estimate
  const CameraModel& initial() const { return initial_; }
  Eigen::Vector2d vanishing_point() const { return vp_; }
  int frames_used() const { return frames_used_; }
  int frames_seen() const { return frames_seen_; }
  int rederived() const { return rederived_; }
  int refused() const { return refused_; }
  const absl::Status& last_refusal() const { return last_refusal_; }
  // Standard error of the estimate, degrees (from the scatter of the
  // frames' points and the effective number of frames averaged).
  double uncertainty_deg() const;
  // 0 before any frame; 1 - uncertainty / 1°, clamped to [0, 1], after.
  double confidence() const;
  double drift_pitch_deg() const { return camera().pitch_deg - initial_.pitch_deg; }
  double drift_yaw_deg() const { return camera().yaw_deg - initial_.yaw_deg; }

 private:
  CameraModel initial_;
  CameraModel applied_;
  OnlineCalibrationOptions options_;
  Eigen::Vector2d vp_;
  double var_deg2_ = 0;  // running variance of the frames' points, degrees^2
  int frames_used_ = 0;
  int frames_seen_ = 0;
  int rederived_ = 0;
  int refused_ = 0;
  absl::Status last_refusal_;
  // The recent frames' lanes: image end points (nearest, farthest).
  std::deque<std::vector<std::array<Eigen::Vector2d, 2>>> recent_;
};

// The vanishing point of one frame's lanes that are straight in the image,
// or none (fewer than two such lanes, or too parallel).
std::optional<Eigen::Vector2d> LanesVanishingPoint(const std::vector<Lane>& lanes,
                                                   double max_bend_px, double min_spread_deg);

}  // namespace lane

#endif  // LANE_CALIBRATION_H_
