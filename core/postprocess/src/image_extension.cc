#include "lane/postprocess/image_extension.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "lane/postprocess/profile.h"

namespace lane {
namespace {

bool InImage(const Eigen::Vector2d& p, const ChannelView& image) {
  return image.Inside(p.x(), p.y());
}

// Image pixels per metre across the road (ground x) at image point `p`.
double PixelsPerMetreAcross(const CameraModel& camera, const Eigen::Vector2d& p) {
  const Eigen::Vector2d g = camera.ImageToGround(p);
  if (!g.allFinite() || g.y() <= 0) return 0;
  const Eigen::Vector2d q = camera.GroundToImage(g + Eigen::Vector2d(1, 0));
  return q.allFinite() ? (q - p).norm() : 0;
}

struct Bar {
  double offset = 0;    // from the profile's centre (samples; FindBar: pixels)
  double contrast = 0;  // peak minus the brighter side
};

// The strongest bar of the smoothed profile `s` within +-half samples of its
// centre: the local maximum that most exceeds the brighter of its two sides
// `side` samples out, refined by a parabola. A marking is a bar, brighter
// than the road on both sides; the bright side of a step (a shadow's border,
// a curb, the hood's reflection) is not, however bright.
std::optional<Bar> StrongestBar(const std::vector<double>& s, int half, int side) {
  const int n = static_cast<int>(s.size()), c = (n - 1) / 2;
  std::optional<Bar> best;
  for (int i = std::max(c - half, side + 1); i <= std::min(c + half, n - side - 2); ++i) {
    if (!(s[i] >= s[i - 1] && s[i] >= s[i + 1])) continue;
    const double contrast = s[i] - std::max(s[i - side], s[i + side]);
    if (contrast <= 0 || (best && contrast <= best->contrast)) continue;
    double off = i;
    const double denom = s[i - 1] - 2 * s[i] + s[i + 1];
    if (denom < 0) off += std::clamp(0.5 * (s[i - 1] - s[i + 1]) / denom, -0.5, 0.5);
    best = Bar{off - c, contrast};
  }
  return best;
}

// Profile samples per smoothing sigma (LocalizeInImage, FindBar): near the
// camera a 10 cm sigma on the road spans 5-15 px, and a 1 px raster only
// multiplied the samples and the taps.
constexpr double kSamplesPerSigma = 4.0;

// How a profile smoothed with `sigma_px` is sampled: every `spacing` pixels,
// kSamplesPerSigma samples per sigma (one pixel while sigma <= 4 px), and
// the smoothing's sigma in samples.
struct ProfileRaster {
  double spacing = 1;
  double sigma_samples = 0;
};
ProfileRaster RasterFor(double sigma_px) {
  const double spacing = std::max(1.0, sigma_px / kSamplesPerSigma);
  return {spacing, spacing > 1.0 ? kSamplesPerSigma : sigma_px};
}

// The strongest bar of the smoothed profile across `p` (normal `n`, a unit
// vector), smoothed with `sigma_m` on the road when that is positive and its
// profile stays in the image, else with the options' sigma (at most half a
// marking). The profile is sampled every max(1, sigma / kSamplesPerSigma)
// px; the bar's offset is in pixels.
std::optional<Bar> FindBar(const ChannelView& image, const CameraModel& camera,
                           const Eigen::Vector2d& p, const Eigen::Vector2d& n,
                           const ImageExtendOptions& o, double sigma_m = 0) {
  const double ppm = PixelsPerMetreAcross(camera, p);
  if (!(ppm > 0)) return std::nullopt;
  const double width_px = o.marking_width_m * ppm;
  const double half = std::clamp(o.search_m * ppm, o.min_search_px, o.max_search_px);
  thread_local std::vector<float> raw;
  thread_local std::vector<double> smooth;
  double side = 0;
  ProfileRaster raster;
  bool inside = false;
  for (const double s : {sigma_m > 0 ? std::max(0.7, sigma_m * ppm) : 0.0,
                         std::max(0.7, std::min(o.sigma_px, 0.5 * width_px))}) {
    if (s <= 0 || inside) continue;
    const double sigma = QuantizedSigma(s);
    side = std::max(width_px, 2.5 * sigma);
    raster = RasterFor(sigma);
    const int h = static_cast<int>(std::lround((half + side + 3 * sigma) / raster.spacing));
    raw.resize(2 * h + 1);
    inside = image.SampleAlong(p, raster.spacing * n, h, raw.data());
  }
  if (!inside) return std::nullopt;  // it leaves the image
  SmoothProfile(raw, raster.sigma_samples, smooth);
  const double spacing = raster.spacing;
  std::optional<Bar> bar = StrongestBar(smooth, static_cast<int>(std::lround(half / spacing)),
                                        std::max(1, static_cast<int>(std::lround(side / spacing))));
  if (bar) bar->offset *= spacing;
  return bar;
}

}  // namespace

std::optional<Bezier> LocalizeInImage(const Bezier& spline, const ChannelView& image,
                                      const CameraModel& camera, const LocalizeOptions& o) {
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < o.points; ++i) {
    const double t = static_cast<double>(i) / (o.points - 1);
    const Eigen::Vector2d p = spline.Eval(t);
    Eigen::Vector2d tangent = spline.Derivative(t);
    if (tangent.norm() < 1e-9 || !InImage(p, image)) continue;
    tangent.normalize();
    const double ppm = PixelsPerMetreAcross(camera, p);
    if (!(ppm > 0)) continue;
    const Eigen::Vector2d normal = Normal(tangent);
    const double sigma = QuantizedSigma(std::max(o.min_sigma_px, o.sigma_m * ppm));
    const double half = std::clamp(o.search_m * ppm, 2.0, o.max_search_px);
    const auto [spacing, sigma_samples] = RasterFor(sigma);
    thread_local std::vector<float> profile;
    double offset = 0;
    if (o.on_bars) {
      // The bar's sides lie a marking width out, and no nearer than the
      // smoothing's reach (2.5 sigma).
      const double side = std::max(o.marking_width_m * ppm, 2.5 * sigma) / spacing;
      const int half_samples = static_cast<int>(std::lround(half / spacing));
      const int side_samples = std::max(1, static_cast<int>(std::lround(side)));
      SampleProfile(image, p, spacing * normal, half_samples + side_samples + 1, profile);
      thread_local std::vector<double> smooth;
      SmoothProfile(profile, sigma_samples, smooth);
      const auto bar = StrongestBar(smooth, half_samples, side_samples);
      if (!bar) continue;
      offset = spacing * bar->offset;
    } else {
      SampleProfile(image, p, spacing * normal, half / spacing, profile);
      const auto peak = FindProfilePeak(profile, sigma_samples);
      if (!peak) continue;
      offset = spacing * peak->offset;
    }
    const Eigen::Vector2d q = p + offset * normal;
    if (!pts.empty()) {
      const Eigen::Vector2d step = q - pts.back();
      if (step.norm() < 1e-9 || step.normalized().dot(tangent) < o.min_cos) continue;
    }
    pts.push_back(q);
  }
  if (pts.size() < 4) return std::nullopt;
  return FitBezier(pts);
}

namespace {

// Whether the ground step from image point a to b runs within max_deg of the
// road's direction (the ground y axis).
bool AlongTheRoad(const CameraModel& camera, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                  double max_deg) {
  if (max_deg <= 0) return true;
  const Eigen::Vector2d ga = camera.ImageToGround(a), gb = camera.ImageToGround(b);
  if (!ga.allFinite() || !gb.allFinite() || ga.y() <= 0 || gb.y() <= 0) return false;
  return AngleFromVerticalDeg(gb - ga) <= max_deg;
}

}  // namespace

double GroundAngleFromRoadDeg(const Bezier& spline, const CameraModel& camera) {
  const Eigen::Vector2d a = camera.ImageToGround(spline.p[0]);
  const Eigen::Vector2d b = camera.ImageToGround(spline.p[3]);
  if (!a.allFinite() || !b.allFinite() || a.y() <= 0 || b.y() <= 0) return 90.0;
  return AngleFromVerticalDeg(b - a);
}

ExtensionRows ImageExtensionRows(const CameraModel& camera, const Roi& roi,
                                 const PostprocessOptions& pp) {
  const double horizon = camera.HorizonRow();
  ExtensionRows rows;
  rows.min_row =
      pp.extend_min_row >= 0 ? pp.extend_min_row : horizon + 0.15 * (roi.bottom - horizon);
  rows.max_row =
      pp.extend_max_row >= 0 ? pp.extend_max_row : roi.bottom + 0.2 * (roi.bottom - horizon);
  return rows;
}

ImageExtendOptions ImageExtendOptionsFrom(const PostprocessOptions& pp, double scale,
                                          double min_row, double max_row, double marking_width_m) {
  ImageExtendOptions o;
  o.step_px = pp.extend_step_px * scale;
  o.search_m = pp.extend_search_m;
  o.min_search_px = 4 * scale;
  o.max_search_px = 2 * pp.extend_search_px * scale;
  o.marking_width_m = marking_width_m;
  o.sigma_px = pp.profile_sigma_px * scale;
  o.continuation_threshold = pp.continuation_threshold;
  o.max_gap_m = pp.extend_gap_m;
  o.min_cos_up = pp.extend_min_cos_up;
  o.min_cos_down = pp.extend_min_cos_down;
  o.max_ground_angle_deg = pp.ipm_max_angle_from_vertical_deg;
  o.min_row = min_row;
  o.max_row = max_row;
  o.extrapolate_down = pp.extend_to_max_row;
  // A double line's lines merge as in localisation (localize_sigma_m).
  o.down_sigma_m = pp.localize_sigma_m;
  return o;
}

double ImageBarContrast(const Bezier& spline, const ChannelView& image, const CameraModel& camera,
                        const ImageExtendOptions& options, int samples) {
  double sum = 0;
  int n = 0;
  ImageExtendOptions o = options;
  o.search_m = 0.5 * options.marking_width_m;  // at the spline, not beside it
  o.min_search_px = 2;
  for (int i = 0; i < samples; ++i) {
    const double t = (i + 0.5) / samples;
    const Eigen::Vector2d p = spline.Eval(t);
    Eigen::Vector2d d = spline.Derivative(t);
    if (d.norm() < 1e-9 || !InImage(p, image)) continue;
    const auto bar = FindBar(image, camera, p, Normal(d.normalized()), o);
    sum += bar ? bar->contrast : 0.0;
    ++n;
  }
  return n > 0 ? sum / n : 0.0;
}

std::optional<Bezier> ClipToImageContent(const Bezier& spline, const ChannelView& image,
                                         double convention_row) {
  constexpr int kSamples = 40;
  // "Black": no pixel of the 5x5 neighbourhood above this (of 255).
  constexpr float kBlack = 12.f;
  const float black = image.image.depth() == CV_32F ? kBlack / 255.f : kBlack;
  const auto on_content = [&](const Eigen::Vector2d& p) {
    if (!InImage(p, image)) return false;
    if (p.y() >= convention_row) return true;
    const int x = static_cast<int>(std::lround(p.x())), y = static_cast<int>(std::lround(p.y()));
    for (int dy = -2; dy <= 2; ++dy) {
      for (int dx = -2; dx <= 2; ++dx) {
        const int xx = std::clamp(x + dx, 0, image.cols() - 1);
        const int yy = std::clamp(y + dy, image.top(), image.bottom() - 1);
        if (image.At(xx, yy) > black) return true;
      }
    }
    return false;
  };
  const std::vector<Eigen::Vector2d> pts = spline.Sample(kSamples);
  int best_start = 0, best_len = 0;
  for (int i = 0; i < kSamples;) {
    if (!on_content(pts[i])) {
      ++i;
      continue;
    }
    int j = i;
    while (j < kSamples && on_content(pts[j])) ++j;
    if (j - i > best_len) {
      best_len = j - i;
      best_start = i;
    }
    i = j;
  }
  if (best_len == kSamples) return spline;
  if (best_len < 4) return std::nullopt;
  return FitBezier(
      std::vector<Eigen::Vector2d>(pts.begin() + best_start, pts.begin() + best_start + best_len));
}

namespace {

// The road continues straight under the last evidence: a straight line
// fitted on the ground to the evidence's nearest `kStraightFitM` metres (a
// dash and its gap: not one image step, whose direction a pixel of noise
// turns), followed down to image row `max_row`, sampled every `step_px`
// rows. Empty when the evidence does not reach the ground or runs across.
constexpr double kStraightFitM = 6.0;

std::vector<Eigen::Vector2d> ExtrapolateDownOnGround(const std::vector<Eigen::Vector2d>& evidence,
                                                     const CameraModel& camera, double max_row,
                                                     double step_px, int cols) {
  std::vector<Eigen::Vector2d> ground;
  Eigen::Vector2d end(0, -1);
  for (const Eigen::Vector2d& p : evidence) {
    const Eigen::Vector2d g = camera.ImageToGround(p);
    if (!g.allFinite() || g.y() <= 0) continue;
    ground.push_back(g);
    if (end.y() < 0 || p.y() > end.y()) end = p;
  }
  std::vector<Eigen::Vector2d> out;
  if (ground.size() < 2 || end.y() >= max_row) return out;
  double y_near = ground.front().y();
  for (const auto& g : ground) y_near = std::min(y_near, g.y());
  // x = a + b y over the nearest kStraightFitM metres.
  double n = 0, sy = 0, sx = 0, syy = 0, sxy = 0;
  for (const auto& g : ground) {
    if (g.y() > y_near + kStraightFitM) continue;
    n += 1;
    sy += g.y();
    sx += g.x();
    syy += g.y() * g.y();
    sxy += g.x() * g.y();
  }
  const double det = n * syy - sy * sy;
  if (n < 2 || det < 1e-9) return out;
  const double b = (n * sxy - sy * sx) / det, a = (sx - b * sy) / n;
  // A line on the ground is a line in the image: through the images of two
  // of its points, the nearest evidence's and one a metre further.
  const Eigen::Vector2d start = camera.GroundToImage(Eigen::Vector2d(a + b * y_near, y_near));
  const Eigen::Vector2d further =
      camera.GroundToImage(Eigen::Vector2d(a + b * (y_near + 1.0), y_near + 1.0));
  if (!start.allFinite() || !further.allFinite() || !(start.y() - further.y() > 1e-9)) return out;
  const double du_dv = (start.x() - further.x()) / (start.y() - further.y());
  for (double row = start.y() + step_px; row < max_row + step_px; row += step_px) {
    const double r = std::min(row, max_row);
    const Eigen::Vector2d q(start.x() + (r - start.y()) * du_dv, r);
    if (q.x() < 0 || q.x() > cols - 1) break;
    out.push_back(q);
    if (r >= max_row) break;
  }
  return out;
}

}  // namespace

Bezier ExtendInImage(const Bezier& spline, const ChannelView& image, const CameraModel& camera,
                     const ImageExtendOptions& options) {
  return ExtendInImage(spline, ImageBarContrast(spline, image, camera, options), image, camera,
                       options);
}

Bezier ExtendInImage(const Bezier& spline, double reference, const ChannelView& image,
                     const CameraModel& camera, const ImageExtendOptions& options) {
  const double min_contrast = options.continuation_threshold * reference;
  const double max_row = std::min(options.max_row, image.bottom() - 1.0);

  // Walks from `start` along `dir`; returns the supported points, in order.
  const auto walk = [&](const Eigen::Vector2d& start, Eigen::Vector2d dir, double min_cos) {
    std::vector<Eigen::Vector2d> added;
    if (dir.norm() < 1e-9) return added;
    dir.normalize();
    const Eigen::Vector2d main_dir = dir;
    Eigen::Vector2d cur = start;     // where the next step starts from
    Eigen::Vector2d anchor = start;  // the last supported point
    double gap_m = 0;
    for (int step = 0; step < options.max_steps; ++step) {
      const Eigen::Vector2d guess = cur + options.step_px * dir;
      if (!InImage(guess, image) || guess.y() < options.min_row || guess.y() > max_row) break;
      const Eigen::Vector2d g0 = camera.ImageToGround(cur), g1 = camera.ImageToGround(guess);
      const double step_m = (g0.allFinite() && g1.allFinite()) ? (g1 - g0).norm() : 1e9;
      const auto bar = FindBar(image, camera, guess, Normal(dir), options,
                               dir.y() > 0 ? options.down_sigma_m : 0.0);
      bool supported = bar && bar->contrast >= min_contrast;
      Eigen::Vector2d q = guess;
      if (supported) {
        q = guess + bar->offset * Normal(dir);
        const Eigen::Vector2d d = q - anchor;
        supported = d.norm() > 1e-9 && d.normalized().dot(main_dir) >= min_cos &&
                    InImage(q, image) &&
                    AlongTheRoad(camera, anchor, q, options.max_ground_angle_deg);
      }
      if (supported) {
        dir = (dir + (q - cur).normalized()).normalized();
        added.push_back(q);
        anchor = q;
        cur = q;
        gap_m = 0;
      } else {
        gap_m += step_m;
        if (gap_m > options.max_gap_m) break;
        cur = guess;  // through the gap, straight on
      }
    }
    return added;
  };
  // Without a bar under the spline there is nothing to follow; the
  // labelling convention's extrapolation below still applies.
  const bool follow = reference > 0;
  const auto up = follow ? walk(spline.p[0], -spline.Derivative(0), options.min_cos_up)
                         : std::vector<Eigen::Vector2d>{};
  auto down = follow ? walk(spline.p[3], spline.Derivative(1), options.min_cos_down)
                     : std::vector<Eigen::Vector2d>{};
  if (options.extrapolate_down) {
    std::vector<Eigen::Vector2d> evidence = spline.Sample(20);
    evidence.insert(evidence.end(), down.begin(), down.end());
    const std::vector<Eigen::Vector2d> below =
        ExtrapolateDownOnGround(evidence, camera, max_row, options.step_px, image.cols());
    down.insert(down.end(), below.begin(), below.end());
  }
  if (up.empty() && down.empty()) return spline;
  std::vector<Eigen::Vector2d> pts(up.rbegin(), up.rend());
  for (const auto& p : spline.Sample(20)) pts.push_back(p);
  pts.insert(pts.end(), down.begin(), down.end());
  if (auto fit = FitBezier(pts)) return *fit;
  return spline;
}

}  // namespace lane
