// A continuous synthetic drive (lane/synthetic.h, RenderSyntheticDriveFrame):
// one road, fixed in the world, seen from a car that moves along it. The
// road is described along its length s (metres from the drive's start) and
// across it (metres right of its leftmost boundary); each frame turns it
// into the camera's ground frame (x right, y ahead) and draws it with the
// single-frame renderer (render.cc).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "scene.h"

namespace lane {

absl::Status SyntheticDriveOptions::Validate() const {
  auto bad = [](const std::string& what) {
    return absl::InvalidArgumentError(absl::StrCat("synthetic drive: ", what));
  };
  if (count < 1 || count > 1000000) return bad("count must be in 1..1000000");
  if (!(fps > 0 && fps <= 1000)) return bad("fps must be in (0, 1000]");
  if (!(speed_mps > 0 && speed_mps <= 60)) return bad("speed_mps must be in (0, 60]");
  if (num_lanes < 3 || num_lanes > 8) return bad("num_lanes must be in 3..8");
  if (!(lane_width_m >= 2.5 && lane_width_m <= 5.0)) return bad("lane_width_m must be in [2.5, 5]");
  if (!(lane_change_s > 0 && lane_change_s <= 20)) return bad("lane_change_s must be in (0, 20]");
  if (!(type_settle_s >= 0 && type_settle_s <= 20)) return bad("type_settle_s must be in [0, 20]");
  return synthetic_internal::ValidateOptions(frame);
}

namespace synthetic_internal {
namespace {

// 0 before a, rising smoothly to 1 at b, 1 until c, falling to 0 at d.
double Plateau(double x, double a, double b, double c, double d) {
  auto ramp = [](double t) {
    t = std::clamp(t, 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
  };
  if (x <= a || x >= d) return 0.0;
  if (x < b) return ramp((x - a) / (b - a));
  if (x <= c) return 1.0;
  return 1.0 - ramp((x - c) / (d - c));
}

// A vehicle whose distance ahead goes linearly from y0 to y1 over the
// drive's fractions [t0, t1] of its time, in lane `lane`.
struct DriveVehicle {
  int lane;
  double t0, t1, y0, y1;
  double lateral;  // from the lane's centre, metres
  Object look;
};

// Everything about the drive that does not change from frame to frame.
struct Drive {
  SyntheticDriveOptions o;
  double duration = 0;  // seconds
  double length = 0;    // metres
  Road world;           // boundaries at b * width, straight: the lateral layout
  Look look;
  std::vector<Shadow> shadows;   // in road coordinates (x lateral, y = s)
  std::vector<Object> roadside;  // x lateral, y = s
  std::vector<DriveVehicle> vehicles;
  double switch_s = 0;  // where boundary 1 turns from dashed to solid
  double weave_phase = 0;

  // Road curvature at s (1/m, right +): a right bend, then a left bend.
  double Curvature(double s) const {
    const double L = length;
    return Plateau(s, 0.10 * L, 0.20 * L, 0.30 * L, 0.40 * L) / 300.0 -
           Plateau(s, 0.60 * L, 0.70 * L, 0.80 * L, 0.90 * L) / 400.0;
  }
  double LaneChangeStart() const { return 0.42 * duration; }
  double LaneChangeLength() const { return std::min(o.lane_change_s, 0.4 * duration); }
  // The camera's lateral position (right of boundary 0) and its rate.
  void Lateral(double t, double* d, double* rate) const {
    const double w = o.lane_width_m;
    const double kWeave = 0.15, kWeavePeriod = 7.0;
    const double omega = 2.0 * kPi / kWeavePeriod;
    *d = 1.5 * w + kWeave * std::sin(omega * t + weave_phase);
    *rate = kWeave * omega * std::cos(omega * t + weave_phase);
    const double u = (t - LaneChangeStart()) / LaneChangeLength();
    if (u >= 1.0) {
      *d += w;
    } else if (u > 0.0) {
      *d += w * (0.5 - 0.5 * std::cos(kPi * u));
      *rate += w * 0.5 * kPi / LaneChangeLength() * std::sin(kPi * u);
    }
  }
  // Exposure over the drive: a darker stretch, then a brighter one.
  double Gain(double t) const {
    const double T = duration;
    return 1.0 - 0.35 * Plateau(t, 0.28 * T, 0.33 * T, 0.42 * T, 0.47 * T) +
           0.12 * Plateau(t, 0.75 * T, 0.80 * T, 0.90 * T, 0.95 * T);
  }
};

// Boundaries (solid yellow left, dashed white between, solid white right) and asphalt edges.
void SampleBoundaries(const SyntheticDriveOptions& o, Rng& rng, Road& road) {
  road.lane_width = o.lane_width_m;
  const double dash = Uniform(rng, 2.8, 3.2);
  const double gap = Uniform(rng, 8.5, 9.5);
  for (int b = 0; b <= o.num_lanes; ++b) {
    Boundary m;
    m.offset = b * o.lane_width_m;
    m.width = Uniform(rng, o.frame.min_marking_width_m, o.frame.max_marking_width_m);
    m.dashed = b > 0 && b < o.num_lanes;
    m.yellow = b == 0;
    m.dash = dash;
    m.gap = gap;
    m.phase = Uniform(rng, 0.0, dash + gap);
    m.alpha = Uniform(rng, 0.9, 1.0);
    m.wear = Uniform(rng, 0.0, 0.2);
    if (m.yellow) {
      m.colour = cv::Vec3f(static_cast<float>(Uniform(rng, 30, 60)),
                           static_cast<float>(Uniform(rng, 170, 200)),
                           static_cast<float>(Uniform(rng, 210, 240)));
    } else {
      const double w = Uniform(rng, 220, 250);
      m.colour = cv::Vec3f(static_cast<float>(w), static_cast<float>(w), static_cast<float>(w));
    }
    m.salt = rng();
    road.boundaries.push_back(m);
  }
  road.edge_left = -Uniform(rng, 0.4, 1.0);
  road.edge_right = o.num_lanes * o.lane_width_m + Uniform(rng, 0.8, 2.0);
}

// Tree shadows across a road of length L over a stretch, and a few elsewhere.
std::vector<Shadow> SampleShadows(double L, Rng& rng) {
  std::vector<Shadow> shadows;
  for (int i = 0; i < 8; ++i) {
    Shadow s;
    s.band = true;
    s.factor = Uniform(rng, 0.45, 0.7);
    s.soft = Uniform(rng, 0.1, 0.4);
    s.ragged = Uniform(rng, 0.2, 0.6);
    s.salt = rng();
    s.slope = Uniform(rng, -0.4, 0.4);
    s.depth = Uniform(rng, 1.5, 5.0);
    s.q0 = i < 5 ? Uniform(rng, 0.18, 0.34) * L + 30.0 : Uniform(rng, 0.0, L + 40.0);
    s.xa = -1e9;
    s.xb = 1e9;
    shadows.push_back(s);
  }
  return shadows;
}

// A vehicle in `lane` going from y0 to y1 ahead over the drive's fractions [t0, t1] of time.
DriveVehicle SampleVehicle(Rng& rng, int lane, double t0, double t1, double y0, double y1) {
  DriveVehicle v{lane, t0, t1, y0, y1, Uniform(rng, -0.3, 0.3), {}};
  v.look.kind = Object::kVehicle;
  v.look.height = kVehicleHeight * Uniform(rng, 0.9, 1.2);
  v.look.size = kVehicleWidth * Uniform(rng, 0.95, 1.1);
  const double g = Uniform(rng, 15, 90);
  v.look.colour = cv::Scalar(g, g * Uniform(rng, 0.8, 1.0), g * Uniform(rng, 0.8, 1.2));
  const double win = Uniform(rng, 55, 100);
  v.look.colour2 = cv::Scalar(win + 10, win + 5, win);
  return v;
}

Drive MakeDrive(const CameraModel& camera, const SyntheticDriveOptions& o, uint64_t seed) {
  Drive drive;
  drive.o = o;
  drive.duration = o.count / o.fps;
  drive.length = drive.duration * o.speed_mps;
  const double L = drive.length;
  Rng rng(seed);

  Road& road = drive.world;
  SampleBoundaries(o, rng, road);
  drive.switch_s = 0.55 * L;
  drive.weave_phase = Uniform(rng, 0.0, 2.0 * kPi);

  drive.look = SampleLook(rng, camera.image_height);
  drive.look.gain = 1.0;

  drive.shadows = SampleShadows(L, rng);
  // Trees, buildings and poles along the whole road.
  const int roadside = static_cast<int>(L / 8.0) + 6;
  for (int i = 0; i < roadside; ++i) {
    drive.roadside.push_back(SampleRoadsideObject(road, 0.0, L + 160.0, 1.0, rng));
  }
  // Traffic: one car in the left lane that the ego car overtakes; after the
  // lane change one closing in ahead, and one overtaking on the left.
  drive.vehicles.push_back(SampleVehicle(rng, 0, 0.05, 0.40, 28.0, 9.0));
  drive.vehicles.push_back(SampleVehicle(rng, 2, 0.60, 1.00, 32.0, 13.0));
  drive.vehicles.push_back(SampleVehicle(rng, 1, 0.84, 1.00, 6.0, 18.0));
  return drive;
}

// The car at time t: along (s), across (d, right of boundary 0), lateral rate, heading (psi).
struct CarPose {
  double t = 0, s = 0, d = 0, rate = 0, psi = 0, cos_psi = 1;
};

// The car's pose at time t of the drive.
CarPose CarPoseAt(const Drive& drive, double t) {
  CarPose car;
  car.t = t;
  car.s = drive.o.speed_mps * t;
  drive.Lateral(t, &car.d, &car.rate);
  car.psi = std::atan2(car.rate, drive.o.speed_mps);
  car.cos_psi = std::cos(car.psi);
  return car;
}

// The road in the car's ground frame (x right, y ahead): offsets, heading, curvature ahead.
Road RoadSeenFrom(const Drive& drive, const CarPose& car) {
  Road road = drive.world;
  road.heading = -std::tan(car.psi);
  road.curvature = drive.Curvature(car.s + 15.0);
  road.world_texture = true;
  road.s0 = car.s;
  for (Boundary& m : road.boundaries) {
    const double lateral = m.offset;  // from boundary 0 on the road
    m.offset = (lateral - car.d) / car.cos_psi;
    m.phase -= car.s;
    if (m.dashed && &m == &road.boundaries[1]) m.solid_from = drive.switch_s - car.s;
  }
  road.edge_left = (drive.world.edge_left - car.d) / car.cos_psi;
  road.edge_right = (drive.world.edge_right - car.d) / car.cos_psi;
  return road;
}

// The drive's shadows, roadside objects and vehicles in the car's frame, into scene.
void PlaceInScene(const Drive& drive, const CarPose& car, double y_bottom, Scene& scene) {
  const Road& road = scene.road;
  for (Shadow s : drive.shadows) {
    s.q0 = s.q0 - car.s + s.slope * car.d;
    s.noise_dx = car.d;
    s.noise_dy = car.s;
    scene.shadows.push_back(s);
  }
  for (Object r : drive.roadside) {
    r.y -= car.s;
    if (r.y < y_bottom + 1.0 || r.y > 160.0) continue;
    r.x = road.X((r.x - car.d) / car.cos_psi, r.y);
    scene.objects.push_back(r);
  }
  for (const DriveVehicle& v : drive.vehicles) {
    const double f = car.t / drive.duration;
    if (f < v.t0 || f > v.t1) continue;
    Object o = v.look;
    o.y = v.y0 + (v.y1 - v.y0) * (f - v.t0) / (v.t1 - v.t0);
    const double centre = (v.lane + 0.5) * drive.o.lane_width_m + v.lateral;
    o.x = road.X((centre - car.d) / car.cos_psi, o.y);
    o.extra = v.lane;
    scene.objects.push_back(o);
  }
}

// Labels the pattern nearest the camera, and whether it changes in view or just changed.
void LabelPatterns(const SyntheticDriveOptions& options, const Road& road, double y_bottom,
                   SyntheticFrame& frame) {
  const double y_near = std::max({options.frame.truth_near_m, y_bottom, 0.1});
  for (SyntheticBoundary& b : frame.boundaries) {
    const Boundary& m = road.boundaries[static_cast<size_t>(b.id)];
    if (!m.dashed || !std::isfinite(m.solid_from)) continue;
    b.dashed = m.solid_from > y_near;
    b.type_changes = m.solid_from < options.frame.truth_far_m &&
                     m.solid_from > y_near - options.type_settle_s * options.speed_mps;
  }
}

// The true ego lane: its index, the car's offset, the lane's width, heading and curvature.
SyntheticEgo EgoTruth(const CameraModel& camera, const Road& road, const CarPose& car, int ego,
                      double w) {
  SyntheticEgo truth;
  truth.lane = ego;
  truth.offset_m = car.d - (ego + 0.5) * w;
  truth.width_m = w;
  // The lane's direction from the optical axis: the axis meets the ground
  // at the principal point's ground point.
  const Eigen::Vector2d axis = camera.ImageToGround({camera.cu, camera.cv});
  const double axis_angle = axis.allFinite() && axis.y() > 0 ? std::atan2(axis.x(), axis.y())
                                                             : camera.yaw_deg * kDegToRad;
  truth.heading_deg = (std::atan(road.heading) - axis_angle) / kDegToRad;
  truth.curvature_per_m = road.curvature;
  truth.offset_rate_mps = car.rate;
  return truth;
}

}  // namespace
}  // namespace synthetic_internal

using namespace synthetic_internal;  // NOLINT: this library's own helpers

absl::StatusOr<SyntheticFrame> RenderSyntheticDriveFrame(const CameraModel& camera,
                                                         const SyntheticDriveOptions& options,
                                                         uint64_t seed, int index) {
  if (absl::Status s = camera.Validate(); !s.ok()) return s;
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (index < 0 || index >= options.count) {
    return absl::InvalidArgumentError(
        absl::StrCat("synthetic drive: frame ", index, " outside 0..", options.count - 1));
  }
  const Drive drive = MakeDrive(camera, options, seed);
  const double t = index / options.fps;
  const double w = options.lane_width_m;
  const CarPose car = CarPoseAt(drive, t);

  Scene scene;
  scene.road = RoadSeenFrom(drive, car);
  const int lanes = options.num_lanes;
  const int ego = std::clamp(static_cast<int>(std::floor(car.d / w)), 0, lanes - 1);
  scene.road.ego_left = ego;
  scene.road.ego_right = ego + 1;

  scene.look = drive.look;
  scene.look.gain = drive.Gain(t);
  const double y_bottom = BottomDistance(camera);
  PlaceInScene(drive, car, y_bottom, scene);
  scene.noise_seed = seed * 0x9e3779b97f4a7c15ULL + static_cast<uint64_t>(index) + 1;

  SyntheticFrame frame = RenderScene(camera, options.frame, scene);
  frame.time_s = t;
  LabelPatterns(options, scene.road, y_bottom, frame);
  frame.ego = EgoTruth(camera, scene.road, car, ego, w);
  return frame;
}

}  // namespace lane
