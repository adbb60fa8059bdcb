// Raised pavement markers (Botts' dots) and the concrete road they were
// measured on (issue 49 item 5: 512x288 US highway frames): the scene's
// part and the dots' and seams' coverage of a pixel.
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "scene.h"

namespace lane::synthetic_internal {

namespace {

// Measured: round dots 0.09 m across, grey 240-252, 4 to a group about
// 0.95 m apart, a group every 12-13 m.
constexpr double kDotDiameterM = 0.09;
constexpr int kDotsPerGroup = 4;
// Their height (a ceramic dome, about 18 mm): seen from the camera a dot
// stands above the road, so it covers the ground behind it up to where its
// top's line of sight meets the road, `height / camera height` of its
// distance further (0.09 m at 8 m, 0.2 m at 20 m: the measured 3 px and 2
// px of height in the image, where a flat disc would show 1.7 and 0.3).
constexpr double kDotHeightM = 0.018;
// A slab seam's width (a sawn, sealed joint), metres.
constexpr double kSeamWidthM = 0.02;

// The share of [pos - 0.5 extent, pos + 0.5 extent] inside a stripe of
// `width` centred on 0.
double StripeCover(double pos, double width, double extent) {
  const double lo = std::max(pos - 0.5 * extent, -0.5 * width);
  const double hi = std::min(pos + 0.5 * extent, 0.5 * width);
  return std::max(0.0, hi - lo) / extent;
}

// The distance from `v` to the nearest multiple of `period`, signed.
double FromNearest(double v, double period) { return v - period * std::round(v / period); }

}  // namespace

void AddBottsDots(const SyntheticOptions& o, double camera_height_m, Rng& rng, Road* road,
                  Look* look) {
  if (o.concrete) {
    look->asphalt = Uniform(rng, 140, 160);
    look->asphalt_tint = cv::Vec3f(static_cast<float>(Uniform(rng, 0.98, 1.02)), 1.0f,
                                   static_cast<float>(Uniform(rng, 0.97, 1.01)));
    look->patch_amp = Uniform(rng, 3, 8);
    look->mid_amp = Uniform(rng, 2, 4);
    look->grain_amp = Uniform(rng, 4, 8);
    look->track_dark = Uniform(rng, 8, 18);  // tyre polish
    look->seam_every = Uniform(rng, 4.5, 6.0);
    look->seam_dark = Uniform(rng, 20, 40);
    look->seam_beside = Uniform(rng, 0.1, 0.3);
  }
  if (!(o.botts_dots_probability > 0)) return;
  // Inner boundaries only: a road's edges stay painted lines.
  for (size_t b = 1; b + 1 < road->boundaries.size(); ++b) {
    if (!Chance(rng, o.botts_dots_probability)) continue;
    Boundary& m = road->boundaries[b];
    m.dots = true;
    m.dashed = false;
    m.yellow = false;
    m.double_gap = 0;
    m.width = kDotDiameterM;
    m.dot_rise = kDotHeightM / camera_height_m;
    m.dot_spacing = Uniform(rng, 0.85, 1.05);
    m.dash = (kDotsPerGroup - 1) * m.dot_spacing;
    m.gap = Uniform(rng, 12.0, 13.0) - m.dash;
    m.phase = Uniform(rng, 0.0, m.dash + m.gap);
    // Measured: the dots' brightest pixels 240-252, their contrast over the
    // concrete +60 to +90: a dome's flanks are shaded, and a pixel holds
    // more of them than of its lit top.
    m.alpha = Uniform(rng, 0.7, 0.9);
    m.wear = 0.0;
    const float grey = static_cast<float>(Uniform(rng, 240, 252));
    m.colour = cv::Vec3f(grey, grey, grey);
  }
}

double DotsCover(const Boundary& m, double across, double fd, double along, double fa) {
  const double r = 0.5 * m.width;
  if (std::abs(across) >= r + 0.5 * fd) return 0.0;
  fa = std::max(fa, 1e-4);
  const double period = m.dash + m.gap;
  const double lo = along - 0.5 * fa, hi = along + 0.5 * fa;
  // A dot centred at c covers [c - r, c + rise + r] along: a disc swept
  // `rise` away from the camera.
  const double rise = along * m.dot_rise;
  // The across overlap of the footprint with a chord of half-length `half`.
  auto chord = [&](double half) {
    return std::max(0.0, std::min(across + 0.5 * fd, half) - std::max(across - 0.5 * fd, -half));
  };
  const double k0 = std::floor((lo - r - rise - m.phase - m.dash) / period);
  const double k1 = std::floor((hi + r - m.phase) / period);
  if (k1 - k0 > 3) {
    // A footprint many groups long (towards the horizon): the dots' mean
    // area per metre, spread across the pixel.
    const double per_metre = kDotsPerGroup * (kPi * r * r + 2.0 * r * rise) / period;
    return std::min(1.0, per_metre * chord(r) / (2.0 * r * fd));
  }
  constexpr int kSteps = 12;
  double area = 0;
  for (double k = k0; k <= k1; ++k) {
    for (int j = 0; j < kDotsPerGroup; ++j) {
      const double c = m.phase + k * period + j * m.dot_spacing;
      const double t0 = std::max(lo, c - r), t1 = std::min(hi, c + rise + r);
      if (t1 <= t0) continue;
      const double dt = (t1 - t0) / kSteps;
      for (int s = 0; s < kSteps; ++s) {
        const double t = t0 + (s + 0.5) * dt - c;
        const double from_disc = t < 0 ? t : std::max(0.0, t - rise);
        area += chord(std::sqrt(std::max(0.0, r * r - from_disc * from_disc))) * dt;
      }
    }
  }
  return std::min(1.0, area / (fd * fa));
}

double SeamDarkening(const Road& road, const Look& look, double lane_pos, double along, double fx,
                     double fy) {
  const double across =
      StripeCover(FromNearest(along, look.seam_every), kSeamWidthM, std::max(fy, 1e-4));
  const double beside = StripeCover(FromNearest(lane_pos - look.seam_beside, road.lane_width),
                                    kSeamWidthM, std::max(fx, 1e-4));
  return look.seam_dark * std::min(1.0, across + beside);
}

}  // namespace lane::synthetic_internal
