// Stage 7's options (PostprocessOptions): the checks in the top view, the
// localisation and extension in the image and the checks after them. The
// bottom of the postprocess layer: every check reads its options from here.
#ifndef LANE_POSTPROCESS_POSTPROCESS_OPTIONS_H_
#define LANE_POSTPROCESS_POSTPROCESS_OPTIONS_H_

#include "absl/status/status.h"

namespace lane {

struct PostprocessOptions {
  // --- checks in the top view ---
  // Splines whose mean direction is further than this from vertical are
  // dropped (reference: closer than 70 deg to horizontal), degrees.
  double ipm_max_angle_from_vertical_deg = 20.0;
  // Splines whose control polygon is less straight than this (mean cosine of
  // its angles, 1 = straight) fall back to the RANSAC line.
  double min_straightness = 0.85;
  // Splines shorter than this fraction of the top view's height fall back to
  // the RANSAC line.
  double min_length_fraction = 0.25;
  // Marking check (not in the paper): a painted marking is a bright bar, darker
  // on BOTH sides, whereas a curb or the edge of the asphalt is a step that
  // is dark on one side only, yet excites the second-derivative filter too.
  // Along the top-view spline, the IPM intensity must exceed the intensity
  // `side_offset_m` to the left and to the right by at least
  // `min_side_contrast` (IPM intensity units, 1 = full scale) along at least
  // `min_bar_fraction` of its length (so dashed markings pass).
  // 0 disables the check. The paper lists curbs as its main source of false
  // positives (section IV).
  double side_offset_m = 0.3;
  double min_side_contrast = 0.027;
  // A dashed line is paint along a quarter of its length on US roads (3 m
  // dashes, 9 m gaps; 2 m / 4 m, a third, on Chinese urban roads), and a
  // top view about one dash cycle deep shows a dash cut by its edge as less.
  // A quarter, the old fixed value, lost dashed lines on about half their
  // frames; a fifth keeps them. The contrast above went up with it, from
  // 0.015, to keep the false-positive rate (cordova1, docs/accuracy-log.md
  // entry 35).
  double min_bar_fraction = 0.2;
  // Vertical objects (lane/postprocess/vehicle_check.h): a top-view spline closer in
  // direction to the ray from the camera's foot point through it than to the
  // road's direction is dropped, where the two directions differ by at
  // least this many degrees (twice the ~3 deg by which yaw and curvature
  // tilt markings from the road's axis). 0 disables the test.
  // The road's direction is the frame's median candidate direction; a
  // candidate that bends by more than max_ray_bend_m from its straight line
  // is a marking on a curve, not a (straight) ray.
  double min_ray_angle_deg = 6.0;
  // Bright neighbours (lane/postprocess/vehicle_check.h): a top-view spline with a side,
  // side_offset_m across, brighter than the road by more than half its own
  // contrast along more than this fraction of its length is dropped: a
  // marking has road on both sides. >= 1 disables it (the default: on the
  // dev clips it cost more markings, beside double lines and bright curbs,
  // than it removed false positives; docs/accuracy-log.md).
  double max_bright_side_fraction = 1.0;
  double max_ray_bend_m = 0.15;
  // Extension in the top view: tangent step and normal half-search, IPM px.
  double ipm_extend_step_px = 5.0;
  double ipm_normal_search_px = 10.0;

  // --- in the image (values for a 640 px wide image; scaled by width/640) ---
  // Samples of the top-view spline mapped back to refit it in the image.
  int backproject_samples = 11;
  // Localisation: points sampled on the spline and half length of the normal
  // segment searched for the brightest (Gaussian-smoothed) profile peak.
  int localize_points = 21;
  double localize_search_px = 20.0;
  double profile_sigma_px = 2.0;
  // A localised point is rejected when the direction to it from the previous
  // point turns by more than acos(localize_min_cos) from the spline's.
  double localize_min_cos = 0.9;
  // Extension: tangent step and normal half-search, pixels (the top view's
  // walk uses the ipm_ values; the image's bar search these).
  double extend_step_px = 10.0;
  double extend_search_px = 20.0;
  // Stop when the profile contrast falls below this fraction of the mean
  // contrast of the localised points.
  double continuation_threshold = 0.35;
  // Stop when the direction turns by more than acos(cos) from the spline's
  // direction: looser going up (far, curves look sharper) than down.
  double extend_min_cos_up = 0.86;
  double extend_min_cos_down = 0.95;
  // Extension stays between these image rows. Negative = derived from the
  // camera: top = horizon + 0.15 * (ROI bottom - horizon), bottom = ROI bottom
  // + 0.2 * (ROI bottom - horizon) (reference: rows 200..380 of the Caltech
  // camera, whose horizon is at row 171 and ROI bottom at 350).
  double extend_min_row = -1;
  double extend_max_row = -1;
  // Extension in the image follows the road's geometry
  // (lane/postprocess/image_extension.h): each step looks for a bright bar as wide as a
  // marking across a normal `extend_search_m` metres long on the road (so the
  // window follows the perspective: the reference's fixed 20 px are +-1.4 m
  // at the Caltech camera's far rows and +-0.2 m at its near rows), walks
  // through up to `extend_gap_m` metres without one (the gap between two
  // dashes: the longest standard gap, a German motorway's 12 m (6 m dashes;
  // US 9 m, 3 m dashes; Chinese roads 4-9 m), so a dashed line is followed
  // as far as its dashes continue; beyond that the lane is not followed.
  // 6 m until docs/accuracy-log.md entry 63 stopped at a US gap), and, with
  // `extend_to_max_row`, extrapolates the final straight segment down to
  // `extend_max_row` (the road continues straight under the last evidence; lane labels such as
  // CULane's run to the image bottom). Localisation in the image (LocalizeInImage) searches the
  // normal
  // +-localize_search_m on the road and smooths the profile with
  // localize_sigma_m on the road (at least profile_sigma_px), so the two
  // lines of a double line merge into one peak at their centre (0.1 m: a
  // marking's width; the lines of a double line are 10-15 cm apart). (The
  // reference's fixed-pixel walk in the image, `extend_geometric` and
  // `localize_geometric` false, was removed: no config used it.)
  double localize_search_m = 0.4;
  // Localise on the strongest bar (brighter than both sides) rather than on
  // the brightest point (LocalizeOptions::on_bars).
  bool localize_on_bars = true;
  double localize_sigma_m = 0.1;
  double extend_search_m = 0.4;
  double extend_gap_m = 12.0;
  bool extend_to_max_row = false;
  // The final image spline is cut to the part inside the image and on image
  // content (not black: outside a lens's image circle). A top-view spline
  // spans the whole top view, which extends beyond the image's sides where
  // the ground rectangle does; a lane stops where the image does.
  bool clip_to_image = true;
  // The final image spline, mapped to the ground, must run within
  // ipm_max_angle_from_vertical_deg of the road's direction, as the top-view
  // spline had to (paper II-E.3: geometric checks after each step).
  bool check_ground_angle = true;
  // Colour (lane/postprocess/marking_check.h): an image spline whose median redness
  // (R - G) / R exceeds this is dropped. Yellow paint reads ~0.15, faded
  // orange ~0.3, red curbs, red cars and tail lights 0.5-0.7; 0.4 lies
  // between. >= 1 disables it. Grey frames are not checked.
  double max_redness = 0.4;
  // A final image spline shorter than this (pixels at 640 width) is replaced
  // by the line.
  double min_image_length_px = 40.0;
  // Turn extension/localisation in the image on or off.
  bool localize_in_image = true;
  // Localise in the image only where the top view cannot place a marking
  // itself: when its pixel across is wider than a marking
  // (filter.marking_width_m). A finer top view (a ground view of a few cm per
  // pixel) already puts the lane within a pixel of the marking, and the
  // image's wider search then only finds other bars beside it: shadows'
  // borders, curbs, vehicle edges (camera-only configs, 5 seeds:
  // driver161-a, 0.0625 m/px, CULane F1 0.463 localised vs 0.48 not;
  // cordova1's 0.114 m/px top view gains 0.06 from it).
  bool localize_only_coarse_top_view = true;
  bool extend_in_image = true;
  bool extend_in_ipm = true;

  absl::Status Validate() const;
};

}  // namespace lane

#endif  // LANE_POSTPROCESS_POSTPROCESS_OPTIONS_H_
