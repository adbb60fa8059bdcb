#include "lane/track/lane_tracker.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <tuple>

namespace lane {
namespace {

// Kalman update of a track with a detected lane: the measurement is the
// lane's lateral position at points spread over its extent, each with
// standard deviation measured_x_sd + measured_x_sd_per_m * y, so that a
// short lane says little of the curvature and the heading it implies at
// the camera. Robust (Huber): a point whose innovation lies more than
// huber_k standard deviations from the prediction has its variance scaled
// by |r| / huber_k, so that it pulls the track as if it lay huber_k
// standard deviations off (one pass, the points taken one by one: a
// spline that runs off at its far end, across a dash and a stain).
void KalmanUpdate(const Lane& lane, const LaneTrackingOptions& options, Track* track) {
  constexpr int kPoints = 6;
  const std::vector<Eigen::Vector2d> pts = GroundBezier(lane).Sample(kPoints);
  Eigen::Matrix<double, kPoints, 3> h;
  Eigen::Matrix<double, kPoints, 1> z;
  for (int i = 0; i < kPoints; ++i) {
    const double y = pts[static_cast<size_t>(i)].y();
    h.row(i) << 1.0, y, 0.5 * y * y;
    z(i) = pts[static_cast<size_t>(i)].x();
  }
  if (!h.allFinite() || !z.allFinite()) return;
  const Eigen::Matrix3d& p = track->covariance;
  const Eigen::Matrix<double, kPoints, 1> innovation = z - h * track->curve.coefficients;
  Eigen::Matrix<double, kPoints, kPoints> s = h * p * h.transpose();
  for (int i = 0; i < kPoints; ++i) {
    const double e = options.measured_x_sd + options.measured_x_sd_per_m * std::max(0.0, h(i, 1));
    double variance = e * e;
    if (options.huber_k > 0) {
      const double r = std::abs(innovation(i)) / std::sqrt(s(i, i) + variance);
      if (r > options.huber_k) variance *= r / options.huber_k;
    }
    s(i, i) += variance;
  }
  const Eigen::Matrix<double, 3, kPoints> gain = p * h.transpose() * s.inverse();
  track->curve.coefficients += gain * innovation;
  track->covariance = (Eigen::Matrix3d::Identity() - gain * h) * p;
}

}  // namespace

LaneIdentity IdentityOf(const Track& track) {
  LaneIdentity out;
  out.id = track.id;
  out.confirmed = track.Reported();
  out.curve = track.curve;
  out.covariance = track.covariance;
  const std::array<double, 5>& v = track.type_votes;
  const double solid = v[static_cast<size_t>(MarkingType::kSolid)];
  const double dashed = v[static_cast<size_t>(MarkingType::kDashed)];
  size_t best = 0;
  for (size_t k = 1; k < v.size(); ++k) {
    if (v[k] > v[best]) best = k;
  }
  out.type = v[best] > 0 ? static_cast<MarkingType>(best) : MarkingType::kUnknown;
  if ((out.type == MarkingType::kSolid || out.type == MarkingType::kDashed) && dashed > 0 &&
      dashed >= 0.3 * (solid + dashed)) {
    out.type = MarkingType::kDashed;
  }
  if (track.yellow_votes > track.white_votes) {
    out.color = MarkingColor::kYellow;
  } else if (track.white_votes > track.yellow_votes) {
    out.color = MarkingColor::kWhite;
  }
  return out;
}

LaneTracker::LaneTracker(LaneTrackingOptions options) : options_(options) {}

void LaneTracker::Reset() {
  tracks_.clear();
  started_ = false;
  ++resets_;
}

TrackerState LaneTracker::Snapshot() const {
  TrackerState state;
  state.next_id = next_id_;
  state.started = started_;
  state.time_s = time_s_;
  std::vector<const Track*> kept;
  for (const Track& t : tracks_) kept.push_back(&t);
  if (kept.size() > TrackerState::kMaxTracks) {
    std::stable_sort(kept.begin(), kept.end(),
                     [](const Track* a, const Track* b) { return a->hits > b->hits; });
    kept.resize(TrackerState::kMaxTracks);
  }
  for (const Track* t : kept) {
    TrackSnapshot s;
    s.id = t->id;
    s.confirmed = t->confirmed;
    s.hits = t->hits;
    s.misses = t->misses;
    s.age_frames = frame_ - t->born_frame;
    s.since_hit_frames = frame_ - t->last_hit_frame;
    s.curve = t->curve;
    s.covariance = t->covariance;
    s.white_votes = t->white_votes;
    s.yellow_votes = t->yellow_votes;
    s.type_votes = t->type_votes;
    state.tracks.push_back(s);
  }
  return state;
}

void LaneTracker::Restore(const TrackerState& state) {
  tracks_.clear();
  ++resets_;
  next_id_ = std::max(next_id_, state.next_id);
  started_ = state.started;
  time_s_ = state.time_s;
  // Ages become frame numbers of this tracker's count (only their order
  // against each other and the frames to come matters).
  for (const TrackSnapshot& s : state.tracks) {
    Track t;
    t.id = s.id;
    t.confirmed = s.confirmed;
    t.hits = s.hits;
    t.misses = s.misses;
    t.born_frame = frame_ - s.age_frames;
    t.last_hit_frame = frame_ - s.since_hit_frames;
    t.curve = s.curve;
    // Symmetric exactly (the encoding keeps the upper triangle).
    t.covariance = 0.5 * (s.covariance + s.covariance.transpose());
    t.white_votes = s.white_votes;
    t.yellow_votes = s.yellow_votes;
    t.type_votes = s.type_votes;
    tracks_.push_back(t);
  }
  MarkParallel();
}

void LaneTracker::ReserveIdsBelow(int id) { next_id_ = std::max(next_id_, id); }

void LaneTracker::MarkParallel() {
  constexpr double kPi = 3.14159265358979323846;
  constexpr double kMinExtentM = 4.0;  // shorter pieces say little of a direction
  for (Track& t : tracks_) t.parallel = true;
  if (options_.parallel_max_deg <= 0) return;
  const double max_rad = options_.parallel_max_deg * kPi / 180.0;
  auto slope_at = [](const Track& t, double y) {
    return t.curve.coefficients(1) + t.curve.coefficients(2) * y;
  };
  std::vector<bool> parallel(tracks_.size(), true);
  for (size_t i = 0; i < tracks_.size(); ++i) {
    const Track& t = tracks_[i];
    const double ym = 0.5 * (t.curve.y_near + t.curve.y_far);
    std::vector<double> others;
    for (size_t k = 0; k < tracks_.size(); ++k) {
      const Track& o = tracks_[k];
      if (k == i || !o.confirmed || o.misses > 0 || o.curve.y_far - o.curve.y_near < kMinExtentM) {
        continue;
      }
      others.push_back(std::atan(slope_at(o, ym)));
    }
    if (others.size() < 2) continue;
    const auto mid = others.begin() + static_cast<std::ptrdiff_t>(others.size() / 2);
    std::nth_element(others.begin(), mid, others.end());
    double median = *mid;
    if (others.size() % 2 == 0) median = 0.5 * (median + *std::max_element(others.begin(), mid));
    parallel[i] = std::abs(std::atan(slope_at(t, ym)) - median) <= max_rad;
  }
  for (size_t i = 0; i < tracks_.size(); ++i) tracks_[i].parallel = parallel[i];
}

void LaneTracker::Predict(double dt) {
  const Eigen::Vector3d q(options_.offset_noise, options_.heading_noise, options_.curvature_noise);
  const Eigen::Matrix3d noise = (q.cwiseProduct(q) * dt).asDiagonal();
  for (Track& t : tracks_) t.covariance += noise;
}

std::vector<LaneIdentity> LaneTracker::Update(const std::vector<Lane>& lanes,
                                              std::optional<double> time_s,
                                              const std::vector<MarkingColor>& colors,
                                              const std::vector<MarkingType>& types) {
  const double dt = Advance(time_s);
  Predict(dt);
  FrameLanes frame{lanes, {}, colors, types};
  for (const Lane& lane : lanes) frame.curves.push_back(FitGroundCurve(lane));
  std::vector<int> track_of = Associate(frame);
  std::vector<bool> matched(tracks_.size(), false);
  for (int i : track_of) {
    if (i >= 0) matched[static_cast<size_t>(i)] = true;
  }
  // Type votes fade, so that a dashed line turning solid is followed.
  const double fade = std::exp(-dt / std::max(1e-3, options_.type_memory_s));
  for (Track& track : tracks_) {
    for (double& v : track.type_votes) v *= fade;
  }
  for (size_t j = 0; j < lanes.size(); ++j) {
    if (track_of[j] >= 0) UpdateTrack(tracks_[static_cast<size_t>(track_of[j])], frame, j);
  }
  for (size_t i = 0; i < matched.size(); ++i) {
    if (!matched[i]) ++tracks_[i].misses;
  }
  Spawn(frame, track_of);
  MergeDuplicates(frame, track_of);
  MarkParallel();
  std::vector<LaneIdentity> out(lanes.size());
  for (size_t j = 0; j < lanes.size(); ++j) {
    if (track_of[j] >= 0) out[j] = IdentityOf(tracks_[static_cast<size_t>(track_of[j])]);
  }
  Prune();
  return out;
}

double LaneTracker::Advance(std::optional<double> time_s) {
  const double frame_dt = 1.0 / std::max(1e-3, options_.default_fps);
  const double t = time_s.value_or(started_ ? time_s_ + frame_dt : 0.0);
  double dt = started_ ? t - time_s_ : frame_dt;
  if (started_ && (dt < 0 || dt > options_.max_gap_s)) {
    Reset();  // a new clip, or the camera was away too long
    dt = frame_dt;
  }
  started_ = true;
  ++frame_;
  time_s_ = t;
  return dt;
}

std::vector<int> LaneTracker::Associate(const FrameLanes& frame) const {
  std::vector<std::tuple<double, size_t, size_t>> pairs;
  for (size_t i = 0; i < tracks_.size(); ++i) {
    for (size_t j = 0; j < frame.curves.size(); ++j) {
      if (!frame.curves[j]) continue;
      const double cost = LateralDistance(tracks_[i].curve, *frame.curves[j]);
      if (cost < options_.gate_m) pairs.emplace_back(cost, i, j);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  std::vector<int> track_of(frame.lanes.size(), -1);
  std::vector<bool> matched(tracks_.size(), false);
  for (const auto& [cost, i, j] : pairs) {
    if (matched[i] || track_of[j] >= 0) continue;
    matched[i] = true;
    track_of[j] = static_cast<int>(i);
  }
  return track_of;
}

namespace {

// Lane j's colour and type votes go to `track`.
void Vote(Track& track, const std::vector<MarkingColor>& colors,
          const std::vector<MarkingType>& types, size_t j) {
  if (j < types.size() && types[j] != MarkingType::kUnknown) {
    track.type_votes[static_cast<size_t>(types[j])] += 1;
  }
  if (j >= colors.size()) return;
  if (colors[j] == MarkingColor::kWhite) track.white_votes += 1;
  if (colors[j] == MarkingColor::kYellow) track.yellow_votes += 1;
}

}  // namespace

void LaneTracker::UpdateTrack(Track& track, const FrameLanes& frame, size_t j) {
  KalmanUpdate(frame.lanes[j], options_, &track);
  track.curve.y_near = frame.curves[j]->y_near;
  track.curve.y_far = frame.curves[j]->y_far;
  ++track.hits;
  track.last_hit_frame = frame_;
  track.misses = 0;
  track.confirmed = track.confirmed || track.hits >= options_.confirm_frames;
  Vote(track, frame.colors, frame.types, j);
}

void LaneTracker::Spawn(const FrameLanes& frame, std::vector<int>& track_of) {
  for (size_t j = 0; j < frame.lanes.size(); ++j) {
    if (track_of[j] >= 0 || !frame.curves[j]) continue;
    Track track;
    track.id = next_id_++;
    track.born_frame = frame_;
    track.last_hit_frame = frame_;
    track.hits = 1;
    track.confirmed = options_.confirm_frames <= 1;
    // The prior: the lane's fitted offset and heading, loosely, and a
    // straight road; the first measurement then sets what it shows.
    track.curve = *frame.curves[j];
    track.curve.coefficients(2) = 0.0;
    const Eigen::Vector3d prior(options_.prior_offset_sd, options_.prior_heading_sd,
                                options_.prior_curvature_sd);
    track.covariance = prior.cwiseProduct(prior).asDiagonal();
    KalmanUpdate(frame.lanes[j], options_, &track);
    Vote(track, frame.colors, frame.types, j);
    tracks_.push_back(track);
    track_of[j] = static_cast<int>(tracks_.size()) - 1;
  }
}

void LaneTracker::MergeDuplicates(const FrameLanes& frame, std::vector<int>& track_of) {
  // A detection that left the gate for a frame started a second track, or
  // the boundary was missed.
  for (size_t a = 0; a < tracks_.size(); ++a) {
    for (size_t b = 0; b < tracks_.size(); ++b) {
      if (a == b || tracks_[a].misses >= options_.max_misses ||
          tracks_[b].misses >= options_.max_misses) {
        continue;
      }
      const bool b_weaker = tracks_[b].hits < tracks_[a].hits ||
                            (tracks_[b].hits == tracks_[a].hits && tracks_[b].id > tracks_[a].id);
      if (!b_weaker ||
          LateralDistance(tracks_[a].curve, tracks_[b].curve) >= options_.duplicate_m) {
        continue;
      }
      const auto ia = static_cast<int>(a), ib = static_cast<int>(b);
      const bool a_has_lane = std::find(track_of.begin(), track_of.end(), ia) != track_of.end();
      const bool b_has_lane = std::find(track_of.begin(), track_of.end(), ib) != track_of.end();
      // Both found in this frame: two boundaries close together (a lane
      // ending, a double line), not one boundary twice.
      if (a_has_lane && b_has_lane) continue;
      for (size_t j = 0; j < track_of.size(); ++j) {
        if (track_of[j] != ib) continue;
        track_of[j] = ia;
        UpdateTrack(tracks_[a], frame, j);
      }
      tracks_[b].misses = options_.max_misses;  // ends in Prune
    }
  }
}

void LaneTracker::Prune() {
  tracks_.erase(std::remove_if(tracks_.begin(), tracks_.end(),
                               [&](const Track& tr) { return tr.misses >= options_.max_misses; }),
                tracks_.end());
}

}  // namespace lane
