// Image structure that stays put while the road moves (docs/calibration.md,
// "Static structure"): a reflection in the windscreen, a sticker, the hood's
// edge, a camera's timestamp overlay. Fixed to the camera, it gives the same
// marking segments in every frame, and so votes for one vanishing point in
// every frame, which is exactly what the first pass of `lane calibrate`
// rewards. It is not road either, so the detector may ignore it too
// (IpmOptions::static_mask).
//
// A pixel is static when, over a drive's moving frames, both
//   * a bright bar is present there in most frames (the first pass's bar
//     test, at its four widths), and
//   * its appearance stays the same: most of its detail (the paint channel
//     minus a blur of it) is the same signal in every frame.
// The second test keeps the markings that stay in place in the image (a
// solid line on a straight road): the car weaves and vibrates by pixels, so
// the line's detail changes sign across its edges from frame to frame, and
// the asphalt and paint texture along it move; a reflection's digits do not
// move at all.
#ifndef LANE_CALIBRATE_STATIC_STRUCTURE_H_
#define LANE_CALIBRATE_STATIC_STRUCTURE_H_

#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "lane/calibrate/vanishing_point.h"
#include "lane/geometry/ipm.h"

namespace lane {

struct StaticStructureOptions {
  // Off: nothing is static (calibration as before 2026-12-07).
  bool enabled = true;
  // Presence: a bright bar at least `min_contrast` grey levels above both
  // sides (MarkingSegmentOptions' test and threshold) in at least this share
  // of the moving frames.
  double min_contrast = 10.0;
  double min_presence = 0.7;
  // Appearance: detail = paint channel minus its Gaussian blur of
  // `detail_sigma_px`; coherence = mean(detail)^2 / (mean(detail^2) +
  // noise_levels^2), the share of the detail's energy that is the same in
  // every frame (1 for a fixed pattern, about 1/frames for a moving one).
  // Measured (docs/calibration.md, "Static structure"): road pixels present
  // in 70 % of the frames (driver161-a reaches 0.74, rendered drives 0.73)
  // have a coherence of 0.3 at most, and road pixels as coherent as 0.5
  // (a 1 s rendered clip) are present in less than 70 %; about 400 pixels
  // of the card's digits on driver161-a pass both.
  double detail_sigma_px = 3.0;
  double noise_levels = 2.0;
  double min_coherence = 0.5;
  // With fewer moving frames than this nothing is static: too few frames
  // to tell a marking from the camera's own structure.
  int min_frames = 10;
  // A segment whose axis runs over static pixels (grown by margin_px: the
  // axis is fitted to the bar's row centres) along at least this share of
  // its length is static and gets no vote.
  double margin_px = 2.0;
  double min_static_share = 0.5;
  // The mask as rectangles (a config's ipm.static_mask): the static pieces
  // grown by box_margin_px (a digit's strokes merge into one box), at most
  // max_boxes of them (the largest), each at least min_box_area pixels of
  // static pixels.
  int box_margin_px = 4;
  int max_boxes = 16;
  int min_box_area = 20;

  absl::Status Validate() const;
};

// What a drive showed: the static pixels, their pieces as rectangles.
struct StaticStructure {
  // CV_8U of the frames' size, 255 on static pixels grown by margin_px;
  // empty when nothing is known (disabled, or too few frames).
  cv::Mat mask;
  // The static pieces' rectangles (grown by box_margin_px, clipped to the
  // image), largest first.
  std::vector<Roi> boxes;
  int frames = 0;  // moving frames seen
  double min_static_share = 0.5;

  // True when `s` runs over static pixels along at least min_static_share
  // of its length.
  bool Covers(const ImageSegment& s) const;
  // The boxes that reach into rows (top, bottom): the ones a detector
  // reading those rows could see.
  std::vector<Roi> BoxesInRows(double top, double bottom) const;
  // Removes the segments it covers from `segments` and returns them.
  std::vector<ImageSegment> TakeCovered(std::vector<ImageSegment>& segments) const;
};

// Feed the paint channels (PaintChannel: CV_8UC1, all of one size) of a
// drive's moving frames; Finish gives the static structure.
class StaticStructureFinder {
 public:
  explicit StaticStructureFinder(StaticStructureOptions options = {})
      : options_(std::move(options)) {}

  void Add(const cv::Mat& paint);
  int frames() const { return frames_; }
  StaticStructure Finish() const;

 private:
  StaticStructureOptions options_;
  int frames_ = 0;
  cv::Mat presence_;            // CV_32F: frames with a bar at the pixel
  cv::Mat detail_sum_;          // CV_32F: sum of the detail
  cv::Mat detail_sum_squares_;  // CV_32F: sum of its squares
};

}  // namespace lane

#endif  // LANE_CALIBRATE_STATIC_STRUCTURE_H_
