// The synthetic renderer's internals: the scene (road, boundaries, shadows,
// objects, look) and the helpers that the sampling (scene.cc) and the
// drawing (render.cc) share.
#ifndef LANE_SYNTHETIC_SCENE_H_
#define LANE_SYNTHETIC_SCENE_H_

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "absl/status/status.h"
#include "lane/geometry/bezier.h"
#include "lane/geometry/camera.h"
#include "lane/synthetic.h"

namespace lane::synthetic_internal {

using Rng = std::mt19937_64;

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;

// Ground truth sampling and the visibility rule shared by truth and pixels.
constexpr int kTruthSamples = 120;
constexpr int kMinVisibleSamples = 8;
constexpr double kMinVisibleRows = 30.0;

// Fixed-point (4 fractional bits) drawing coordinates.
constexpr int kShift = 4;

// Vehicles (metres).
constexpr double kVehicleWidth = 1.8;
constexpr double kVehicleHeight = 1.5;

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
  // > 0: a double line, two lines of `width` this far apart (metres),
  // centred on `offset`.
  double double_gap = 0.0;
  // Botts' dots (AddBottsDots): discs of diameter `width`, in groups of 4
  // `dot_spacing` apart; a group every `dash + gap` metres, `dash` being
  // the group's length centre to centre, the first at `phase`.
  bool dots = false;
  double dot_spacing = 0.95;
  // A dot's height over the camera's: it covers the road this share of its
  // distance behind it too (DotsCover).
  double dot_rise = 0;
  cv::Vec3f colour;
  uint64_t salt = 0;
  // A dashed boundary is solid from this far ahead on (metres; a drive's
  // dashed-to-solid change).
  double solid_from = std::numeric_limits<double>::infinity();
  // Nothing is painted nearer than this (metres; SyntheticOptions::first_dash_m).
  double paint_from = -std::numeric_limits<double>::infinity();
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
  // A drive (drive.cc): the asphalt and verge texture is fixed to the road,
  // at (lateral position from the first boundary, y + s0), so that it moves
  // past the camera; single frames texture (x, y).
  bool world_texture = false;
  double s0 = 0;

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
  double noise_dx = 0, noise_dy = 0;  // the leafy edge's noise is read at (x + dx, y + dy)
};

struct Look {
  double asphalt = 100;  // mean grey
  cv::Vec3f asphalt_tint{1, 1, 1};
  double patch_amp = 10, mid_amp = 5, grain_amp = 10;
  double track_dark = 0;  // tyre tracks
  // Concrete (SyntheticOptions::concrete): slab seams this much darker,
  // across the road every `seam_every` metres (0 = none) and along it
  // `seam_beside` metres right of each boundary.
  double seam_every = 0, seam_dark = 0, seam_beside = 0;
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
  enum Kind { kVehicle, kTree, kBuilding, kPole, kSign, kGuardrail } kind = kVehicle;
  double x = 0, y = 0;  // ground position of its base (nearest point), metres
  double size = 0;      // building length / tree crown radius
  double height = 0;
  // Building: depth (signed, away from the road); vehicle: lane; sign:
  // panel width; guardrail: length along the road (it follows `offset`).
  double extra = 0;
  double offset = 0;  // guardrail: lateral offset at y = 0 (Road::X)
  cv::Scalar colour, colour2;
};

double Uniform(Rng& rng, double lo, double hi);
int UniformInt(Rng& rng, int lo, int hi);
bool Chance(Rng& rng, double p);

// Hash-based value noise in ground coordinates (no tables: defined
// everywhere on the unbounded road plane).
double ValueNoise(double x, double y, double inv_cell, uint64_t salt);
double SoftStep(double s, double w);
cv::Vec3f Lerp(const cv::Vec3f& a, const cv::Vec3f& b, double t);

// Geometry and drawing helpers.
double Depth(const CameraModel& cam, double x, double y, double z);
Eigen::Vector2d Project(const CameraModel& cam, double x, double y, double z);
cv::Point Fp(double u, double v);
void FillPoly(cv::Mat& img, const std::vector<Eigen::Vector2d>& pts, const cv::Scalar& colour);
void FillRoundedRect(cv::Mat& img, double u0, double v0, double u1, double v1, double r,
                     const cv::Scalar& colour);
void FillRect(cv::Mat& img, double u0, double v0, double u1, double v1, const cv::Scalar& colour);

// Scene sampling: everything random comes from one engine, so a seed fully
// determines the frame.
absl::Status ValidateOptions(const SyntheticOptions& o);
Road SampleRoad(const SyntheticOptions& o, Rng& rng);
Look SampleLook(Rng& rng, int image_height);
std::vector<Shadow> SampleShadows(const SyntheticOptions& o, const Road& road, double y_min,
                                  Rng& rng);
std::vector<Object> SampleObjects(const SyntheticOptions& o, const Road& road, double y_min,
                                  Rng& rng);
// The lateral position `clearance` metres beyond the asphalt's edge on one
// side, `y` ahead; a tree crown's green.
double BesideRoad(const Road& road, bool left, double y, double clearance);
cv::Scalar CrownColour(Rng& rng);
// One tree, building or pole beside the road at y in [near, far] (denser
// near `near` for power > 1).
Object SampleRoadsideObject(const Road& road, double near, double far, double power, Rng& rng);
// The clutter options' objects (SyntheticOptions: extra roadside objects,
// tree rows, signs, guardrails) and worn paint, from their own engine, so
// that the rest of the frame stays as without them.
void AddClutter(const SyntheticOptions& o, double y_min, Rng& rng, Road* road,
                std::vector<Object>* objects);
double ShadowFactor(const std::vector<Shadow>& shadows, double x, double y, double foot);
// SyntheticOptions::concrete and botts_dots_probability (dots.cc), from
// their own engine, so that the rest of the frame stays as without them.
void AddBottsDots(const SyntheticOptions& o, double camera_height_m, Rng& rng, Road* road,
                  Look* look);
// The share of a pixel covered by a boundary of Botts' dots: `across` the
// pixel's centre from the boundary (metres), `along` its distance ahead,
// `fd` and `fa` the footprint's extents across and along.
double DotsCover(const Boundary& m, double across, double fd, double along, double fa);
// The darkening of the concrete's slab seams (Look::seam_*) at a pixel:
// `lane_pos` from the first boundary, `along` ahead, `fx` and `fy` the
// footprint's extents across and along.
double SeamDarkening(const Road& road, const Look& look, double lane_pos, double along, double fx,
                     double fy);
double PaintedUpTo(const Boundary& m, double s);
// Night lighting (SyntheticOptions::night), built from grey levels measured
// on a CULane night clip (1640x590, camera 1.23 m high, pitch 1.8 deg;
// issue 49). Light is given as the grey level it gives a day-grey-100
// asphalt; a pixel of day grey d under light G shows
//   255 q / (1 + q),  q = G / (255 - G) (d / 100)^kNightGamma,
// a camera response that maps the measured road and marking levels both
// unlit (road 17, marking 31-35) and in the headlight pool (road ~100,
// marking +46) from one day marking-to-asphalt ratio.
struct Night {
  bool on = false;
  double unlit = 17;  // the road outside every light (measured 17)
  double sky = 8;     // the light above the horizon and on the hood (HoodRow)
  // The low beams' pool: on the camera's axis the measured profile
  // (NightAxisGrey), its part above `unlit` times `pool_gain`; across, a
  // Gaussian centred y tan(pool_centre_deg) to the right, of sigma
  // hypot(y tan(pool_sigma_deg), kNightLampSpreadM): two lamps' cones
  // (measured at 12 m: 158 on the axis, 91 / 74 at +-2 m, 36 / 22 at
  // +-3.5 m, 16 / 15 at +-7 m: sigma 1.6 m, centre 0.17 m right; dipped
  // beams light the kerb side).
  double pool_gain = 1.0;
  double pool_sigma_deg = 6.84;
  double pool_centre_deg = 0.8;
  // Street lamps: pools of light on the ground (grey added to the unlit
  // road at the centre, Gaussian of `radius_m`) and their heads, `height_m`
  // up, drawn as glare. Measured: markings +28 to +33 under them (20-50 m).
  struct Lamp {
    double x = 0, y = 0, radius_m = 6, gain = 28, height_m = 8;
  };
  std::vector<Lamp> lamps;
  // Saturated blobs above the horizon (neon signs, lamps, windows): 4-19 a
  // frame, up to 2,200 px each at 1640x590 (scaled by the image's area).
  struct Glare {
    Eigen::Vector2d at;
    double half_w = 2, half_h = 2;  // pixels
    bool round = true;              // an ellipse, else a rectangle (a sign)
  };
  std::vector<Glare> glare;
  // Oncoming headlights on the horizon (image points, radius px).
  struct Light {
    Eigen::Vector2d at;
    double radius = 3;
  };
  std::vector<Light> lights;

  // The light (NightLight's grey) at ground point (x, y).
  double GroundLight(double x, double y) const;
};
// The measured grey of the road on the camera's axis under the low beams,
// `y` metres ahead: 150-160 at 12-15 m, 124 at 20, 82 at 30, 52 at 40, 38
// at 60 m, then falling with the square of the distance to `unlit`; nearer
// than 12 m (not measured: the hood hides the road below 6 m) it falls off
// towards the car, as the markings' contrast does (+40 at 8-12 m against
// +46 at 12-20 m).
double NightAxisGrey(double y, double unlit);
// The night's marking contrast falls beyond 45 m faster than the light
// (measured: +32 at 30-50 m, +14 at 50-90 m): the paint's share of a
// ground pixel's day grey above the asphalt is scaled by this factor.
double NightPaintFactor(double y);
constexpr double kNightGamma = 0.88;
// Half the distance between the car's two headlamps, metres.
constexpr double kNightLampSpreadM = 0.7;
// The grey a day-grey `d` surface shows under light `g` (Night's response).
double NightGrey(double d, double g);
Night SampleNight(const CameraModel& cam, const Road& road, Rng& rng);
// At night the sensor's gain is up: 2.5 times the noise at mid grey, falling
// with the square root of the level (photon noise), so that black stays black.
constexpr double kNightNoiseGain = 2.5;

// Everything random of one frame, then drawn by RenderScene.
struct Scene {
  Road road;
  Look look;
  std::vector<Shadow> shadows;
  std::vector<Object> objects;
  uint64_t noise_seed = 0;
  Night night;
};
// SyntheticOptions::static_overlay: the reflection of a card with digits,
// blended into `img` (CV_8UC3) at a fixed place for its size.
void DrawStaticOverlay(cv::Mat& img);

// The ground distance of the bottom row's centre (0.5 when the ground is not
// visible there).
double BottomDistance(const CameraModel& cam);
// Draws the scene and fits its truth (the boundaries' `visible` and `truth`
// are set). The options' noise, JPEG and truth range apply.
SyntheticFrame RenderScene(const CameraModel& cam, const SyntheticOptions& options, Scene& scene);

// Fits the boundary's image-space Bezier truth between y_near and y_far;
// false when too little of it is visible.
// Labels stop at the hood (SyntheticOptions::hood_top_row) unless
// `options.labels_through_hood`.
bool FitTruth(const CameraModel& cam, const Road& road, double y_near, double y_far,
              const SyntheticOptions& options, Boundary* m);

// Paints the hood (SyntheticOptions::hood_top_row, HoodRow) over `img`
// (8-bit BGR) as in daylight; at night ApplyNight then lights it by the sky.
void DrawHood(const CameraModel& cam, const SyntheticOptions& options, cv::Mat& img);
// Relights a day image (8-bit BGR) for the night (night.cc): ground pixels
// by Night's light there, the sky and the hood by the sky's light, then the
// glare, the lamps' heads and the oncoming headlights.
void ApplyNight(const CameraModel& cam, const SyntheticOptions& options, const Night& night,
                const Look& look, cv::Mat& img);

}  // namespace lane::synthetic_internal

#endif  // LANE_SYNTHETIC_SCENE_H_
