#include "lane/geometry/ground_view_rule.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"

namespace lane {
namespace {

constexpr double kNeverM = std::numeric_limits<double>::infinity();
// Distances are searched from here (metres ahead of the camera's foot
// point) to kFarthestM, in steps of kStepRatio, then refined by bisection.
constexpr double kNearestM = 0.5;
constexpr double kFarthestM = 1000.0;
constexpr double kStepRatio = 1.004;
constexpr int kBisections = 24;
// Lateral spacing of the boundaries tried within the reach, metres.
constexpr double kLateralStepM = 0.25;

// Whether a ground point (x, y) lies in front of the camera (its image is
// the projection, not the mirror image of a point behind): the homogeneous
// coordinate of CameraModel::GroundToImage is positive.
class InFront {
 public:
  explicit InFront(const CameraModel& camera)
      : c1_(std::cos(camera.pitch_deg * kDegToRad)),
        s1h_(std::sin(camera.pitch_deg * kDegToRad) * camera.height_m),
        c2_(std::cos(camera.yaw_deg * kDegToRad)),
        s2_(std::sin(camera.yaw_deg * kDegToRad)) {}
  bool operator()(double x, double y) const { return c1_ * (s2_ * x + c2_ * y) + s1h_ > 1e-6; }

 private:
  double c1_, s1h_, c2_, s2_;
};

// The first y in [lo, hi] where `pred` holds, when it does not at lo but
// does at hi (bisection to kBisections steps).
template <class Pred>
double FirstTrue(double lo, double hi, const Pred& pred) {
  for (int i = 0; i < kBisections; ++i) {
    const double mid = 0.5 * (lo + hi);
    (pred(mid) ? hi : lo) = mid;
  }
  return hi;
}

// The rule's view of one camera: is the ground point on the road in the
// image (inside it, below the horizon's margin, above the outline)?
class RoadVisibility {
 public:
  RoadVisibility(const CameraModel& camera, const RoadOutline& outline, double margin_px)
      : camera_(camera),
        in_front_(camera),
        outline_(outline),
        top_row_(camera.HorizonRow() + margin_px) {}

  bool OnRoad(double x, double y) const {
    if (!in_front_(x, y)) return false;
    const Eigen::Vector2d p = camera_.GroundToImage({x, y});
    if (!p.allFinite() || !(p.y() >= top_row_)) return false;
    if (p.x() < 0 || p.x() > camera_.image_width - 1.0) return false;
    // Row first_row_below - 1 is the road's last.
    return p.y() <= outline_.FirstRowBelow(p.x(), camera_.image_height) - 1.0;
  }

  // The nearest distance ahead at which the boundary at lateral x is on the
  // road, searched up to `far`; infinity when it is not.
  double Entry(double x, double far) const {
    double previous = kNearestM;
    if (OnRoad(x, previous)) return previous;
    for (double y = kNearestM * kStepRatio; y <= far; y *= kStepRatio) {
      if (OnRoad(x, y)) return FirstTrue(previous, y, [&](double t) { return OnRoad(x, t); });
      previous = y;
    }
    return kNeverM;
  }

 private:
  const CameraModel& camera_;
  InFront in_front_;
  const RoadOutline& outline_;
  double top_row_;
};

// The distance at which the ground point (x, y) rises to image row `row`
// (towards the horizon), or kFarthestM.
double DistanceAtRow(const CameraModel& camera, double x, double row) {
  const InFront in_front(camera);
  auto above = [&](double y) {
    if (!in_front(x, y)) return false;
    const Eigen::Vector2d p = camera.GroundToImage({x, y});
    return !p.allFinite() || p.y() < row;
  };
  if (!above(kFarthestM)) return kFarthestM;
  if (above(kNearestM)) return kNearestM;
  return FirstTrue(kNearestM, kFarthestM, above);
}

// The distance at which a marking of `width_m` straight ahead (x = 0)
// narrows to `min_px` image columns, or kFarthestM.
double DistanceAtMarkingWidth(const CameraModel& camera, double width_m, double min_px) {
  const InFront in_front(camera);
  auto narrow = [&](double y) {
    if (!in_front(-0.5 * width_m, y) || !in_front(0.5 * width_m, y)) return false;
    const double u0 = camera.GroundToImage({-0.5 * width_m, y}).x();
    const double u1 = camera.GroundToImage({0.5 * width_m, y}).x();
    return !(std::abs(u1 - u0) >= min_px);
  };
  if (!narrow(kFarthestM)) return kFarthestM;
  if (narrow(kNearestM)) return kNearestM;
  return FirstTrue(kNearestM, kFarthestM, narrow);
}

}  // namespace

RoadOutline RoadOutline::Flat(double row, int image_width) {
  RoadOutline o;
  o.first_row_below.assign(static_cast<size_t>(std::max(0, image_width)), row);
  return o;
}

double RoadOutline::FirstRowBelow(double u, int image_height) const {
  if (first_row_below.empty()) return image_height;
  const double last = static_cast<double>(first_row_below.size() - 1);
  const size_t k = static_cast<size_t>(std::clamp(std::round(u), 0.0, last));
  return std::min<double>(first_row_below[k], image_height);
}

double RoadOutline::Top(int image_height) const {
  double top = image_height;
  for (double r : first_row_below) top = std::min(top, r);
  return top;
}

double RoadOutline::Bottom(int image_height) const {
  if (first_row_below.empty()) return image_height;
  double bottom = 0;
  for (double r : first_row_below) bottom = std::max(bottom, std::min<double>(r, image_height));
  return bottom;
}

absl::Status GroundViewRule::Validate() const {
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v > lo && v < hi; };
  if (!in(lane_width_m, 1.0, 10.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("lane width must lie in (1, 10) metres, got ", lane_width_m));
  }
  if (!in(reach_lanes, 0.0, 5.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("reach must lie in (0, 5) lane widths, got ", reach_lanes));
  }
  if (!in(stretch_m, 0.0, 200.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("stretch must lie in (0, 200) metres, got ", stretch_m));
  }
  if (!in(marking_width_m, 0.0, 2.0) || !in(min_marking_px, 0.0, 100.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("the resolution limit needs a marking width in (0, 2) m and pixels in (0, "
                     "100), got ",
                     marking_width_m, " m and ", min_marking_px, " px"));
  }
  if (!in(lateral_lanes, 0.0, 10.0) || !(lateral_margin_m >= 0 && lateral_margin_m < 10.0)) {
    return absl::InvalidArgumentError(absl::StrCat("the lateral extent needs lanes in (0, 10) ",
                                                   "and a margin in [0, 10) m, got ", lateral_lanes,
                                                   " and ", lateral_margin_m));
  }
  if (!in(metres_per_px_x, 0.001, 10.0) || !in(metres_per_px_y, 0.001, 10.0)) {
    return absl::InvalidArgumentError("metres per pixel must lie in (0.001, 10)");
  }
  if (!(horizon_margin_px >= 0 && horizon_margin_px < 1e4)) {
    return absl::InvalidArgumentError("horizon margin must lie in [0, 1e4) pixels");
  }
  return absl::OkStatus();
}

absl::StatusOr<DerivedGroundView> DeriveGroundView(const CameraModel& camera,
                                                   const RoadOutline& outline,
                                                   const GroundViewRule& rule) {
  if (absl::Status s = camera.Validate(); !s.ok()) return s;
  if (absl::Status s = rule.Validate(); !s.ok()) return s;
  DerivedGroundView d;
  GroundView& g = d.view;
  g.x_max_m = rule.lateral_lanes * rule.lane_width_m + rule.lateral_margin_m;
  g.x_min_m = -g.x_max_m;
  g.metres_per_px_x = rule.metres_per_px_x;
  g.metres_per_px_y = rule.metres_per_px_y;

  // The far limit: where the view's far corners rise to the horizon's
  // margin, or a marking narrows below the resolution.
  const double margin_row = camera.HorizonRow() + rule.horizon_margin_px;
  double horizon_limit = kNeverM;
  for (const double x : {g.x_min_m, 0.0, g.x_max_m}) {
    horizon_limit = std::min(horizon_limit, DistanceAtRow(camera, x, margin_row));
  }
  d.far_limit_m = std::min(
      horizon_limit, DistanceAtMarkingWidth(camera, rule.marking_width_m, rule.min_marking_px));

  // Every boundary within the reach: where it comes into view.
  const RoadVisibility visibility(camera, outline, rule.horizon_margin_px);
  const double reach = rule.reach_lanes * rule.lane_width_m;
  const int steps = std::max(2, static_cast<int>(std::ceil(2.0 * reach / kLateralStepM)));
  d.nearest_road_m = kNeverM;
  d.last_entry_m = 0;
  bool unseen = false;
  for (int i = 0; i <= steps; ++i) {
    const double x = -reach + 2.0 * reach * i / steps;
    const double entry = visibility.Entry(x, d.far_limit_m);
    if (i == 0) d.outer_left_entry_m = entry;
    if (i == steps) d.outer_right_entry_m = entry;
    if (!std::isfinite(entry)) {
      unseen = true;
      continue;
    }
    d.nearest_road_m = std::min(d.nearest_road_m, entry);
    d.last_entry_m = std::max(d.last_entry_m, entry);
  }
  if (!std::isfinite(d.nearest_road_m)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "no lane boundary within ", reach, " m of the camera shows on the road between ", kNearestM,
        " and ", d.far_limit_m, " m ahead (horizon at row ", camera.HorizonRow(),
        ", road's last row ", outline.Bottom(camera.image_height) - 1.0,
        "): is the camera's pitch right?"));
  }
  g.y_min_m = d.nearest_road_m;
  g.y_max_m = std::min(d.last_entry_m + rule.stretch_m, d.far_limit_m);
  d.cut = unseen || d.last_entry_m + rule.stretch_m > d.far_limit_m;
  if (!(g.y_max_m - g.y_min_m >= 8 * rule.metres_per_px_y)) {
    return absl::InvalidArgumentError(
        absl::StrCat("the road shows from ", g.y_min_m,
                     " m, but the resolution's or the horizon's far limit is ", d.far_limit_m,
                     " m: no top view of 8 rows fits"));
  }
  return d;
}

IpmOptions GroundViewIpm(const GroundView& view, IpmOptions ipm) {
  ipm.view = IpmView::kGround;
  ipm.ground = view;
  ipm.interpolation = Interpolation::kArea;
  return ipm;
}

absl::StatusOr<IpmOptions> BuiltInIpm(const CameraModel& camera) {
  absl::StatusOr<DerivedGroundView> d = DeriveGroundView(camera);
  if (!d.ok()) return d.status();
  return GroundViewIpm(d->view);
}

}  // namespace lane
