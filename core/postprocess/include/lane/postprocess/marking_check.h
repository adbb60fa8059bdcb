// Stage 7, the marking check in the image (not in the paper): a painted
// marking is a bar, brighter than the road on both sides, as wide as a
// marking (10-15 cm, wide lines 20-30 cm, double lines up to ~35 cm where
// the camera merges them). Crosswalk stripes (30-60 cm and more), vehicle
// bodies and the bright side of a step (a curb, a shadow's edge) are not.
//
// Widths are measured along image rows: a row of the image is a line of
// constant distance on the road (the camera does not roll), so the width of
// a bar across a row, divided by the image pixels per metre across the road
// at that row, is the marking's width on the road (for a marking parallel to
// the road; one at a small angle reads a little wider).
#ifndef LANE_MARKING_CHECK_H_
#define LANE_MARKING_CHECK_H_

#include "lane/geometry/bezier.h"
#include "lane/geometry/camera.h"
#include "lane/geometry/channel_view.h"
#include "lane/postprocess/postprocess_options.h"

namespace lane {

struct BarWidthOptions {
  int samples = 24;           // points of the image spline examined
  double window_m = 0.8;      // half length of the row profile, metres on the road
  double search_m = 0.15;     // the bar's peak is looked for this close to the spline
  double max_width_m = 0.4;   // wider bars are not markings
  double min_contrast = 6.0;  // peak over the profile's median, of 255: below, a gap
};

struct BarWidthReport {
  int structured = 0;         // samples with a bright peak (not a gap between dashes)
  int narrow_bars = 0;        // of those, bars of at most max_width_m
  double median_width_m = 0;  // of the samples that are bars (any width); 0 if none
  // Fraction of the structured samples that are narrow bars (0 if none).
  double NarrowFraction() const {
    return structured > 0 ? static_cast<double>(narrow_bars) / structured : 0.0;
  }
};

BarWidthReport MeasureBarWidths(const Bezier& spline, const ChannelView& image,
                                const CameraModel& camera, const BarWidthOptions& options);

// Colour (the paper's section IV: colour "will allow us to remove the false
// positives due to curbs"): lane paint is white or yellow, so red and green
// are about equally bright in it (yellow: green ~0.85 of red; faded orange
// ~0.7), while red-painted curbs, red vehicles and tail lights have green
// well below red. The median over `samples` points of the image spline of
// (R - G) / R at the brightest pixel (in `view`) within `search_px` of the
// spline along its row. NaN for a grey frame or when no sample is bright
// enough (R < 40) to have a colour.
double MedianRedness(const Bezier& spline, const cv::Mat& bgr, const ChannelView& view,
                     double search_px, int samples = 24);

}  // namespace lane

#endif  // LANE_MARKING_CHECK_H_
