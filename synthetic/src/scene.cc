// Scene sampling for the synthetic renderer: random helpers, value noise,
// geometry, and the road, look, shadows and objects of one frame.
#include "scene.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "lane/geometry/bezier.h"

namespace lane::synthetic_internal {

// ---------------------------------------------------------------------------
// Random helpers. Everything random comes from one std::mt19937_64 so a seed
// fully determines the frame.

double Uniform(Rng& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

int UniformInt(Rng& rng, int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); }

bool Chance(Rng& rng, double p) { return Uniform(rng, 0.0, 1.0) < p; }

// ---------------------------------------------------------------------------
// Hash-based value noise in ground coordinates: no tables, so the texture is
// defined everywhere on the (unbounded) road plane.

uint64_t Mix64(uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// Uniform in [-1, 1] for an integer lattice point.
double Lattice(int64_t i, int64_t j, uint64_t salt) {
  const uint64_t h = Mix64(salt + static_cast<uint64_t>(i) * 0x632be59bd9b4e019ULL +
                           static_cast<uint64_t>(j) * 0x85157af5ULL);
  return static_cast<double>(h >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

// Smoothly interpolated lattice noise with cells of 1 / inv_cell, in [-1, 1].
double ValueNoise(double x, double y, double inv_cell, uint64_t salt) {
  x = std::clamp(x * inv_cell, -1e12, 1e12);
  y = std::clamp(y * inv_cell, -1e12, 1e12);
  const double fx = std::floor(x);
  const double fy = std::floor(y);
  double tx = x - fx;
  double ty = y - fy;
  tx = tx * tx * (3.0 - 2.0 * tx);
  ty = ty * ty * (3.0 - 2.0 * ty);
  const auto i = static_cast<int64_t>(fx);
  const auto j = static_cast<int64_t>(fy);
  const double a = Lattice(i, j, salt);
  const double b = Lattice(i + 1, j, salt);
  const double c = Lattice(i, j + 1, salt);
  const double d = Lattice(i + 1, j + 1, salt);
  return (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * ty;
}

// Average of a box of width `w` of a unit step at 0 (0 left, 1 right) centred
// at s: the anti-aliased step.
double SoftStep(double s, double w) { return std::clamp(0.5 + s / w, 0.0, 1.0); }

cv::Vec3f Lerp(const cv::Vec3f& a, const cv::Vec3f& b, double t) {
  const auto f = static_cast<float>(t);
  return a + (b - a) * f;
}

// ---------------------------------------------------------------------------
// Geometry helpers.

// Depth along the optical axis of a point `z` metres above the road; positive
// in front of the camera.
double Depth(const CameraModel& cam, double x, double y, double z) {
  const double p = cam.pitch_deg * kDegToRad;
  const double b = cam.yaw_deg * kDegToRad;
  return std::cos(p) * (std::sin(b) * x + std::cos(b) * y) + std::sin(p) * (cam.height_m - z);
}

// Image of the point (x, y) `z` metres above the road: the road-plane
// projection of a camera `z` metres lower.
Eigen::Vector2d Project(const CameraModel& cam, double x, double y, double z) {
  if (z == 0.0) return cam.GroundToImage({x, y});
  CameraModel c = cam;
  c.height_m = cam.height_m - z;
  return c.GroundToImage({x, y});
}

cv::Point Fp(double u, double v) {
  const double lim = 1e6;
  if (!std::isfinite(u)) u = lim;
  if (!std::isfinite(v)) v = lim;
  return {cvRound(std::clamp(u, -lim, lim) * (1 << kShift)),
          cvRound(std::clamp(v, -lim, lim) * (1 << kShift))};
}

void FillPoly(cv::Mat& img, const std::vector<Eigen::Vector2d>& pts, const cv::Scalar& colour) {
  std::vector<cv::Point> p;
  p.reserve(pts.size());
  for (const auto& q : pts) p.push_back(Fp(q.x(), q.y()));
  cv::fillConvexPoly(img, p, colour, cv::LINE_AA, kShift);
}

void FillRoundedRect(cv::Mat& img, double u0, double v0, double u1, double v1, double r,
                     const cv::Scalar& colour) {
  if (u1 <= u0 || v1 <= v0) return;
  r = std::clamp(r, 0.0, 0.5 * std::min(u1 - u0, v1 - v0));
  std::vector<Eigen::Vector2d> pts;
  const double cu[4] = {u1 - r, u0 + r, u0 + r, u1 - r};
  const double cvv[4] = {v1 - r, v1 - r, v0 + r, v0 + r};
  for (int k = 0; k < 4; ++k) {
    for (int s = 0; s <= 4; ++s) {
      const double a = (k + s / 4.0) * 0.5 * kPi;
      pts.emplace_back(cu[k] + r * std::cos(a), cvv[k] + r * std::sin(a));
    }
  }
  FillPoly(img, pts, colour);
}

void FillRect(cv::Mat& img, double u0, double v0, double u1, double v1, const cv::Scalar& colour) {
  FillPoly(img, {{u0, v0}, {u1, v0}, {u1, v1}, {u0, v1}}, colour);
}

// ---------------------------------------------------------------------------
// Scene sampling.

absl::Status ValidateOptions(const SyntheticOptions& o) {
  auto bad = [](const std::string& what) {
    return absl::InvalidArgumentError(absl::StrCat("synthetic options: ", what));
  };
  if (o.num_lanes < 0 || o.num_lanes > 16) return bad("num_lanes must be in 0..16");
  if (!std::isfinite(o.lane_width_m) || o.lane_width_m < 1.0 || o.lane_width_m > 10.0) {
    return bad("lane_width_m must be in [1, 10] metres");
  }
  if (!std::isfinite(o.min_radius_m) || o.min_radius_m <= 0) {
    return bad("min_radius_m must be > 0");
  }
  for (double p : {o.straight_probability, o.dashed_probability, o.yellow_probability}) {
    if (!(p >= 0.0 && p <= 1.0)) return bad("probabilities must be in [0, 1]");
  }
  if (!std::isfinite(o.min_marking_width_m) || !std::isfinite(o.max_marking_width_m) ||
      o.min_marking_width_m <= 0 || o.max_marking_width_m < o.min_marking_width_m ||
      o.max_marking_width_m > 1.0) {
    return bad("marking widths must satisfy 0 < min <= max <= 1 metre");
  }
  if (o.max_vehicles < 0 || o.max_vehicles > 64) return bad("max_vehicles must be in 0..64");
  if (o.max_shadows < 0 || o.max_shadows > 64) return bad("max_shadows must be in 0..64");
  if (!(o.noise_sigma >= 0.0 && o.noise_sigma <= 255.0)) {
    return bad("noise_sigma must be in [0, 255]");
  }
  if (o.jpeg_quality < 0 || o.jpeg_quality > 100) return bad("jpeg_quality must be in 0..100");
  if (o.extra_roadside_objects < 0 || o.extra_roadside_objects > 256) {
    return bad("extra_roadside_objects must be in 0..256");
  }
  for (double p : {o.tree_row_probability, o.sign_probability, o.guardrail_probability,
                   o.worn_probability, o.double_line_probability, o.botts_dots_probability}) {
    if (!(p >= 0.0 && p <= 1.0)) return bad("clutter probabilities must be in [0, 1]");
  }
  if (!(o.min_dash_m > 0 && o.max_dash_m >= o.min_dash_m && o.max_dash_m <= 100 &&
        o.min_gap_m > 0 && o.max_gap_m >= o.min_gap_m && o.max_gap_m <= 100)) {
    return bad("dashes and gaps must satisfy 0 < min <= max <= 100 metres");
  }
  if (!std::isfinite(o.truth_near_m) || o.truth_near_m < 0) return bad("truth_near_m must be >= 0");
  if (!(o.hood_top_row >= 0 && o.hood_top_row <= 16384) ||
      !(o.hood_side_row >= 0 && o.hood_side_row <= 16384)) {
    return bad("hood rows must be in [0, 16384]");
  }
  if (o.hood_top_row > 0 && o.hood_side_row > 0 && o.hood_side_row < o.hood_top_row) {
    return bad("hood_side_row must not lie above hood_top_row");
  }
  if (!(o.first_dash_m >= 0 && o.first_dash_m <= 1000)) {
    return bad("first_dash_m must be in [0, 1000] metres");
  }
  if (!std::isfinite(o.truth_far_m) || o.truth_far_m <= o.truth_near_m) {
    return bad("truth_far_m must be > truth_near_m");
  }
  return absl::OkStatus();
}

Road SampleRoad(const SyntheticOptions& o, Rng& rng) {
  Road road;
  road.lane_width = o.lane_width_m;
  const int lanes = o.num_lanes > 0 ? o.num_lanes : UniformInt(rng, 1, 5);
  const int ego = UniformInt(rng, 0, lanes - 1);
  // Distance of the car from its lane's left boundary.
  const double pos = Uniform(rng, 0.3, 0.7) * road.lane_width;
  road.heading = Uniform(rng, -o.max_heading_rad, o.max_heading_rad);
  if (!Chance(rng, o.straight_probability)) {
    // Radius between min_radius and ~10x that, denser at the tight end.
    const double r = o.min_radius_m * std::exp(Uniform(rng, 0.0, std::log(10.0)));
    road.curvature = (Chance(rng, 0.5) ? 1.0 : -1.0) / r;
  }
  for (int b = 0; b <= lanes; ++b) {
    Boundary m;
    m.offset = (b - ego) * road.lane_width - pos;
    m.width = Uniform(rng, o.min_marking_width_m, o.max_marking_width_m);
    m.dashed = Chance(rng, o.dashed_probability);
    m.yellow = Chance(rng, o.yellow_probability);
    m.dash = Uniform(rng, o.min_dash_m, o.max_dash_m);
    m.gap = Uniform(rng, o.min_gap_m, o.max_gap_m);
    m.phase = Uniform(rng, 0.0, m.dash + m.gap);
    if (o.first_dash_m > 0) m.phase = m.paint_from = o.first_dash_m;
    m.alpha = Uniform(rng, 0.85, 1.0);
    m.wear = Uniform(rng, 0.0, 0.25);
    if (m.yellow) {
      m.colour = cv::Vec3f(static_cast<float>(Uniform(rng, 30, 70)),
                           static_cast<float>(Uniform(rng, 165, 200)),
                           static_cast<float>(Uniform(rng, 205, 240)));
    } else {
      const double w = Uniform(rng, 215, 250);
      m.colour = cv::Vec3f(static_cast<float>(w), static_cast<float>(w),
                           static_cast<float>(w * Uniform(rng, 0.96, 1.0)));
    }
    m.salt = rng();
    // Drawn only when asked for, so that frames without double lines keep
    // their random stream.
    if (o.double_line_probability > 0 && b > 0 && b < lanes &&
        Chance(rng, o.double_line_probability)) {
      m.double_gap = Uniform(rng, 0.10, 0.20);
      m.dashed = false;
    }
    road.boundaries.push_back(m);
  }
  road.ego_left = ego;
  road.ego_right = ego + 1;
  road.edge_left = road.boundaries.front().offset - Uniform(rng, 0.3, 2.5);
  road.edge_right = road.boundaries.back().offset + Uniform(rng, 0.3, 2.5);
  return road;
}

Look SampleLook(Rng& rng, int image_height) {
  Look k;
  k.asphalt = Uniform(rng, 80, 120);
  k.asphalt_tint = cv::Vec3f(static_cast<float>(Uniform(rng, 0.97, 1.04)), 1.0f,
                             static_cast<float>(Uniform(rng, 0.96, 1.03)));
  k.patch_amp = Uniform(rng, 4, 14);
  k.mid_amp = Uniform(rng, 2, 7);
  k.grain_amp = Uniform(rng, 6, 16);
  k.track_dark = Uniform(rng, 0, 10);
  if (Chance(rng, 0.6)) {  // grass
    k.verge = cv::Vec3f(static_cast<float>(Uniform(rng, 40, 80)),
                        static_cast<float>(Uniform(rng, 95, 140)),
                        static_cast<float>(Uniform(rng, 70, 110)));
  } else {  // gravel / dirt
    const double g = Uniform(rng, 100, 135);
    k.verge = cv::Vec3f(static_cast<float>(g * Uniform(rng, 0.75, 0.9)),
                        static_cast<float>(g * Uniform(rng, 0.9, 0.97)), static_cast<float>(g));
  }
  k.verge_amp = Uniform(rng, 10, 25);
  const double haze = Uniform(rng, 175, 215);
  k.haze = cv::Vec3f(static_cast<float>(haze + Uniform(rng, 0, 15)), static_cast<float>(haze),
                     static_cast<float>(haze - Uniform(rng, 0, 10)));
  k.haze_dist = Uniform(rng, 250, 900);
  if (Chance(rng, 0.6)) {  // clear sky
    k.sky_top = cv::Vec3f(static_cast<float>(Uniform(rng, 200, 245)),
                          static_cast<float>(Uniform(rng, 150, 195)),
                          static_cast<float>(Uniform(rng, 95, 145)));
  } else {  // overcast
    const double g = Uniform(rng, 165, 225);
    k.sky_top =
        cv::Vec3f(static_cast<float>(g + 5), static_cast<float>(g), static_cast<float>(g - 3));
  }
  k.treeline_base = Uniform(rng, 0.0, 0.04) * image_height;
  k.treeline_amp = Uniform(rng, 0.0, 0.10) * image_height;
  k.treeline_scale = Uniform(rng, 0.005, 0.03);
  k.treeline =
      cv::Vec3f(static_cast<float>(Uniform(rng, 45, 90)), static_cast<float>(Uniform(rng, 65, 105)),
                static_cast<float>(Uniform(rng, 50, 90)));
  k.clouds = Chance(rng, 0.6) ? Uniform(rng, 0.3, 0.9) : 0.0;
  k.cloud_scale = Uniform(rng, 2.0, 6.0) / image_height;
  const double cg = Uniform(rng, 200, 250);
  k.cloud = cv::Vec3f(static_cast<float>(cg), static_cast<float>(cg), static_cast<float>(cg - 3));
  k.blur_sigma = Uniform(rng, 0.4, 0.8);
  k.gain = Uniform(rng, 0.88, 1.1);
  k.salt = rng();
  return k;
}

std::vector<Shadow> SampleShadows(const SyntheticOptions& o, const Road& road, double y_min,
                                  Rng& rng) {
  std::vector<Shadow> out;
  const int n = o.max_shadows > 0 ? UniformInt(rng, 0, o.max_shadows) : 0;
  for (int i = 0; i < n; ++i) {
    Shadow s;
    s.band = Chance(rng, 0.6);
    s.factor = Uniform(rng, 0.4, 0.7);
    s.soft = Uniform(rng, 0.05, 0.4);
    s.ragged = Chance(rng, 0.6) ? Uniform(rng, 0.2, 0.7) : 0.0;  // trees vs buildings
    s.salt = rng();
    const double y = Uniform(rng, y_min, std::max(y_min + 1.0, 45.0));
    const double xc = road.X(0.0, y);
    if (s.band) {
      s.slope = Uniform(rng, -0.6, 0.6);
      s.depth = Uniform(rng, 1.0, 10.0);
      s.q0 = y - s.slope * xc;
      if (Chance(rng, 0.5)) {
        s.xa = -1e9;
        s.xb = 1e9;
      } else if (Chance(rng, 0.5)) {  // from the left edge inwards
        s.xa = -1e9;
        s.xb = xc + road.edge_left + Uniform(rng, 1.0, road.edge_right - road.edge_left);
      } else {
        s.xa = xc + road.edge_right - Uniform(rng, 1.0, road.edge_right - road.edge_left);
        s.xb = 1e9;
      }
    } else {
      s.cx = xc + Uniform(rng, road.edge_left, road.edge_right);
      s.cy = y;
      s.rx = Uniform(rng, 0.8, 4.0);
      s.ry = Uniform(rng, 1.5, 8.0);
    }
    out.push_back(s);
  }
  return out;
}

// Brightness multiplier of the shadows at ground point (x, y) for a pixel
// whose footprint is `foot` metres across.
double ShadowFactor(const std::vector<Shadow>& shadows, double x, double y, double foot) {
  double f = 1.0;
  for (const Shadow& s : shadows) {
    double dist;  // signed distance to the outline, positive inside (metres)
    if (s.band) {
      const double q = y - s.slope * x;
      const double n = 1.0 / std::sqrt(1.0 + s.slope * s.slope);
      dist = std::min({(q - s.q0) * n, (s.q0 + s.depth - q) * n, x - s.xa, s.xb - x});
    } else {
      const double dx = (x - s.cx) / s.rx;
      const double dy = (y - s.cy) / s.ry;
      dist = (1.0 - std::sqrt(dx * dx + dy * dy)) * std::min(s.rx, s.ry);
    }
    const double width = s.soft + foot;
    if (dist < -width - s.ragged) continue;
    if (s.ragged > 0)
      dist += s.ragged * ValueNoise(x + s.noise_dx, y + s.noise_dy, 1.0 / 0.7, s.salt);
    const double cover = SoftStep(dist, width);
    f = std::min(f, 1.0 - (1.0 - s.factor) * cover);
  }
  return f;
}

// Painted length of a dashed boundary in [0, s] (cumulative).
double PaintedUpTo(const Boundary& m, double s) {
  const double period = m.dash + m.gap;
  auto dashed = [&](double y) {
    const double t = y - m.phase;
    const double k = std::floor(t / period);
    return k * m.dash + std::min(t - k * period, m.dash);
  };
  s = std::max(s, m.paint_from);
  if (s <= m.solid_from) return dashed(s);
  return dashed(m.solid_from) + (s - m.solid_from);
}

// Ground truth of one boundary: the visible projected centre line, fitted.
bool FitTruth(const CameraModel& cam, const Road& road, double y_near, double y_far,
              const SyntheticOptions& options, Boundary* m) {
  const int w = cam.image_width;
  const int h = cam.image_height;
  const double horizon = cam.HorizonRow();
  const bool stop_at_hood = options.hood_top_row > 0 && !options.labels_through_hood;
  std::vector<Eigen::Vector2d> run, best;
  auto close_run = [&]() {
    if (run.size() > best.size()) best = run;
    run.clear();
  };
  for (int k = 0; k < kTruthSamples; ++k) {
    // Uniform in inverse distance: roughly uniform in image rows.
    const double t = static_cast<double>(k) / (kTruthSamples - 1);
    const double y = 1.0 / (1.0 / y_near + t * (1.0 / y_far - 1.0 / y_near));
    const double x = road.X(m->offset, y);
    if (Depth(cam, x, y, 0.0) <= 1e-3) {
      close_run();
      continue;
    }
    const Eigen::Vector2d p = cam.GroundToImage({x, y});
    const bool inside = p.allFinite() && p.x() >= 0 && p.x() <= w - 1 && p.y() >= 0 &&
                        p.y() <= h - 1 && p.y() > horizon &&
                        !(stop_at_hood && p.y() >= HoodRow(cam, options, p.x()));
    if (inside) {
      run.push_back(p);
    } else {
      close_run();
    }
  }
  close_run();
  if (static_cast<int>(best.size()) < kMinVisibleSamples) return false;
  double vmin = best.front().y();
  double vmax = vmin;
  for (const auto& p : best) {
    vmin = std::min(vmin, p.y());
    vmax = std::max(vmax, p.y());
  }
  if (vmax - vmin < kMinVisibleRows) return false;
  const auto fit = FitBezier(best);
  if (!fit) return false;
  m->truth = *fit;
  return true;
}

std::vector<Object> SampleObjects(const SyntheticOptions& o, const Road& road, double y_min,
                                  Rng& rng) {
  std::vector<Object> out;
  // Vehicles in the lanes ahead.
  const int lanes = static_cast<int>(road.boundaries.size()) - 1;
  const int nv = o.max_vehicles > 0 ? UniformInt(rng, 0, o.max_vehicles) : 0;
  for (int i = 0; i < nv; ++i) {
    const int lane = UniformInt(rng, 0, lanes - 1);
    const bool ego = lane == road.ego_left;
    const double y = Uniform(rng, std::max(y_min + 2.0, ego ? 10.0 : 5.0), 60.0);
    bool clash = false;
    for (const Object& v : out) clash |= std::abs(v.y - y) < 9.0 && std::abs(v.extra - lane) < 0.5;
    if (clash) continue;
    Object v;
    v.kind = Object::kVehicle;
    const double centre = 0.5 * (road.boundaries[lane].offset + road.boundaries[lane + 1].offset);
    v.x = road.X(centre + Uniform(rng, -0.3, 0.3), y);
    v.y = y;
    v.extra = lane;
    v.height = kVehicleHeight * Uniform(rng, 0.9, 1.2);
    v.size = kVehicleWidth * Uniform(rng, 0.95, 1.1);
    if (Chance(rng, 0.7)) {
      const double g = Uniform(rng, 15, 70);
      v.colour = cv::Scalar(g, g, g);
    } else {
      v.colour = cv::Scalar(Uniform(rng, 20, 90), Uniform(rng, 20, 70), Uniform(rng, 20, 90));
    }
    const double win = Uniform(rng, 55, 100);
    v.colour2 = cv::Scalar(win + 10, win + 5, win);
    out.push_back(v);
  }
  // Roadside objects beyond the asphalt, denser near the car.
  const int nr = UniformInt(rng, 3, 16);
  for (int i = 0; i < nr; ++i) {
    out.push_back(SampleRoadsideObject(road, std::max(y_min + 2.0, 10.0), 150.0, 2.0, rng));
  }
  return out;
}

double BesideRoad(const Road& road, bool left, double y, double clearance) {
  const double edge = left ? road.edge_left : road.edge_right;
  return road.X(edge, y) + (left ? -clearance : clearance);
}

cv::Scalar CrownColour(Rng& rng) {
  return cv::Scalar(Uniform(rng, 25, 60), Uniform(rng, 55, 100), Uniform(rng, 30, 60));
}

Object SampleRoadsideObject(const Road& road, double near, double far, double power, Rng& rng) {
  Object r;
  const double pick = Uniform(rng, 0.0, 1.0);
  r.kind = pick < 0.5 ? Object::kTree : (pick < 0.75 ? Object::kBuilding : Object::kPole);
  const bool left = Chance(rng, 0.5);
  r.y = near + (far - near) * std::pow(Uniform(rng, 0.0, 1.0), power);
  const double clearance =
      r.kind == Object::kPole ? Uniform(rng, 0.8, 3.0) : Uniform(rng, 3.0, 14.0);
  r.x = BesideRoad(road, left, r.y, clearance);
  switch (r.kind) {
    case Object::kTree: {
      r.size = Uniform(rng, 1.5, 3.5);
      r.height = Uniform(rng, 4.0, 11.0);
      r.colour = CrownColour(rng);
      r.colour2 = cv::Scalar(Uniform(rng, 30, 50), Uniform(rng, 40, 60), Uniform(rng, 50, 70));
      break;
    }
    case Object::kBuilding: {
      r.size = Uniform(rng, 8.0, 30.0);
      r.height = Uniform(rng, 5.0, 20.0);
      r.extra = (left ? -1.0 : 1.0) * Uniform(rng, 6.0, 15.0);
      const double g = Uniform(rng, 90, 200);
      r.colour = cv::Scalar(g * Uniform(rng, 0.85, 1.05), g, g * Uniform(rng, 0.95, 1.15));
      r.colour2 = r.colour * Uniform(rng, 0.65, 0.85);
      break;
    }
    case Object::kPole: {
      r.height = Uniform(rng, 6.0, 10.0);
      r.size = 0.12;
      const double g = Uniform(rng, 80, 160);
      r.colour = cv::Scalar(g, g, g);
      break;
    }
    case Object::kVehicle:
    case Object::kSign:
    case Object::kGuardrail:
      break;
  }
  return r;
}

void AddClutter(const SyntheticOptions& o, double y_min, Rng& rng, Road* road,
                std::vector<Object>* objects) {
  const double near = std::max(y_min + 2.0, 6.0);
  for (int i = 0; i < o.extra_roadside_objects; ++i) {
    objects->push_back(SampleRoadsideObject(*road, near, 150.0, 1.5, rng));
  }
  if (Chance(rng, o.tree_row_probability)) {
    // An avenue: trees at a steady spacing close to the asphalt, their
    // trunks painted white half the time (bright bars like markings).
    const bool left = Chance(rng, 0.5);
    const double spacing = Uniform(rng, 6.0, 12.0), clearance = Uniform(rng, 1.0, 3.0);
    const bool white = Chance(rng, 0.5);
    for (double y = near + Uniform(rng, 0.0, spacing); y < 120.0; y += spacing) {
      Object t;
      t.kind = Object::kTree;
      t.y = y;
      t.x = BesideRoad(*road, left, y, clearance);
      t.size = Uniform(rng, 1.5, 3.0);
      t.height = Uniform(rng, 5.0, 9.0);
      t.colour = CrownColour(rng);
      const double g = white ? Uniform(rng, 190, 235) : Uniform(rng, 35, 60);
      t.colour2 = cv::Scalar(g, g, g);
      objects->push_back(t);
    }
  }
  if (Chance(rng, o.sign_probability)) {
    // A panel facing the road on two posts, light with a white border.
    Object sgn;
    sgn.kind = Object::kSign;
    const bool left = Chance(rng, 0.5);
    sgn.y = Uniform(rng, near + 4.0, 60.0);
    const double edge = left ? road->edge_left : road->edge_right;
    sgn.extra = Uniform(rng, 1.5, 3.5);
    sgn.x = road->X(edge, sgn.y) + (left ? -1.0 - sgn.extra : 1.0);
    sgn.size = Uniform(rng, 1.0, 2.0);    // panel height
    sgn.height = Uniform(rng, 2.5, 4.5);  // top above the ground
    const int palette = UniformInt(rng, 0, 2);
    sgn.colour = palette == 0   ? cv::Scalar(60, 120, 30)     // green
                 : palette == 1 ? cv::Scalar(150, 70, 20)     // blue
                                : cv::Scalar(225, 225, 225);  // white
    sgn.colour2 = cv::Scalar(235, 235, 235);
    objects->push_back(sgn);
  }
  if (Chance(rng, o.guardrail_probability)) {
    // Bright galvanised steel along a road edge, 0.45-0.75 m high.
    Object g;
    g.kind = Object::kGuardrail;
    const bool left = Chance(rng, 0.5);
    g.offset = (left ? road->edge_left : road->edge_right) + (left ? -0.5 : 0.5);
    g.y = std::max(y_min, 0.5);
    g.x = road->X(g.offset, g.y);
    g.extra = Uniform(rng, 40.0, 120.0);
    g.height = 0.75;
    const double grey = Uniform(rng, 150, 210);
    g.colour = cv::Scalar(grey, grey, grey);
    g.colour2 = cv::Scalar(40, 40, 40);
    objects->push_back(g);
  }
  for (Boundary& b : road->boundaries) {
    if (!Chance(rng, o.worn_probability)) continue;
    b.alpha *= Chance(rng, 0.3) ? 0.0 : Uniform(rng, 0.0, 0.3);
  }
}

}  // namespace lane::synthetic_internal

namespace lane {

void SetRoadsideClutter(SyntheticOptions* o) {
  o->max_vehicles = std::max(o->max_vehicles, 3);
  o->extra_roadside_objects = 10;
  o->tree_row_probability = 0.6;
  o->sign_probability = 0.4;
  o->guardrail_probability = 0.4;
  o->worn_probability = 0.25;
}

}  // namespace lane
