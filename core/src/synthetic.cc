#include "lane/synthetic.h"

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
#include "lane/bezier.h"

namespace lane {
namespace {

using Rng = std::mt19937_64;

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;

// Ground truth sampling and the visibility rule shared by truth and pixels.
constexpr int kTruthSamples = 120;
constexpr int kMinVisibleSamples = 8;
constexpr double kMinVisibleRows = 30.0;

// Vehicles (metres).
constexpr double kVehicleWidth = 1.8;
constexpr double kVehicleHeight = 1.5;

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
// Scene description.

struct Boundary {
  double offset = 0;  // lateral position at y = 0, metres
  double width = 0.12;
  bool dashed = false;
  bool yellow = false;
  double dash = 3.0;   // painted length, metres
  double gap = 9.0;    // unpainted length, metres
  double phase = 0.0;  // metres
  double alpha = 1.0;  // paint opacity
  double wear = 0.0;   // 0 = fresh paint
  cv::Vec3f colour;
  uint64_t salt = 0;
  bool visible = false;
  Bezier truth;
};

struct Road {
  double heading = 0;    // radians, shared by all boundaries
  double curvature = 0;  // 1/m
  double lane_width = 3.6;
  std::vector<Boundary> boundaries;
  double edge_left = 0;  // asphalt edges, lateral offsets at y = 0
  double edge_right = 0;
  int ego_left = -1;
  int ego_right = -1;

  double X(double offset, double y) const { return offset + heading * y + 0.5 * curvature * y * y; }
  double Slope(double y) const { return heading + curvature * y; }
};

struct Shadow {
  bool band = true;
  // Band: q = y - slope * x in [q0, q0 + depth], and x in [xa, xb].
  double slope = 0, q0 = 0, depth = 0, xa = 0, xb = 0;
  // Ellipse.
  double cx = 0, cy = 0, rx = 1, ry = 1;
  double factor = 0.55;  // brightness multiplier inside
  double soft = 0.2;     // penumbra, metres
  double ragged = 0.0;   // amplitude of the leafy edge, metres
  uint64_t salt = 0;
};

struct Look {
  double asphalt = 100;  // mean grey
  cv::Vec3f asphalt_tint{1, 1, 1};
  double patch_amp = 10, mid_amp = 5, grain_amp = 10;
  double track_dark = 0;         // tyre tracks
  cv::Vec3f verge{70, 120, 95};  // BGR
  double verge_amp = 18;
  cv::Vec3f haze{200, 200, 200};
  double haze_dist = 500;  // metres
  cv::Vec3f sky_top{220, 170, 120};
  double treeline_base = 0, treeline_amp = 0;  // pixels
  double treeline_scale = 0.02;                // 1/pixels
  cv::Vec3f treeline{60, 80, 60};
  double clouds = 0;  // opacity
  double cloud_scale = 0.01;
  cv::Vec3f cloud{235, 235, 235};
  double blur_sigma = 0.6;
  double gain = 1.0;
  uint64_t salt = 0;
};

// An object standing on the ground drawn over the rendered road.
struct Object {
  enum Kind { kVehicle, kTree, kBuilding, kPole } kind = kVehicle;
  double x = 0, y = 0;  // ground position of its base (nearest point), metres
  double size = 0;      // building length / tree crown radius
  double height = 0;
  double extra = 0;  // building: depth (signed, away from the road); vehicle: lane
  cv::Scalar colour, colour2;
};

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

// Fixed-point (4 fractional bits) drawing coordinates.
constexpr int kShift = 4;
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
  if (!std::isfinite(o.truth_near_m) || o.truth_near_m < 0) return bad("truth_near_m must be >= 0");
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
  road.heading = Uniform(rng, -0.02, 0.02);
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
    m.dash = Uniform(rng, 2.5, 3.5);
    m.gap = Uniform(rng, 6.0, 9.0);
    m.phase = Uniform(rng, 0.0, m.dash + m.gap);
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
    if (s.ragged > 0) dist += s.ragged * ValueNoise(x, y, 1.0 / 0.7, s.salt);
    const double cover = SoftStep(dist, width);
    f = std::min(f, 1.0 - (1.0 - s.factor) * cover);
  }
  return f;
}

// Painted length of a dashed boundary in [0, s] (cumulative).
double PaintedUpTo(const Boundary& m, double s) {
  const double period = m.dash + m.gap;
  const double t = s - m.phase;
  const double k = std::floor(t / period);
  return k * m.dash + std::min(t - k * period, m.dash);
}

// Ground truth of one boundary: the visible projected centre line, fitted.
bool FitTruth(const CameraModel& cam, const Road& road, double y_near, double y_far, Boundary* m) {
  const int w = cam.image_width;
  const int h = cam.image_height;
  const double horizon = cam.HorizonRow();
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
                        p.y() <= h - 1 && p.y() > horizon;
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
  // Roadside objects beyond the asphalt.
  const int nr = UniformInt(rng, 3, 16);
  for (int i = 0; i < nr; ++i) {
    Object r;
    const double pick = Uniform(rng, 0.0, 1.0);
    r.kind = pick < 0.5 ? Object::kTree : (pick < 0.75 ? Object::kBuilding : Object::kPole);
    const bool left = Chance(rng, 0.5);
    // Denser near the car.
    const double near = std::max(y_min + 2.0, 10.0);
    r.y = near + (150.0 - near) * std::pow(Uniform(rng, 0.0, 1.0), 2.0);
    const double clearance =
        r.kind == Object::kPole ? Uniform(rng, 0.8, 3.0) : Uniform(rng, 3.0, 14.0);
    const double edge = left ? road.edge_left : road.edge_right;
    r.x = road.X(edge, r.y) + (left ? -clearance : clearance);
    switch (r.kind) {
      case Object::kTree: {
        r.size = Uniform(rng, 1.5, 3.5);
        r.height = Uniform(rng, 4.0, 11.0);
        r.colour = cv::Scalar(Uniform(rng, 25, 60), Uniform(rng, 55, 100), Uniform(rng, 30, 60));
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
        break;
    }
    out.push_back(r);
  }
  return out;
}

// ---------------------------------------------------------------------------
// Rendering.

void RenderSky(const CameraModel& cam, const Look& look, cv::Mat3f& img) {
  const int w = img.cols;
  const double horizon = cam.HorizonRow();
  const int last = std::min(img.rows - 1, static_cast<int>(std::floor(horizon + 0.5)));
  if (last < 0) return;
  const double span = std::max(1.0, 0.7 * img.rows);
  std::vector<double> top(w);
  for (int u = 0; u < w; ++u) {
    const double n = 0.6 * ValueNoise(u * look.treeline_scale, 0.5, 1.0, look.salt + 11) +
                     0.4 * ValueNoise(u * look.treeline_scale * 4.0, 0.5, 1.0, look.salt + 12);
    top[u] = horizon - look.treeline_base - look.treeline_amp * std::max(0.0, n + 0.3);
  }
  // Clouds: stretched fractal noise, evaluated on a coarse grid (it is smooth)
  // and interpolated.
  cv::Mat1f clouds;
  if (look.clouds > 0) {
    constexpr int kStep = 4;
    cv::Mat1f coarse(last / kStep + 2, w / kStep + 2);
    for (int i = 0; i < coarse.rows; ++i) {
      for (int j = 0; j < coarse.cols; ++j) {
        const double cx = j * kStep * look.cloud_scale, cy = i * kStep * look.cloud_scale * 2.5;
        const double n = 0.55 * ValueNoise(cx, cy, 1.0, look.salt + 14) +
                         0.3 * ValueNoise(cx * 2.3, cy * 2.3, 1.0, look.salt + 15) +
                         0.15 * ValueNoise(cx * 5.1, cy * 5.1, 1.0, look.salt + 16);
        coarse(i, j) = static_cast<float>(look.clouds * std::clamp((n + 0.1) * 2.5, 0.0, 1.0));
      }
    }
    cv::resize(coarse, clouds, cv::Size(coarse.cols * kStep, coarse.rows * kStep), 0, 0,
               cv::INTER_LINEAR);
  }
  for (int v = 0; v <= last; ++v) {
    const double t = std::pow(std::clamp((horizon - v) / span, 0.0, 1.0), 0.7);
    const cv::Vec3f clear = Lerp(look.haze, look.sky_top, t);
    auto* row = img.ptr<cv::Vec3f>(v);
    const float* cloud_row = clouds.empty() ? nullptr : clouds.ptr<float>(v);
    for (int u = 0; u < w; ++u) {
      cv::Vec3f sky = clear;
      if (cloud_row) sky = Lerp(sky, look.cloud, cloud_row[u] * (0.3 + 0.7 * t));
      const double cover = SoftStep(v - top[u], 1.0);
      if (cover <= 0) {
        row[u] = sky;
        continue;
      }
      // Distant trees/hills: hazy, textured.
      const double tex = 12.0 * ValueNoise(u, v, 0.25, look.salt + 13);
      cv::Vec3f c = Lerp(look.treeline, look.haze, 0.35) + cv::Vec3f::all(static_cast<float>(tex));
      row[u] = Lerp(sky, c, cover);
    }
  }
}

void RenderGround(const CameraModel& cam, const Road& road, const Look& look,
                  const std::vector<Shadow>& shadows, cv::Mat3f& img) {
  const int w = img.cols;
  const int h = img.rows;
  const double horizon = cam.HorizonRow();
  const int first = std::max(0, static_cast<int>(std::floor(horizon + 0.5)) + 1);
  const double du = w > 1 ? w - 1 : 1;
  // Ground point of pixel (u, v) is a(v) + b(v) * u (the homography's
  // denominator depends on v only).
  auto row_affine = [&](double v, Eigen::Vector2d* a, Eigen::Vector2d* b) {
    *a = cam.ImageToGround({0.0, v});
    *b = (cam.ImageToGround({du, v}) - *a) / du;
  };
  std::vector<const Boundary*> visible;
  for (const Boundary& m : road.boundaries) {
    if (m.visible) visible.push_back(&m);
  }
  const Boundary& b0 = road.boundaries.front();
  const uint64_t salt = look.salt;
  for (int v = first; v < h; ++v) {
    Eigen::Vector2d a, b, am, bm, ap, bp;
    row_affine(v, &a, &b);
    row_affine(v - 0.5, &am, &bm);
    row_affine(v + 0.5, &ap, &bp);
    auto* row = img.ptr<cv::Vec3f>(v);
    // Atmospheric haze exp(-y / haze_dist); y is affine in u along the row.
    double clear = std::exp(-a.y() / look.haze_dist);
    const double clear_step = std::exp(-b.y() / look.haze_dist);
    // Rows at the horizon span huge distances: evaluate those directly.
    const bool recur = clear > 1e-200 && clear_step < 1e10 && clear_step > 1e-10;
    for (int u = 0; u < w; ++u, clear *= clear_step) {
      const double x = a.x() + b.x() * u;
      const double y = a.y() + b.y() * u;
      if (!(y > 0) || !std::isfinite(x)) continue;
      // Pixel footprint on the ground: Jacobian columns.
      const double jux = b.x(), juy = b.y();
      const double jvx = (ap.x() - am.x()) + (bp.x() - bm.x()) * u;
      const double jvy = (ap.y() - am.y()) + (bp.y() - bm.y()) * u;
      const double area = std::abs(jux * jvy - juy * jvx);
      const double foot = std::sqrt(area);
      const double ext_x = std::abs(jux) + std::abs(jvx);

      // Asphalt: low-frequency patches, mid-scale mottling and fine grain,
      // each attenuated once the pixel averages over many cells.
      double grey = look.asphalt + look.patch_amp * ValueNoise(x, y, 1.0 / 7.0, salt + 1);
      const double mid = look.mid_amp * std::min(1.0, 1.2 / foot);
      if (mid > 0.2) grey += mid * ValueNoise(x, y, 1.0 / 1.2, salt + 2);
      const double grain = look.grain_amp * std::min(1.0, 0.07 / foot);
      if (grain > 0.2) grey += grain * ValueNoise(x, y, 1.0 / 0.07, salt + 3);
      const double fine = look.grain_amp * std::min(1.0, 0.02 / foot);
      if (fine > 0.2) grey += fine * ValueNoise(x, y, 1.0 / 0.02, salt + 6);
      // Darker tyre tracks in every lane.
      const double slope = road.Slope(y);
      const double inv_norm = 1.0 / std::sqrt(1.0 + slope * slope);
      const double lane_pos = (x - road.X(b0.offset, y)) * inv_norm;
      const double in_lane = lane_pos - road.lane_width * std::floor(lane_pos / road.lane_width);
      const double track = std::min(std::abs(in_lane - 0.5 * road.lane_width + 0.85),
                                    std::abs(in_lane - 0.5 * road.lane_width - 0.85));
      const double bump = std::max(0.0, 1.0 - track * track / 0.3);
      grey -= look.track_dark * bump * bump;
      cv::Vec3f colour = look.asphalt_tint * static_cast<float>(grey);

      // Verge beyond the asphalt edges.
      const double fd0 = std::max(1e-4, ext_x * inv_norm + 1e-3);
      const double el = (x - road.X(road.edge_left, y)) * inv_norm;
      const double er = (road.X(road.edge_right, y) - x) * inv_norm;
      const double on_road = SoftStep(el, fd0) * SoftStep(er, fd0);
      if (on_road < 1.0) {
        const double vt = look.verge_amp *
                          (0.6 * ValueNoise(x, y, 1.0 / 0.8, salt + 4) +
                           0.4 * std::min(1.0, 0.1 / foot) * ValueNoise(x, y, 1.0 / 0.1, salt + 5));
        const cv::Vec3f verge = look.verge + cv::Vec3f::all(static_cast<float>(vt));
        colour = Lerp(verge, colour, on_road);
      }

      // Markings: box-filtered coverage across (lateral) and along (dashes).
      for (const Boundary* m : visible) {
        const double d = (x - road.X(m->offset, y)) * inv_norm;
        const double nx = inv_norm, ny = -slope * inv_norm;  // unit normal
        const double fd =
            std::max(1e-4, std::abs(nx * jux + ny * juy) + std::abs(nx * jvx + ny * jvy));
        const double half = 0.5 * m->width;
        if (std::abs(d) >= half + 0.5 * fd) continue;
        const double lo = std::max(d - 0.5 * fd, -half);
        const double hi = std::min(d + 0.5 * fd, half);
        double cover = std::max(0.0, hi - lo) / fd;
        if (m->dashed) {
          const double tx = slope * inv_norm, ty = inv_norm;  // unit tangent
          const double fa = std::abs(tx * jux + ty * juy) + std::abs(tx * jvx + ty * jvy);
          if (fa < 1e-6) {
            cover *= (PaintedUpTo(*m, y + 1e-6) - PaintedUpTo(*m, y)) > 0 ? 1.0 : 0.0;
          } else {
            cover *= (PaintedUpTo(*m, y + 0.5 * fa) - PaintedUpTo(*m, y - 0.5 * fa)) / fa;
          }
        }
        if (cover <= 0) continue;
        double alpha = m->alpha;
        if (m->wear > 0) {
          alpha *= 1.0 - m->wear * std::max(0.0, ValueNoise(x, y, 1.0 / 0.4, m->salt));
        }
        colour = Lerp(colour, m->colour, alpha * cover);
      }

      colour *= static_cast<float>(ShadowFactor(shadows, x, y, foot));
      const double haze = 1.0 - (recur ? clear : std::exp(-y / look.haze_dist));
      row[u] = Lerp(colour, look.haze, haze);
    }
  }
}

void DrawVehicle(const CameraModel& cam, const Object& o, cv::Mat& img) {
  const Eigen::Vector2d bl = cam.GroundToImage({o.x - 0.5 * o.size, o.y});
  const Eigen::Vector2d br = cam.GroundToImage({o.x + 0.5 * o.size, o.y});
  const Eigen::Vector2d top = Project(cam, o.x, o.y, o.height);
  const double u0 = bl.x(), u1 = br.x();
  const double vb = 0.5 * (bl.y() + br.y());
  const double vt = top.y();
  const double w = u1 - u0;
  const double hh = vb - vt;
  if (w < 1.0 || hh < 1.0) return;
  const double uc = 0.5 * (u0 + u1);
  // Contact shadow on the road.
  cv::ellipse(img, Fp(uc, vb),
              cv::Size(cvRound(0.6 * w * 16), cvRound(std::max(1.0, 0.05 * hh) * 16)), 0, 0, 360,
              cv::Scalar(18, 18, 18), cv::FILLED, cv::LINE_AA, kShift);
  // Wheels, body, rear window, lights, plate.
  const cv::Scalar tyre(12, 12, 12);
  FillRect(img, u0 + 0.05 * w, vb - 0.25 * hh, u0 + 0.22 * w, vb, tyre);
  FillRect(img, u1 - 0.22 * w, vb - 0.25 * hh, u1 - 0.05 * w, vb, tyre);
  FillRoundedRect(img, u0, vt, u1, vb - 0.12 * hh, 0.12 * w, o.colour);
  FillRoundedRect(img, u0 + 0.12 * w, vt + 0.08 * hh, u1 - 0.12 * w, vt + 0.40 * hh, 0.06 * w,
                  o.colour2);
  const cv::Scalar red(35, 35, 175);
  FillRect(img, u0 + 0.04 * w, vt + 0.48 * hh, u0 + 0.2 * w, vt + 0.58 * hh, red);
  FillRect(img, u1 - 0.2 * w, vt + 0.48 * hh, u1 - 0.04 * w, vt + 0.58 * hh, red);
  FillRect(img, uc - 0.11 * w, vt + 0.62 * hh, uc + 0.11 * w, vt + 0.71 * hh,
           cv::Scalar(170, 170, 170));
  FillRect(img, u0 + 0.02 * w, vt + 0.76 * hh, u1 - 0.02 * w, vt + 0.82 * hh, o.colour * 0.6);
}

void DrawTree(const CameraModel& cam, const Object& o, cv::Mat& img) {
  const double trunk = 0.18;
  const double crown_z = o.height - o.size;
  FillPoly(img,
           {Project(cam, o.x - trunk, o.y, 0), Project(cam, o.x + trunk, o.y, 0),
            Project(cam, o.x + trunk, o.y, crown_z), Project(cam, o.x - trunk, o.y, crown_z)},
           o.colour2);
  const Eigen::Vector2d c = Project(cam, o.x, o.y, crown_z);
  const double r = (Project(cam, o.x + o.size, o.y, crown_z) - c).norm();
  if (r < 0.5) return;
  // A few overlapping blobs of slightly different greens.
  for (int k = 0; k < 4; ++k) {
    const double a = 1.7 * k + o.x;
    const Eigen::Vector2d p = c + 0.35 * r * Eigen::Vector2d(std::cos(a), std::sin(a) - 0.3);
    const double shade = 0.85 + 0.1 * k;
    cv::circle(img, Fp(p.x(), p.y()), cvRound(0.75 * r * 16), o.colour * shade, cv::FILLED,
               cv::LINE_AA, kShift);
  }
}

void DrawBuilding(const CameraModel& cam, const Object& o, cv::Mat& img) {
  const double y0 = o.y, y1 = o.y + o.size, x0 = o.x, x1 = o.x + o.extra, z = o.height;
  if (Depth(cam, x0, y0, z) < 1.0 || Depth(cam, x1, y0, z) < 1.0) return;
  // Face towards the camera (perpendicular to the road) and the side facade.
  FillPoly(img,
           {Project(cam, x0, y0, 0), Project(cam, x1, y0, 0), Project(cam, x1, y0, z),
            Project(cam, x0, y0, z)},
           o.colour);
  FillPoly(img,
           {Project(cam, x0, y0, 0), Project(cam, x0, y1, 0), Project(cam, x0, y1, z),
            Project(cam, x0, y0, z)},
           o.colour2);
  // Windows on the side facade.
  const cv::Scalar glass = o.colour2 * 0.45;
  for (double wz = 1.5; wz + 1.2 < z; wz += 3.0) {
    for (double wy = y0 + 1.0; wy + 1.5 < y1; wy += 3.0) {
      FillPoly(img,
               {Project(cam, x0, wy, wz), Project(cam, x0, wy + 1.5, wz),
                Project(cam, x0, wy + 1.5, wz + 1.2), Project(cam, x0, wy, wz + 1.2)},
               glass);
    }
  }
}

void DrawPole(const CameraModel& cam, const Object& o, cv::Mat& img) {
  FillPoly(img,
           {Project(cam, o.x - o.size, o.y, 0), Project(cam, o.x + o.size, o.y, 0),
            Project(cam, o.x + o.size, o.y, o.height), Project(cam, o.x - o.size, o.y, o.height)},
           o.colour);
}

void DrawObjects(const CameraModel& cam, std::vector<Object> objects, cv::Mat& img) {
  std::stable_sort(objects.begin(), objects.end(),
                   [](const Object& a, const Object& b) { return a.y > b.y; });
  for (const Object& o : objects) {
    if (Depth(cam, o.x, o.y, 0) < 1.0 || Depth(cam, o.x, o.y, o.height) < 1.0) continue;
    switch (o.kind) {
      case Object::kVehicle:
        DrawVehicle(cam, o, img);
        break;
      case Object::kTree:
        DrawTree(cam, o, img);
        break;
      case Object::kBuilding:
        DrawBuilding(cam, o, img);
        break;
      case Object::kPole:
        DrawPole(cam, o, img);
        break;
    }
  }
}

}  // namespace

absl::StatusOr<SyntheticFrame> RenderSyntheticFrame(const CameraModel& camera,
                                                    const SyntheticOptions& options,
                                                    uint64_t seed) {
  if (absl::Status s = camera.Validate(); !s.ok()) return s;
  if (absl::Status s = ValidateOptions(options); !s.ok()) return s;
  const int w = camera.image_width;
  const int h = camera.image_height;
  const double horizon = camera.HorizonRow();
  Rng rng(seed);

  Road road = SampleRoad(options, rng);
  const Look look = SampleLook(rng, h);

  // Nearest visible ground distance (bottom row, centre column).
  double y_bottom = 0.5;
  const bool ground_visible = h - 1 > horizon + 0.5;
  if (ground_visible) {
    const double yb = camera.ImageToGround({0.5 * (w - 1), h - 1.0}).y();
    if (std::isfinite(yb) && yb > 0) y_bottom = yb;
  }
  const std::vector<Shadow> shadows = SampleShadows(options, road, y_bottom, rng);
  const std::vector<Object> objects = SampleObjects(options, road, y_bottom, rng);
  const uint64_t noise_seed = rng();

  // Ground truth decides which boundaries exist in the frame.
  SyntheticFrame frame;
  const double y_near = std::max({options.truth_near_m, y_bottom, 0.1});
  const double y_far = options.truth_far_m;
  for (int i = 0; i < static_cast<int>(road.boundaries.size()); ++i) {
    Boundary& m = road.boundaries[i];
    m.visible = ground_visible && y_near < y_far && FitTruth(camera, road, y_near, y_far, &m);
    if (!m.visible) continue;
    if (i == road.ego_left) frame.ego_left = static_cast<int>(frame.boundaries.size());
    if (i == road.ego_right) frame.ego_right = static_cast<int>(frame.boundaries.size());
    SyntheticBoundary out;
    out.image = m.truth.p;
    out.dashed = m.dashed;
    out.yellow = m.yellow;
    out.lateral_offset_m = m.offset;
    frame.boundaries.push_back(out);
  }

  cv::Mat3f canvas(h, w, cv::Vec3f(look.haze));
  RenderSky(camera, look, canvas);
  RenderGround(camera, road, look, shadows, canvas);
  cv::Mat img;
  canvas.convertTo(img, CV_8UC3);
  DrawObjects(camera, objects, img);
  cv::GaussianBlur(img, img, cv::Size(3, 3), look.blur_sigma);

  // Exposure and sensor noise.
  cv::Mat f;
  img.convertTo(f, CV_32FC3, look.gain);
  if (options.noise_sigma > 0) {
    cv::Mat noise(f.size(), CV_32FC3);
    cv::RNG cvrng(noise_seed);
    cvrng.fill(noise, cv::RNG::NORMAL, 0.0, options.noise_sigma);
    f += noise;
  }
  f.convertTo(img, CV_8UC3);
  if (options.jpeg_quality > 0) {
    std::vector<uchar> buf;
    cv::imencode(".jpg", img, buf, {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality});
    img = cv::imdecode(buf, cv::IMREAD_COLOR);
  }
  frame.bgr = img;
  return frame;
}

std::string SyntheticLabelsJson(const std::string& frame_name, const SyntheticFrame& frame) {
  auto round2 = [](double v) { return std::round(v * 100.0) / 100.0; };
  nlohmann::ordered_json j;
  j["frame"] = frame_name;
  j["width"] = frame.bgr.cols;
  j["height"] = frame.bgr.rows;
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (int i = 0; i < static_cast<int>(frame.boundaries.size()); ++i) {
    const SyntheticBoundary& b = frame.boundaries[i];
    nlohmann::ordered_json pts = nlohmann::ordered_json::array();
    for (const auto& p : b.image) pts.push_back({round2(p.x()), round2(p.y())});
    nlohmann::ordered_json e;
    e["points"] = pts;
    e["dashed"] = b.dashed;
    e["color"] = b.yellow ? "yellow" : "white";
    e["ego"] = i == frame.ego_left ? "left" : (i == frame.ego_right ? "right" : "none");
    list.push_back(e);
  }
  j["boundaries"] = list;
  return j.dump();
}

}  // namespace lane
