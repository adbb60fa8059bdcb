// Walks along a spline's normals in an image (or the top view): localising
// it on the profile peaks, measuring how much of a bright bar it is, and
// extending it along its tangent (paper II-E.1, II-E.2). The steps stage 7
// is made of.
#ifndef LANE_POSTPROCESS_SPLINE_WALK_H_
#define LANE_POSTPROCESS_SPLINE_WALK_H_

#include <optional>

#include "lane/geometry/bezier.h"
#include "lane/geometry/channel_view.h"

namespace lane {

// A spline moved onto the profile peaks along its normals, and the peaks'
// mean contrast.
struct LocalizedSpline {
  Bezier spline;
  double mean_contrast = 0;
};
// Localisation: moves `n` samples of the spline to the profile peak along
// their normals, rejects points that turn too sharply, and refits. nullopt if
// fewer than 4 points survive.
std::optional<LocalizedSpline> LocalizeSpline(const Bezier& spline, const ChannelView& image, int n,
                                              double search_px, double sigma_px, double min_cos);

// The (1 - bar_fraction) quantile over samples of `spline` of min(I(p) -
// I(p - d n), I(p) - I(p + d n)) where n is the normal, d = side_offset_px
// and I(p) is the brightest value within 1 px of p along n: how much
// brighter the curve is than both of its sides along bar_fraction of its
// length (a high quantile lets dashed markings pass).
double BarContrast(const Bezier& spline, const ChannelView& image, double side_offset_px,
                   double bar_fraction, int samples = 20);

struct ExtendOptions {
  double step_px = 10;
  double search_px = 20;
  double sigma_px = 2;
  double min_contrast = 0;      // absolute contrast to continue
  double min_cos_start = 0.95;  // going towards t=0
  double min_cos_end = 0.86;    // going towards t=1
  double min_row = 0;           // stay within these rows
  double max_row = 1e9;
  int max_steps = 60;
};
// Extension at both ends along the tangent, then a refit through the old
// samples and the new points. Returns the input when nothing was added.
Bezier ExtendSpline(const Bezier& spline, const ChannelView& image, const ExtendOptions& options);

}  // namespace lane

#endif  // LANE_POSTPROCESS_SPLINE_WALK_H_
