// Stage 7, extension in the image (paper section II-E.2), with the camera's
// geometry: the spline is followed along its tangent up towards the horizon
// and down towards the bottom of the road, as long as the image profile
// across it shows a bright bar; gaps between dashes are walked through, and
// below the last evidence the final straight segment may be extrapolated.
//
// Widths and gaps are given on the road (metres) and converted at each step
// with the camera, so one set of values holds from the near rows, where a
// 15 cm marking spans many pixels, to the far rows, where it spans two.
#ifndef LANE_IMAGE_EXTENSION_H_
#define LANE_IMAGE_EXTENSION_H_

#include <limits>
#include <optional>

#include "lane/geometry/bezier.h"
#include "lane/geometry/camera.h"
#include "lane/geometry/channel_view.h"
#include "lane/geometry/ipm.h"
#include "lane/postprocess/postprocess_options.h"

namespace lane {

struct ImageExtendOptions {
  double step_px = 10;           // step along the tangent, image pixels
  double search_m = 0.4;         // half length of the normal searched, metres on the road
  double min_search_px = 4;      // ... but at least this many pixels
  double max_search_px = 40;     // ... and at most this many
  double marking_width_m = 0.1;  // width of the bar looked for, metres
  double sigma_px = 2;           // profile smoothing (sigma), pixels
  // A step is supported when the profile's bar contrast (peak minus the
  // brighter of the two sides one marking width out) reaches this fraction
  // of the spline's own bar contrast.
  double continuation_threshold = 0.35;
  double max_gap_m = 12;       // unsupported distance along the road walked through
  double min_cos_up = 0.86;    // direction change allowed going up (towards t = 0)
  double min_cos_down = 0.95;  // going down
  // The walk follows the road: each new point, seen on the ground from the
  // last supported one, must run within this angle of the road's direction
  // (the top view's check, paper II-E.3, applied while extending; without it
  // a walk near the horizon slides along vehicles' lower edges). <= 0: off.
  double max_ground_angle_deg = 20;
  double min_row = 0;  // the walk stays within these image rows
  double max_row = 1e9;
  // Below the last supported point, extend the final straight segment down
  // to max_row (or the image's bottom row, whichever is higher).
  bool extrapolate_down = false;
  int max_steps = 80;
  // Walking down (towards the camera), profiles are smoothed with this sigma
  // on the road (metres; 0 = off), as localisation's are: near the camera
  // the two lines of a double line resolve, and the walk would jump to one
  // of them (half the pair's width aside: a turn the direction checks
  // refuse), where the boundary is labelled at their centre. Where the wider
  // profile would leave the image, the narrow one is used.
  double down_sigma_m = 0;
};

// Localisation in the image (paper section II-E.1) with the camera's
// geometry: `points` samples of the spline move to the strongest bar of the
// profile across them, searched +-search_m on the road and smoothed with
// sigma_m on the road (at least min_sigma_px), converted to pixels at each
// sample. A bar is a local maximum brighter than both of its sides, a
// marking width (and at least 2.5 sigma) out; the bright side of a step (a
// shadow's border, a curb, the hood's reflection) is not one. A smoothing as
// wide as a marking merges the two lines of a double line into one peak at
// their centre, where such a boundary is labelled, and leaves a single
// line's peak at its centre. Points without a bar stay out; points that turn
// the curve by more than acos(min_cos) are rejected; nullopt if fewer than 4
// remain.
struct LocalizeOptions {
  int points = 21;
  double search_m = 0.4;
  double sigma_m = 0.1;
  double min_sigma_px = 2;
  double max_search_px = 40;
  double min_cos = 0.9;
  double marking_width_m = 0.1;
  // false: the brightest point of the profile (the peak of the paper and the
  // reference), which a bright step beside a marking wins.
  bool on_bars = true;
};
std::optional<Bezier> LocalizeInImage(const Bezier& spline, const ChannelView& image,
                                      const CameraModel& camera, const LocalizeOptions& options);

// Angle of the chord of `spline` (image) from the road's direction on the
// ground, degrees; 90 when its ends do not map to the ground ahead.
double GroundAngleFromRoadDeg(const Bezier& spline, const CameraModel& camera);

// The image rows the extension stays within: extend_min_row and
// extend_max_row of `pp`, or when negative derived from the camera's horizon
// and the ROI's bottom (min: horizon + 0.15 (bottom - horizon); max: bottom +
// 0.2 (bottom - horizon), the reference's rows 200..380 for the Caltech
// camera).
struct ExtensionRows {
  double min_row = 0;
  double max_row = 0;
};
ExtensionRows ImageExtensionRows(const CameraModel& camera, const Roi& roi,
                                 const PostprocessOptions& pp);

// The options of the post-processing's image extension: pixel values of
// `pp` scaled by `scale` (image width / 640), rows as given, the bar as wide
// as `marking_width_m`.
ImageExtendOptions ImageExtendOptionsFrom(const PostprocessOptions& pp, double scale,
                                          double min_row, double max_row, double marking_width_m);

// Mean bar contrast of `spline` in the image, over `samples` points: the
// smoothed profile across the spline at its peak minus the brighter side one
// marking width away. 0 when no sample shows a bar.
double ImageBarContrast(const Bezier& spline, const ChannelView& image, const CameraModel& camera,
                        const ImageExtendOptions& options, int samples = 11);

// The extension; P0 of `spline` must be its upper (far) end. Returns the
// refitted spline (upper end first), or the input when nothing was added.
// The walks follow the bar under the spline (its ImageBarContrast, the
// reference the continuation threshold is a fraction of); without one
// (contrast 0) there is nothing to follow, and only extrapolate_down (a
// labelling convention, which needs no evidence) applies.
Bezier ExtendInImage(const Bezier& spline, const ChannelView& image, const CameraModel& camera,
                     const ImageExtendOptions& options);
// The same with the spline's ImageBarContrast already measured.
Bezier ExtendInImage(const Bezier& spline, double reference, const ChannelView& image,
                     const CameraModel& camera, const ImageExtendOptions& options);

// The longest part of `spline` that lies inside the image and on image
// content: points where the image is black in a 5x5 neighbourhood (outside
// a lens's image circle, as in the Caltech Lanes frames) do not count,
// except at or below image row `convention_row`: there a labelling
// convention carries lanes on whatever the image shows (CULane's lanes run
// through the car's hood, which is black at night, to the bottom row).
// Samples of the kept part are refitted; nullopt when fewer than 4 samples
// of 40 remain. Top-view splines project beyond the image's sides where the
// ground rectangle does; labels stop at the image's edge.
std::optional<Bezier> ClipToImageContent(
    const Bezier& spline, const ChannelView& image,
    double convention_row = std::numeric_limits<double>::infinity());

}  // namespace lane

#endif  // LANE_IMAGE_EXTENSION_H_
