#include "lane/calibrate/self_check.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "lane/base/median.h"

namespace lane {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

struct ChordLine {
  double heading_deg = 0;
  double x_ref = 0;  // lateral position at the frame's reference distance
};

}  // namespace

void LaneGeometryCheck::AddFrame(const std::vector<GroundChord>& lanes) {
  ++frames_;
  // Lanes that run ahead for at least half a metre; their lateral position
  // at one distance shared by the frame (the median of their middles).
  std::vector<const GroundChord*> usable;
  std::vector<double> mids;
  for (const GroundChord& c : lanes) {
    const Eigen::Vector2d d = c.far - c.near;
    if (!d.allFinite() || !c.near.allFinite() || d.y() < 0.5) continue;
    usable.push_back(&c);
    mids.push_back(0.5 * (c.near.y() + c.far.y()));
  }
  if (usable.size() < 2) return;
  const double y_ref = Median(mids);
  std::vector<ChordLine> lines;
  for (const GroundChord* c : usable) {
    const Eigen::Vector2d d = c->far - c->near;
    lines.push_back({std::atan2(d.x(), d.y()) * kRadToDeg,
                     c->near.x() + (y_ref - c->near.y()) * d.x() / d.y()});
  }
  std::sort(lines.begin(), lines.end(),
            [](const ChordLine& a, const ChordLine& b) { return a.x_ref < b.x_ref; });
  int best = -1;
  double best_centre = std::numeric_limits<double>::infinity(), best_width = 0;
  for (size_t i = 0; i + 1 < lines.size(); ++i) {
    const double heading = 0.5 * (lines[i].heading_deg + lines[i + 1].heading_deg);
    const double width = (lines[i + 1].x_ref - lines[i].x_ref) * std::cos(heading / kRadToDeg);
    if (width < options_.min_lane_width_m || width > options_.max_lane_width_m) continue;
    const double centre = std::abs(0.5 * (lines[i].x_ref + lines[i + 1].x_ref));
    if (centre < best_centre) {
      best_centre = centre;
      best = static_cast<int>(i);
      best_width = width;
    }
  }
  if (best < 0) return;
  const ChordLine& l = lines[static_cast<size_t>(best)];
  const ChordLine& r = lines[static_cast<size_t>(best) + 1];
  heading_deg_.push_back(0.5 * (l.heading_deg + r.heading_deg));
  divergence_deg_.push_back(r.heading_deg - l.heading_deg);
  width_m_.push_back(best_width);
}

LaneGeometryReport LaneGeometryCheck::Report() const {
  LaneGeometryReport r;
  r.frames = frames_;
  r.frames_with_pair = static_cast<int>(heading_deg_.size());
  r.heading_deg = Median(heading_deg_);
  r.divergence_deg = Median(divergence_deg_);
  r.width_m = Median(width_m_);
  const LaneGeometryCheckOptions& o = options_;
  const int needed =
      std::max(o.min_frames,
               static_cast<int>(std::ceil(o.min_pair_fraction * static_cast<double>(frames_))));
  if (r.frames_with_pair < needed) {
    r.verdict = absl::FailedPreconditionError(absl::StrFormat(
        "with this camera the detector finds neighbouring lanes %.1f-%.1f m apart in only %d of "
        "%d frames (at least %d needed): its top view does not show the road's lanes, so the "
        "vanishing point is probably wrong",
        o.min_lane_width_m, o.max_lane_width_m, r.frames_with_pair, r.frames, needed));
  } else if (std::abs(r.heading_deg) > o.max_heading_deg) {
    r.verdict = absl::FailedPreconditionError(absl::StrFormat(
        "with this camera the lanes point %.2f deg %s of straight ahead on the ground (at most "
        "%.2f allowed): a yaw error of about that much",
        std::abs(r.heading_deg), r.heading_deg > 0 ? "right" : "left", o.max_heading_deg));
  } else if (std::abs(r.divergence_deg) > o.max_divergence_deg) {
    r.verdict = absl::FailedPreconditionError(absl::StrFormat(
        "with this camera neighbouring lanes %s by %.2f deg on the ground (at most %.2f "
        "allowed): a pitch error",
        r.divergence_deg > 0 ? "diverge" : "converge", std::abs(r.divergence_deg),
        o.max_divergence_deg));
  }
  return r;
}

}  // namespace lane
