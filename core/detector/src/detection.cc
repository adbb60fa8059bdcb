#include "lane/detector/detection.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"

namespace lane {

LanePathCounts CountLanePaths(const Detection& detection) {
  LanePathCounts counts;
  for (const Lane& lane : detection.lanes) {
    if (lane.inferred) continue;
    ++(lane.refit ? counts.refit : counts.searched);
  }
  return counts;
}

std::optional<Lane> LaneAlongCurve(const GroundCurve& curve, const IpmMapping& ipm,
                                   bool near_first) {
  constexpr int kSamples = 12;
  const CameraModel& camera = ipm.camera();
  const double horizon = camera.HorizonRow();
  const double y_from = near_first ? curve.y_near : curve.y_far;
  const double y_to = near_first ? curve.y_far : curve.y_near;
  std::vector<Eigen::Vector2d> ground, image, top;
  for (int i = 0; i < kSamples; ++i) {
    const double y = y_from + (y_to - y_from) * i / (kSamples - 1);
    const Eigen::Vector2d g(curve.X(y), y);
    const Eigen::Vector2d p = camera.GroundToImage(g);
    if (!p.allFinite() || p.y() <= horizon) continue;
    ground.push_back(g);
    image.push_back(p);
    top.push_back(ipm.GroundToIpm(g));
  }
  if (ground.size() < 4) return std::nullopt;
  const auto g = FitBezier(ground);
  const auto m = FitBezier(image);
  const auto t = FitBezier(top);
  if (!g || !m || !t) return std::nullopt;
  Lane lane;
  lane.ground = g->p;
  lane.image = m->p;
  lane.ipm = t->p;
  return lane;
}

const char* ModeName(Mode mode) { return mode == Mode::kTwo ? "two" : "all"; }

std::optional<Mode> ParseMode(const std::string& name) {
  if (name == "all") return Mode::kAll;
  if (name == "two") return Mode::kTwo;
  return std::nullopt;
}

const char* ChannelName(Channel channel) {
  switch (channel) {
    case Channel::kRed:
      return "red";
    case Channel::kGreen:
      return "green";
    case Channel::kBlue:
      return "blue";
    case Channel::kGray:
      return "gray";
    case Channel::kMinRedGreen:
      return "min_rg";
  }
  return "red";
}

std::optional<Channel> ParseChannel(const std::string& name) {
  if (name == "red") return Channel::kRed;
  if (name == "green") return Channel::kGreen;
  if (name == "blue") return Channel::kBlue;
  if (name == "gray" || name == "grey") return Channel::kGray;
  if (name == "min_rg") return Channel::kMinRedGreen;
  return std::nullopt;
}

DetectorOptions DetectorOptions::ForMode(Mode mode) {
  DetectorOptions o;
  o.mode = mode;
  if (mode == Mode::kTwo) {
    // The reference's bracketed 2-lanes values, converted to metres at the
    // Caltech camera's 8.9 IPM px per metre, except the quantile (threshold.h:
    // the reference's 98.5 % lost worn boundaries).
    o.hough.min_peak *= 1.5;  // reference: 6 instead of 4
    o.hough.group_distance_m = 1.7;
    o.line_ransac.window_half_width_m = 0.9;
    o.line_ransac.ransac.iterations = 40;
    o.spline_ransac.window_half_width_m = 0.67;
    o.spline_ransac.ransac.iterations = 75;
    o.spline_ransac.k2 = 1.0;
    // The ego lane's band (+-2.9 m) holds its two boundaries: 2 x 0.25 m of
    // kept pixels in 5.8 m is 8.6 % of a row (threshold.h).
    o.threshold.transverse_max_fraction = 0.15;
    // The band seldom reaches a curb, the stricter contrast's target in
    // all-lanes mode; the paper's-era 0.015 keeps more of the ego lane's
    // worn boundaries (cordova1 2-lanes: 96.57 % correct / 2.49 % FP against
    // 96.09 % / 2.49 % at 0.027; docs/accuracy-log.md entry 35).
    o.postprocess.min_side_contrast = 0.015;
  }
  return o;
}

absl::Status DetectorOptions::Validate() const {
  for (const absl::Status& s :
       {filter.Validate(), threshold.Validate(), hough.Validate(), line_ransac.Validate(),
        spline_ransac.Validate(), postprocess.Validate(), two_lanes.Validate(),
        road_model.Validate()}) {
    if (!s.ok()) return s;
  }
  return absl::OkStatus();
}

}  // namespace lane
