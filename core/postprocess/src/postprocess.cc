#include "lane/postprocess/postprocess.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "lane/postprocess/candidate_checks.h"
#include "lane/postprocess/image_extension.h"

namespace lane {
namespace {

float Bilinear(const ChannelView& image, double x, double y) { return image.Bilinear(x, y); }

bool InBounds(const Eigen::Vector2d& p, const ChannelView& image) {
  return image.Inside(p.x(), p.y());
}

}  // namespace

absl::Status PostprocessOptions::Validate() const {
  auto bad = [](const char* name, double v, double lo, double hi) -> absl::Status {
    if (!(v >= lo && v <= hi)) {
      return absl::InvalidArgumentError(
          absl::StrCat("postprocess.", name, " must lie in [", lo, ", ", hi, "], got ", v));
    }
    return absl::OkStatus();
  };
  const struct {
    const char* name;
    double v, lo, hi;
  } checks[] = {
      {"ipm_max_angle_from_vertical_deg", ipm_max_angle_from_vertical_deg, 0, 90},
      {"min_straightness", min_straightness, -1, 1},
      {"min_length_fraction", min_length_fraction, 0, 10},
      {"ipm_extend_step_px", ipm_extend_step_px, 0.5, 100},
      {"ipm_normal_search_px", ipm_normal_search_px, 0, 100},
      {"backproject_samples", static_cast<double>(backproject_samples), 4, 1000},
      {"localize_points", static_cast<double>(localize_points), 4, 1000},
      {"localize_search_px", localize_search_px, 0, 500},
      {"profile_sigma_px", profile_sigma_px, 0, 50},
      {"localize_min_cos", localize_min_cos, -1, 1},
      {"extend_step_px", extend_step_px, 0.5, 500},
      {"extend_search_px", extend_search_px, 0, 500},
      {"continuation_threshold", continuation_threshold, 0, 10},
      {"extend_min_cos_up", extend_min_cos_up, -1, 1},
      {"extend_min_cos_down", extend_min_cos_down, -1, 1},
      {"min_image_length_px", min_image_length_px, 0, 1e5},
      {"side_offset_m", side_offset_m, 0, 10},
      {"min_side_contrast", min_side_contrast, 0, 1},
      {"min_bar_fraction", min_bar_fraction, 0.01, 1},
      {"extend_search_m", extend_search_m, 0.01, 10},
      {"min_ray_angle_deg", min_ray_angle_deg, 0, 90},
      {"max_ray_bend_m", max_ray_bend_m, 0, 10},
      {"max_bright_side_fraction", max_bright_side_fraction, 0, 1},
      {"max_redness", max_redness, -1, 1},
      {"localize_search_m", localize_search_m, 0.01, 10},
      {"localize_sigma_m", localize_sigma_m, 0, 2},
      {"extend_gap_m", extend_gap_m, 0, 100},
  };
  for (const auto& c : checks) {
    if (auto s = bad(c.name, c.v, c.lo, c.hi); !s.ok()) return s;
  }
  if (!std::isfinite(extend_min_row) || !std::isfinite(extend_max_row)) {
    return absl::InvalidArgumentError("postprocess.extend_*_row must be finite");
  }
  return absl::OkStatus();
}

std::optional<Bezier> LocalizeSpline(const Bezier& spline, const ChannelView& image, int n,
                                     double search_px, double sigma_px, double min_cos,
                                     double* mean_contrast) {
  std::vector<Eigen::Vector2d> pts;
  double contrast_sum = 0;
  for (int i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / (n - 1);
    const Eigen::Vector2d p = spline.Eval(t);
    Eigen::Vector2d tangent = spline.Derivative(t);
    if (tangent.norm() < 1e-9 || !InBounds(p, image)) continue;
    tangent.normalize();
    const Eigen::Vector2d normal = Normal(tangent);
    thread_local std::vector<float> profile;
    SampleProfile(image, p, normal, search_px, profile);
    const auto peak = FindProfilePeak(profile, sigma_px);
    if (!peak) continue;
    const Eigen::Vector2d q = p + peak->offset * normal;
    if (!pts.empty()) {
      // Reject a point that makes the localised curve turn away from the
      // spline's own direction.
      const Eigen::Vector2d step = q - pts.back();
      if (step.norm() < 1e-9 || step.normalized().dot(tangent) < min_cos) continue;
    }
    pts.push_back(q);
    contrast_sum += peak->contrast;
  }
  if (pts.size() < 4) return std::nullopt;
  if (mean_contrast) *mean_contrast = contrast_sum / pts.size();
  return FitBezier(pts);
}

double BarContrast(const Bezier& spline, const ChannelView& image, double side_offset_px,
                   double bar_fraction, int samples) {
  std::vector<double> values;
  values.reserve(samples);
  for (int i = 0; i < samples; ++i) {
    const double t = (i + 0.5) / samples;
    const Eigen::Vector2d p = spline.Eval(t);
    Eigen::Vector2d tangent = spline.Derivative(t);
    if (tangent.norm() < 1e-9 || !InBounds(p, image)) continue;
    const Eigen::Vector2d normal = Normal(tangent.normalized());
    double centre = -1e30;
    for (double o : {-1.0, 0.0, 1.0}) {
      const Eigen::Vector2d q = p + o * normal;
      centre = std::max(centre, static_cast<double>(Bilinear(image, q.x(), q.y())));
    }
    const Eigen::Vector2d l = p - side_offset_px * normal;
    const Eigen::Vector2d r = p + side_offset_px * normal;
    if (!InBounds(l, image) || !InBounds(r, image)) continue;
    values.push_back(
        std::min(centre - Bilinear(image, l.x(), l.y()), centre - Bilinear(image, r.x(), r.y())));
  }
  if (values.empty()) return 0.0;
  // A high quantile: a dashed marking is a bar along a fifth to a quarter of
  // its length or more, while a step (curb, asphalt edge) is never one.
  const size_t k =
      std::min(values.size() - 1, static_cast<size_t>(values.size() * (1.0 - bar_fraction)));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

Bezier ExtendSpline(const Bezier& spline, const ChannelView& image, const ExtendOptions& options) {
  auto walk = [&](const Eigen::Vector2d& start, Eigen::Vector2d dir, double min_cos) {
    std::vector<Eigen::Vector2d> added;
    if (dir.norm() < 1e-9) return added;
    dir.normalize();
    const Eigen::Vector2d main_dir = dir;
    Eigen::Vector2d cur = start;
    for (int step = 0; step < options.max_steps; ++step) {
      const Eigen::Vector2d guess = cur + options.step_px * dir;
      if (!InBounds(guess, image) || guess.y() < options.min_row || guess.y() > options.max_row) {
        break;
      }
      const Eigen::Vector2d normal = Normal(dir);
      thread_local std::vector<float> profile;
      SampleProfile(image, guess, normal, options.search_px, profile);
      const auto peak = FindProfilePeak(profile, options.sigma_px);
      if (!peak || peak->contrast < options.min_contrast) break;
      const Eigen::Vector2d q = guess + peak->offset * normal;
      const Eigen::Vector2d d = (q - cur).normalized();
      if (d.dot(main_dir) < min_cos) break;
      if (!InBounds(q, image) || q.y() < options.min_row || q.y() > options.max_row) break;
      added.push_back(q);
      cur = q;
      dir = d;
    }
    return added;
  };
  const auto before = walk(spline.p[0], -spline.Derivative(0), options.min_cos_start);
  const auto after = walk(spline.p[3], spline.Derivative(1), options.min_cos_end);
  if (before.empty() && after.empty()) return spline;
  std::vector<Eigen::Vector2d> pts(before.rbegin(), before.rend());
  for (const auto& p : spline.Sample(20)) pts.push_back(p);
  pts.insert(pts.end(), after.begin(), after.end());
  if (auto fit = FitBezier(pts)) return *fit;
  return spline;
}

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
                                pp.localize_min_cos, &contrast)) {
    c.ipm = TopDown(*loc);
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
  double contrast = 0;
  const bool localize = pp.localize_in_image && (!pp.localize_only_coarse_top_view ||
                                                 f.ipm.metres_per_px_x() > marking_width_m);
  if (localize && pp.localize_geometric) {
    LocalizeOptions lo;
    lo.points = pp.localize_points;
    lo.search_m = pp.localize_search_m;
    lo.sigma_m = pp.localize_sigma_m;
    lo.min_sigma_px = pp.profile_sigma_px * scale;
    lo.max_search_px = 2 * pp.localize_search_px * scale;
    lo.min_cos = pp.localize_min_cos;
    lo.marking_width_m = marking_width_m;
    lo.on_bars = pp.localize_on_bars;
    if (auto loc = LocalizeInImage(c.image, f.channel, cam, lo)) {
      c.image = TopDown(*loc);
    }
    if (!PassesShapeChecks(c.image, min_len, pp.min_straightness)) c.image = fallback;
  } else if (localize) {
    if (auto loc =
            LocalizeSpline(c.image, f.channel, pp.localize_points, pp.localize_search_px * scale,
                           pp.profile_sigma_px * scale, pp.localize_min_cos, &contrast)) {
      c.image = TopDown(*loc);
    }
    if (!PassesShapeChecks(c.image, min_len, pp.min_straightness)) c.image = fallback;
  }
  if (pp.extend_in_image && pp.extend_geometric) {
    const ImageExtendOptions eo =
        ImageExtendOptionsFrom(pp, scale, rows.min_row, rows.max_row, marking_width_m);
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
    for (const auto& [from, options] :
         {std::pair<const Bezier&, const ImageExtendOptions&>{spline, eo},
          {fallback, eo},
          {fallback, straight}}) {
      const Bezier extended = TopDown(ExtendInImage(from, f.channel, cam, options));
      if (PassesShapeChecks(extended, min_len, pp.min_straightness)) {
        c.image = extended;
        break;
      }
    }
  } else if (pp.extend_in_image && contrast > 0) {
    ExtendOptions eo;
    eo.step_px = pp.extend_step_px * scale;
    eo.search_px = pp.extend_search_px * scale;
    eo.sigma_px = pp.profile_sigma_px * scale;
    eo.min_contrast = pp.continuation_threshold * contrast;
    eo.min_cos_start = pp.extend_min_cos_up;
    eo.min_cos_end = pp.extend_min_cos_down;
    eo.min_row = rows.min_row;
    eo.max_row = rows.max_row;
    c.image = TopDown(ExtendSpline(c.image, f.channel, eo));
    if (!PassesShapeChecks(c.image, min_len, pp.min_straightness)) c.image = fallback;
  }
  const std::optional<Bezier> finished =
      FinishImageSpline(c.image, f.channel, f.frame, cam, pp, scale);
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
