// The road's vanishing point from marking evidence, for auto-calibration
// (`lane calibrate`, docs/calibration.md).
//
//   frame -> paint channel min(R, G) -> bright-bar response along each row
//   -> short marking segments (connected pieces, one per row band, that are
//      long, thin and not near-horizontal) -> per-frame vanishing point
//      (exhaustive pair consensus in angle, then a weighted least-squares
//      refit) -> frames combined by a robust mean.
//
// A frame is left out when it shows fewer than two consistent markings, or
// when its near and far markings point at different vanishing points (the
// road curves). Only markings count: a bar must be brighter than the road on
// both sides, so vehicle edges, curbs and shadow borders (steps, not bars)
// give no segments.
#ifndef LANE_VANISHING_POINT_H_
#define LANE_VANISHING_POINT_H_

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace lane {

// A straight piece of a painted marking in the image.
struct ImageSegment {
  Eigen::Vector2d centre;     // image pixels
  Eigen::Vector2d direction;  // unit vector, pointing up the image (v decreasing)
  double length = 0;          // pixels
  double top_row = 0;         // smallest v of its pixels
  double bottom_row = 0;      // largest v of its pixels
};

struct MarkingSegmentOptions {
  // Rows searched, [top_row, bottom_row). bottom_row <= 0: the image height.
  int top_row = 0;
  int bottom_row = 0;
  // Width of the bars looked for, pixels. With a horizon row, the width
  // follows the road: marking_width_m * (v - horizon_row) / height_m pixels
  // (a marking that wide on a flat road seen by a camera that high, for
  // square pixels); without one, each of `fixed_widths_px` is tried and the
  // strongest response is kept.
  std::optional<double> horizon_row;
  double marking_width_m = 0.15;
  double height_m = 1.5;
  std::vector<double> fixed_widths_px;
  // A bar pixel is brighter than the road on each side by at least this
  // (grey levels) and by the `quantile` of the band's responses.
  double min_contrast = 10.0;
  double quantile = 0.96;
  // The band is cut into slices of this many rows, so that each segment is a
  // short, nearly straight piece at one distance (0: image height / 12).
  int slice_rows = 0;
  // Kept pieces: at least this long (pixels; 0: image height / 40) and this
  // elongated (length / width), and at least this steep (degrees from
  // the image rows: stop lines and crosswalks are near horizontal).
  double min_length_px = 0;
  double min_elongation = 4.0;
  double min_angle_deg = 12.0;
};

// The paint channel of a BGR frame: min(red, green) (white and yellow paint
// are bright in both). A CV_8UC1 frame is used as it is.
cv::Mat PaintChannel(const cv::Mat& frame);

// Marking segments of one frame (CV_8UC3 BGR or CV_8UC1 paint channel).
std::vector<ImageSegment> FindMarkingSegments(const cv::Mat& frame,
                                              const MarkingSegmentOptions& options);

// FindMarkingSegments' first step: the bright-bar response of the rows
// [top_row, bottom_row) of a paint channel (CV_8UC1), smoothed over 3 rows
// first, as CV_32F grey levels (rows from top_row; 0 where no bar fits).
cv::Mat MarkingResponse(const cv::Mat& paint, const MarkingSegmentOptions& options);

// The bar widths looked for without a horizon (the first pass of `lane
// calibrate`): W/320, W/160, W/80 and W/40 for frames W pixels wide, at
// least 2 pixels.
std::vector<double> FixedBarWidths(int image_width);

struct VanishingPointOptions {
  // A segment supports a point when its direction is within this angle of
  // the direction from its centre to the point.
  double inlier_angle_deg = 1.5;
  // Support needed: this many segments, whose directions span at least
  // `min_spread_deg` (two lines at nearly the same angle locate nothing).
  int min_inliers = 4;
  double min_spread_deg = 10.0;
  // Curve check: the near half and the far half of a frame's segments (by
  // row) each give a point when they can; the frame is left out when these
  // differ by more than this angle seen from the camera (converted to
  // pixels with `focal_px`).
  double curve_tolerance_deg = 0.5;
  double focal_px = 500.0;
  // At most this many segments (the longest) enter the pair search.
  int max_segments = 80;
  // A point known roughly (pass 1): candidates further than prior_gate_deg
  // from it (seen from the camera) are not considered.
  std::optional<Eigen::Vector2d> prior;
  double prior_gate_deg = 4.0;
  // Where a point may lie (pixels), when set.
  std::optional<cv::Rect2d> bounds;
};

// Why a frame gave no vanishing point (kOk when it did). kElsewhere: its
// markings meet, but further than prior_gate_deg from the prior (pass 1's
// point), so they disagree with it rather than being absent.
enum class VpFrameResult { kOk, kNoMarkings, kCurved, kStationary, kElsewhere };
const char* VpFrameResultName(VpFrameResult result);

struct FrameVanishingPoint {
  VpFrameResult result = VpFrameResult::kNoMarkings;
  Eigen::Vector2d point = Eigen::Vector2d::Zero();
  int inliers = 0;           // segments that support the point
  int segments = 0;          // segments considered
  double rms_deg = 0;        // angle residual of the supporting segments
  std::vector<int> support;  // indices (into the input) of the supporting segments
};

// The point where a frame's segments meet. Deterministic.
FrameVanishingPoint EstimateFrameVanishingPoint(const std::vector<ImageSegment>& segments,
                                                const VanishingPointOptions& options);

// The point most segments of all frames point at: candidates from pairs
// of each frame's longest `pairs_per_frame` segments, support counted over
// every segment of every frame (no curve check). A lane marking's segments
// point at the vanishing point from frame to frame, whereas poles, trunks
// and vehicle edges move with the scene.
struct PooledVanishingPoint {
  Eigen::Vector2d point;
  int support = 0;
  int segments = 0;
  // The supporting segments: (frame, index into that frame's segments).
  std::vector<std::pair<int, int>> supporting;
};
std::optional<PooledVanishingPoint> EstimatePooledVanishingPoint(
    const std::vector<std::vector<ImageSegment>>& frames, const VanishingPointOptions& options,
    int pairs_per_frame = 12);

// Least-squares point of a set of image lines, each given by a point and a
// unit direction, weighted; none when the lines are (nearly) parallel.
std::optional<Eigen::Vector2d> IntersectLines(const std::vector<Eigen::Vector2d>& points,
                                              const std::vector<Eigen::Vector2d>& directions,
                                              const std::vector<double>& weights);

// Per-frame points combined: the mean of the frames within 3 robust
// standard deviations (1.4826 MAD, at least `min_spread_px`) of the median,
// per coordinate.
struct CombinedVanishingPoint {
  Eigen::Vector2d point = Eigen::Vector2d::Zero();
  Eigen::Vector2d standard_error = Eigen::Vector2d::Zero();  // of the mean, pixels
  Eigen::Vector2d spread = Eigen::Vector2d::Zero();          // std of the kept frames, pixels
  int frames_used = 0;
  int frames_rejected = 0;  // outliers to the median
  std::vector<int> used;    // indices (into the input) of the frames kept
};
std::optional<CombinedVanishingPoint> CombineVanishingPoints(
    const std::vector<Eigen::Vector2d>& points, double min_spread_px = 1.0);

// Half-widths (pixels, per coordinate) of a 95 % interval for
// CombineVanishingPoints' point: a bootstrap over the frames (each
// resample combined the same way, outlier rejection included), its
// percentile interval widened by t(n-1) / z for few frames. Deterministic.
Eigen::Vector2d BootstrapInterval(const std::vector<Eigen::Vector2d>& points,
                                  double min_spread_px = 1.0, int resamples = 1000);

}  // namespace lane

#endif  // LANE_VANISHING_POINT_H_
