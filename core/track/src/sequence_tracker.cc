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
  std::vector<Entry> entries(lanes.size());
  for (size_t i = 0; i < lanes.size(); ++i) {
    TrackedLane& tracked = entries[i].lane;
    tracked.lane = lanes[i];
    tracked.id = ids[i].id;
    tracked.confirmed = ids[i].confirmed;
    tracked.color = ids[i].color;
    tracked.type = ids[i].type;
    entries[i].identity = ids[i];
  }
  if (ipm != nullptr) {
    entries = SortedLeftToRight(WithCoasting(DrawFiltered(std::move(entries), *ipm), *ipm));
  }
  Frame frame;
  frame.ego = EgoOfConfirmed(entries);
  frame.lanes.reserve(entries.size());
  for (Entry& entry : entries) frame.lanes.push_back(std::move(entry.lane));
  return frame;
}

std::vector<SequenceTracker::Entry> SequenceTracker::DrawFiltered(std::vector<Entry> entries,
                                                                  const IpmMapping& ipm) const {
  if (!lanes_.options().report_filtered) return entries;
  for (Entry& entry : entries) {
    if (!entry.identity.confirmed) continue;
    const std::optional<Lane> filtered = LaneFromCurve(entry.identity.curve, ipm);
    if (!filtered) continue;
    entry.lane.lane.image = filtered->image;
    entry.lane.lane.ground = filtered->ground;
    entry.lane.lane.ipm = filtered->ipm;
  }
  return entries;
}

std::vector<SequenceTracker::Entry> SequenceTracker::WithCoasting(std::vector<Entry> entries,
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
    for (size_t i = 0; i < entries.size() && !found; ++i) {
      const LaneIdentity& other_identity = entries[i].identity;
      if (other_identity.id < 0) continue;
      const double distance = LateralDistance(track.curve, other_identity.curve);
      if (distance >= o.coast_clearance_m) continue;
      const lane::Track* other = nullptr;
      for (const lane::Track& t : lanes_.tracks()) {
        if (t.id == other_identity.id) other = &t;
      }
      const bool coexisted = other != nullptr && other->born_frame <= track.last_hit_frame;
      found = !(coexisted && distance >= o.duplicate_m);
    }
    if (found) continue;
    std::optional<Lane> lane = LaneFromCurve(track.curve, ipm);
    if (!lane) continue;
    Entry predicted;
    predicted.identity = IdentityOf(track);
    predicted.lane.lane = *lane;
    predicted.lane.id = predicted.identity.id;
    predicted.lane.confirmed = true;
    predicted.lane.predicted = true;
    predicted.lane.color = predicted.identity.color;
    predicted.lane.type = predicted.identity.type;
    entries.push_back(std::move(predicted));
  }
  return entries;
}

std::vector<SequenceTracker::Entry> SequenceTracker::SortedLeftToRight(std::vector<Entry> entries) {
  auto key = [](const Entry& e) {
    const GroundCurve& curve = e.identity.curve;
    return e.identity.id >= 0 ? curve.X(0.5 * (curve.y_near + curve.y_far))
                              : 0.5 * (e.lane.lane.ground[0].x() + e.lane.lane.ground[3].x());
  };
  std::stable_sort(entries.begin(), entries.end(),
                   [&](const Entry& a, const Entry& b) { return key(a) < key(b); });
  return entries;
}

std::optional<EgoLane> SequenceTracker::EgoOfConfirmed(const std::vector<Entry>& entries) {
  // The ego lane from the confirmed lanes' filtered curves only: a
  // one-frame streak on a car does not bound it, and the filter steadies
  // the offset whose rate warns of a departure.
  std::vector<std::optional<GroundCurve>> curves(entries.size());
  std::vector<int> track_ids(entries.size(), -1);
  std::vector<Eigen::Matrix3d> covariances(entries.size(), Eigen::Matrix3d::Identity());
  for (size_t i = 0; i < entries.size(); ++i) {
    const LaneIdentity& identity = entries[i].identity;
    if (!identity.confirmed) continue;
    curves[i] = identity.curve;
    track_ids[i] = identity.id;
    covariances[i] = identity.covariance;
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
