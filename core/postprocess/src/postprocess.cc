#include "lane/postprocess/postprocess.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "lane/postprocess/candidate_checks.h"
#include "lane/postprocess/image_extension.h"
#include "lane/postprocess/spline_walk.h"

namespace lane {
namespace {

bool PassesShapeChecks(const Bezier& s, double min_length, double min_straightness) {
  return s.Length() >= min_length && s.Straightness() >= min_straightness;
}

// The top view part of one candidate: localise, check, extend, check. False
// when the candidate is dropped.
bool PostprocessInTopView(SplineCandidate& c, const PostprocessFrame& f,
                          const PostprocessOptions& pp, const TopViewCheckContext& context) {
  const double mpp_x = f.ipm.metres_per_px_x();
  const double ipm_min_len = pp.min_length_fraction * f.ipm.height();
  if (ChordAngleFromVerticalDeg(c.ipm) > pp.ipm_max_angle_from_vertical_deg) return false;
  const Bezier ipm_line = Bezier::Line(c.line.top, c.line.bottom);
  double contrast = 0;
  if (auto loc = LocalizeSpline(c.ipm, f.filtered, pp.localize_points, pp.ipm_normal_search_px, 0.0,
                                pp.localize_min_cos)) {
    c.ipm = TopDown(loc->spline);
    contrast = loc->mean_contrast;
  }
  if (!PassesShapeChecks(c.ipm, ipm_min_len, pp.min_straightness)) c.ipm = ipm_line;
  if (pp.extend_in_ipm && contrast > 0) {
    ExtendOptions eo;
    eo.step_px = pp.ipm_extend_step_px;
    eo.search_px = pp.ipm_normal_search_px;
    eo.sigma_px = 0;
    eo.min_contrast = pp.continuation_threshold * contrast;
    eo.min_cos_start = pp.extend_min_cos_up;
    eo.min_cos_end = pp.extend_min_cos_down;
    c.ipm = TopDown(ExtendSpline(c.ipm, f.filtered, eo));
    if (!PassesShapeChecks(c.ipm, ipm_min_len, pp.min_straightness)) c.ipm = ipm_line;
  }
  if (ChordAngleFromVerticalDeg(c.ipm) > pp.ipm_max_angle_from_vertical_deg) return false;
  if (pp.min_side_contrast > 0 && BarContrast(c.ipm, f.top_view, pp.side_offset_m / mpp_x,
                                              pp.min_bar_fraction) < pp.min_side_contrast) {
    return false;  // a step (curb, road edge), not a bright marking
  }
  return PassesTopViewChecks(c.ipm, f.top_view, f.ipm, pp, context);
}

// The image part: back-project, localise, check, extend, check, finish. False
// when the candidate is dropped.
bool PostprocessInImage(SplineCandidate& c, const PostprocessFrame& f, const PostprocessOptions& pp,
                        double marking_width_m) {
  const CameraModel& cam = f.ipm.camera();
  const double scale = cam.image_width / 640.0;
  const ExtensionRows rows = ImageExtensionRows(cam, f.ipm.roi(), pp);
  auto to_image = [&f](const Eigen::Vector2d& p) { return f.ipm.IpmToImage(p); };
  const auto image_line = MapSpline(Bezier::Line(c.line.top, c.line.bottom), 4, to_image);
  auto image = MapSpline(c.ipm, pp.backproject_samples, to_image);
  if (!image || !image_line) return false;
  c.image = TopDown(*image);
  const Bezier fallback = TopDown(*image_line);
  const double min_len = pp.min_image_length_px * scale;
  LocalizeOptions lo;
  lo.points = pp.localize_points;
  lo.search_m = pp.localize_search_m;
  lo.sigma_m = pp.localize_sigma_m;
  lo.min_sigma_px = pp.profile_sigma_px * scale;
  lo.max_search_px = 2 * pp.localize_search_px * scale;
  lo.min_cos = pp.localize_min_cos;
  lo.marking_width_m = marking_width_m;
  lo.on_bars = pp.localize_on_bars;
  const bool localize = pp.localize_in_image && (!pp.localize_only_coarse_top_view ||
                                                 f.ipm.metres_per_px_x() > marking_width_m);
  if (localize) {
    if (auto loc = LocalizeInImage(c.image, f.channel, cam, lo)) {
      c.image = TopDown(*loc);
    }
    if (!PassesShapeChecks(c.image, min_len, pp.min_straightness)) c.image = fallback;
  }
  if (pp.extend_in_image) {
    const ImageExtendOptions eo =
        ImageExtendOptionsFrom(pp, scale, rows.min_row, rows.max_row, marking_width_m);
    // The extension follows the bar under the spline. A spline with none
    // under it in the image (ImageBarContrast 0: no sample's profile has a
    // bar within half a marking width) is localised in the image first,
    // when a fine top view skipped that; one with no bar near it even then
    // is no marking: on driver161-a every one was a vehicle's lower edge or
    // its shadow's border (a step, not a bar; docs/accuracy-log.md, entry
    // 61), and is dropped.
    double reference = ImageBarContrast(c.image, f.channel, cam, eo);
    if (!(reference > 0) && !localize && pp.localize_in_image) {
      if (auto loc = LocalizeInImage(c.image, f.channel, cam, lo)) {
        const Bezier moved = TopDown(*loc);
        const double moved_reference = ImageBarContrast(moved, f.channel, cam, eo);
        if (moved_reference > 0 && PassesShapeChecks(moved, min_len, pp.min_straightness)) {
          c.image = moved;
          reference = moved_reference;
        }
      }
    }
    if (!(reference > 0)) return false;
    ImageExtendOptions straight = eo;
    straight.max_steps = 0;
    // The first extension whose shape passes the checks, else the line. A
    // spline that bent off its marking (a short or wiggly fit, a
    // localisation pulled aside) extends into a shape that fails them; the
    // line it was fitted around then goes in its place, and is extended in
    // turn (it ran the whole top view, so its extension is steadier). When
    // the walks along the line stray too (onto a vehicle, far away), the
    // line is only carried on straight down (with extend_to_max_row), which
    // needs no evidence beyond its own.
    const Bezier spline = c.image;
    c.image = fallback;
    // (The straight attempt walks nowhere: its reference is not needed.)
    const struct {
      const Bezier& from;
      const ImageExtendOptions& options;
      double reference;  // its ImageBarContrast when known; < 0: measure it
    } attempts[] = {{spline, eo, reference}, {fallback, eo, -1}, {fallback, straight, 0}};
    for (const auto& a : attempts) {
      const Bezier extended =
          TopDown(a.reference >= 0 ? ExtendInImage(a.from, a.reference, f.channel, cam, a.options)
                                   : ExtendInImage(a.from, f.channel, cam, a.options));
      if (PassesShapeChecks(extended, min_len, pp.min_straightness)) {
        c.image = extended;
        break;
      }
    }
  }
  const std::optional<Bezier> finished =
      FinishImageSpline(c.image, f.channel, f.frame, cam, pp, scale, f.ipm.roi().bottom);
  if (!finished) return false;
  c.image = *finished;
  return true;
}

}  // namespace

std::vector<SplineCandidate> PostprocessCandidates(const std::vector<SplineCandidate>& candidates,
                                                   const PostprocessFrame& frame,
                                                   const PostprocessOptions& options,
                                                   double marking_width_m,
                                                   double merge_distance_px) {
  std::vector<Bezier> ipm_splines;
  for (const SplineCandidate& c : candidates) ipm_splines.push_back(c.ipm);
  const TopViewCheckContext context =
      MakeTopViewCheckContext(ipm_splines, frame.top_view, frame.ipm, options);
  const double scale = frame.ipm.camera().image_width / 640.0;
  std::vector<SplineCandidate> done;
  for (SplineCandidate c : candidates) {
    if (!PostprocessInTopView(c, frame, options, context)) continue;
    if (!PostprocessInImage(c, frame, options, marking_width_m)) continue;
    bool dup = false;
    for (const auto& d : done) {
      dup = dup || MeanNearestDistanceBelow(c.image, d.image, merge_distance_px * scale * 2.5);
    }
    if (!dup) done.push_back(c);
  }
  return done;
}

}  // namespace lane
