// The top view a camera needs, derived from its geometry (docs/config.md,
// "Choosing a ground view"): no per-camera numbers, only the camera, where
// the road ends at the bottom of its image (a hood), and physical
// conventions in metres (a lane width, a dash cycle, a marking's width).
//
// `lane calibrate` writes this view, with the road's outline found in the
// frames; a config that gives a camera and no `ipm` gets it built in, with
// the image's bottom as the outline.
#ifndef LANE_GEOMETRY_GROUND_VIEW_RULE_H_
#define LANE_GEOMETRY_GROUND_VIEW_RULE_H_

#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "lane/geometry/camera.h"
#include "lane/geometry/ipm.h"

namespace lane {

// Where the road ends at the bottom of the image: per image column, the
// first row below the road (the car's hood, a mount, or the image's
// bottom). A hood is seldom flat: it rises towards the image's centre.
struct RoadOutline {
  // One row per image column (0 .. width - 1); empty: the image's bottom
  // in every column.
  std::vector<double> first_row_below;

  // The outline of a flat edge at `row` (a hood edge given as one row).
  static RoadOutline Flat(double row, int image_width);
  // The first row below the road in column `u` (rounded to the nearest
  // column, clamped to the image): at most `image_height`.
  double FirstRowBelow(double u, int image_height) const;
  // The highest and the lowest first row below the road across the image.
  double Top(int image_height) const;
  double Bottom(int image_height) const;
};

// The rule. Each field is a convention in metres or pixels, not a camera's
// number; the defaults are the project's conventions.
struct GroundViewRule {
  // The boundaries the view must hold lie up to `reach_lanes` lane widths
  // either side of the camera: the ego lane's and the next one on each side
  // with the car in the middle of its lane (1.5 x 3.5 m = 5.25 m).
  double lane_width_m = 3.5;
  double reach_lanes = 1.5;
  // Each such boundary must show this much road (in the image, above the
  // hood) inside the view: one dash cycle of a US dashed line (3 m of paint,
  // 9 m of gap), so that a dashed boundary shows a whole dash wherever its
  // pattern falls.
  double stretch_m = 12.0;
  // The far limit of a useful resolution: the view ends where a marking of
  // this width covers `min_marking_px` image columns. Beyond it the top view
  // only magnifies the image, and the image extension searches on.
  double marking_width_m = 0.15;
  double min_marking_px = 2.0;
  // Across: +-(lateral_lanes lane widths + lateral_margin_m), the ego lane's
  // boundaries and the next on each side with the car half a lane off
  // centre (+-7.5 m for 3.5 m lanes).
  double lateral_lanes = 2.0;
  double lateral_margin_m = 0.5;
  // Resolution of the top view. Across: a 15 cm marking spans 2.4 pixels;
  // along: the filter smooths over 1 m (8 pixels per sigma).
  double metres_per_px_x = 0.0625;
  double metres_per_px_y = 0.125;
  // Rows nearer the horizon than this are not road for the rule
  // (IpmOptions::horizon_margin_px).
  double horizon_margin_px = 10.0;

  absl::Status Validate() const;
};

// The view and the distances it was derived from.
struct DerivedGroundView {
  GroundView view;
  // The nearest ground that any boundary within the reach shows (the view's
  // near edge), and the distance at which the last of them comes into view:
  // the view reaches `stretch_m` beyond it, unless `far_limit_m` cuts it.
  double nearest_road_m = 0;
  double last_entry_m = 0;
  // Where the outermost boundaries (at +-reach) come into view, left and
  // right; infinity when one never does below the far limit.
  double outer_left_entry_m = 0;
  double outer_right_entry_m = 0;
  // The far limit: the nearer of the resolution's and the horizon margin's.
  double far_limit_m = 0;
  // True when the far limit cut some boundary's stretch short (or one
  // never came into view): beyond the view, the image extension searches on.
  bool cut = false;
};

// The top view for `camera` with the road ending at `outline` (default: the
// image's bottom). INVALID_ARGUMENT for a bad camera or rule, or when no
// boundary within the reach shows on the road below the horizon.
absl::StatusOr<DerivedGroundView> DeriveGroundView(const CameraModel& camera,
                                                   const RoadOutline& outline = {},
                                                   const GroundViewRule& rule = {});

// The IPM options of a derived view: `base` (a template's) with the ground
// view, area-averaged (one top-view pixel covers several image pixels near
// the camera).
IpmOptions GroundViewIpm(const GroundView& view, IpmOptions base = {});

// The built-in top view of a config that gives a camera and no `ipm`: the
// rule's view with the image's bottom as the road's end, area-averaged.
absl::StatusOr<IpmOptions> BuiltInIpm(const CameraModel& camera);

}  // namespace lane

#endif  // LANE_GEOMETRY_GROUND_VIEW_RULE_H_
