#include "lane/track/sequence_tracker.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace lane {
namespace {

// A lane drawn from a track's curve over its last extent, near end first
// (none when it does not project into the image).
std::optional<Lane> LaneFromCurve(const GroundCurve& curve, const IpmMapping& ipm) {
  return LaneAlongCurve(curve, ipm, /*near_first=*/true);
}

}  // namespace

SequenceTracker::Frame SequenceTracker::Track(const std::vector<Lane>& lanes,
                                              const std::vector<Marking>& markings,
                                              std::optional<double> time_s, const IpmMapping* ipm) {
  std::vector<MarkingColor> colors(lanes.size(), MarkingColor::kUnknown);
  std::vector<MarkingType> types(lanes.size(), MarkingType::kUnknown);
  for (size_t i = 0; i < lanes.size() && i < markings.size(); ++i) {
    colors[i] = markings[i].color;
    types[i] = markings[i].type;
  }
  const std::vector<LaneIdentity> ids = lanes_.Update(lanes, time_s, colors, types);
  Frame frame;
  frame.lanes.reserve(lanes.size());
  for (size_t i = 0; i < lanes.size(); ++i) {
    TrackedLane& tracked = frame.lanes.emplace_back();
    tracked.lane = lanes[i];
    tracked.id = ids[i].id;
    tracked.confirmed = ids[i].confirmed;
    tracked.color = ids[i].color;
    tracked.type = ids[i].type;
  }
  std::vector<LaneIdentity> all = ids;
  if (ipm != nullptr) {
    DrawFiltered(frame.lanes, ids, *ipm);
    AddCoasting(frame.lanes, all, *ipm);
    SortLeftToRight(frame.lanes, all);
  }
  frame.ego = EgoOfConfirmed(all);
  return frame;
}

void SequenceTracker::DrawFiltered(std::vector<TrackedLane>& lanes,
                                   const std::vector<LaneIdentity>& ids,
                                   const IpmMapping& ipm) const {
  for (size_t i = 0; i < lanes.size() && lanes_.options().report_filtered; ++i) {
    if (!ids[i].confirmed) continue;
    const std::optional<Lane> filtered = LaneFromCurve(ids[i].curve, ipm);
    if (!filtered) continue;
    lanes[i].lane.image = filtered->image;
    lanes[i].lane.ground = filtered->ground;
    lanes[i].lane.ipm = filtered->ipm;
  }
}

void SequenceTracker::AddCoasting(std::vector<TrackedLane>& lanes, std::vector<LaneIdentity>& all,
                                  const IpmMapping& ipm) const {
  const LaneTrackingOptions& o = lanes_.options();
  for (const lane::Track& track : lanes_.tracks()) {
    if (!track.Reported() || track.misses < 1 || track.misses > o.coast_frames) continue;
    // Not when a lane of this frame lies near it: the boundary was found
    // (by another track); reporting both would draw it twice. A lane
    // farther than duplicate_m whose track was already there when this
    // one was last seen is another boundary (the asphalt's edge beside a
    // solid line) and does not stand in for it.
    bool found = false;
    for (size_t i = 0; i < lanes.size() && !found; ++i) {
      if (all[i].id < 0) continue;
      const double distance = LateralDistance(track.curve, all[i].curve);
      if (distance >= o.coast_clearance_m) continue;
      const lane::Track* other = nullptr;
      for (const lane::Track& t : lanes_.tracks()) {
        if (t.id == all[i].id) other = &t;
      }
      const bool coexisted = other != nullptr && other->born_frame <= track.last_hit_frame;
      found = !(coexisted && distance >= o.duplicate_m);
    }
    if (found) continue;
    std::optional<Lane> lane = LaneFromCurve(track.curve, ipm);
    if (!lane) continue;
    const LaneIdentity identity = IdentityOf(track);
    TrackedLane predicted;
    predicted.lane = *lane;
    predicted.id = identity.id;
    predicted.confirmed = true;
    predicted.predicted = true;
    predicted.color = identity.color;
    predicted.type = identity.type;
    lanes.push_back(std::move(predicted));
    all.push_back(identity);
  }
}

void SequenceTracker::SortLeftToRight(std::vector<TrackedLane>& lanes,
                                      std::vector<LaneIdentity>& all) const {
  std::vector<size_t> order(lanes.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  auto key = [&](size_t i) {
    return all[i].id >= 0 ? all[i].curve.X(0.5 * (all[i].curve.y_near + all[i].curve.y_far))
                          : 0.5 * (lanes[i].lane.ground[0].x() + lanes[i].lane.ground[3].x());
  };
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return key(a) < key(b); });
  std::vector<TrackedLane> sorted_lanes;
  std::vector<LaneIdentity> sorted_ids;
  for (size_t i : order) {
    sorted_lanes.push_back(std::move(lanes[i]));
    sorted_ids.push_back(all[i]);
  }
  lanes = std::move(sorted_lanes);
  all = std::move(sorted_ids);
}

std::optional<EgoLane> SequenceTracker::EgoOfConfirmed(const std::vector<LaneIdentity>& all) {
  // The ego lane from the confirmed lanes' filtered curves only: a
  // one-frame streak on a car does not bound it, and the filter steadies
  // the offset whose rate warns of a departure.
  std::vector<std::optional<GroundCurve>> curves(all.size());
  std::vector<int> track_ids(all.size(), -1);
  std::vector<Eigen::Matrix3d> covariances(all.size(), Eigen::Matrix3d::Identity());
  for (size_t i = 0; i < all.size(); ++i) {
    if (!all[i].confirmed) continue;
    curves[i] = all[i].curve;
    track_ids[i] = all[i].id;
    covariances[i] = all[i].covariance;
  }
  std::optional<EgoLane> ego =
      EgoLaneOfCurves(curves, track_ids, camera_, ego_options_, &covariances);
  if (lanes_.resets() != resets_seen_) {
    ego_.Reset();
    resets_seen_ = lanes_.resets();
  }
  return ego_.Update(std::move(ego), lanes_.time_s());
}

DetectionPrior SequenceTracker::Prior(const IpmMapping& ipm) const {
  DetectionPrior prior;
  const LaneTrackingOptions& o = lanes_.options();
  const double dt = 1.0 / std::max(1e-3, o.default_fps);
  for (const lane::Track& track : lanes_.tracks()) {
    if (!track.Reported()) continue;
    const double y0 = std::max(track.curve.y_near, ipm.y_min());
    const double y1 = std::min(track.curve.y_far, ipm.y_max());
    if (y1 - y0 < 1.0) continue;  // hardly in the view
    const Eigen::Vector2d a = ipm.GroundToIpm({track.curve.X(y0), y0});
    const Eigen::Vector2d b = ipm.GroundToIpm({track.curve.X(y1), y1});
    if (!a.allFinite() || !b.allFinite() || std::abs(a.y() - b.y()) < 1.0) continue;
    const std::optional<IpmLine> line = MakeIpmLine(a, b - a, ipm.height());
    if (!line) continue;
    DetectionPrior::Window w;
    w.line = *line;
    // The predicted lateral position's sd at mid extent, one frame on.
    const double ym = 0.5 * (y0 + y1);
    const Eigen::Vector3d j(1.0, ym, 0.5 * ym * ym);
    const double var =
        j.dot(track.covariance * j) + o.offset_noise * o.offset_noise * dt * (1 + track.misses);
    w.half_width_m = 0.3 + 2.5 * std::sqrt(std::max(0.0, var));
    w.curve = track.curve;
    w.refit = track.misses == 0;
    prior.windows.push_back(w);
  }
  return prior;
}

void SequenceTracker::Reset() {
  lanes_.Reset();
  ego_.Reset();
}

}  // namespace lane
