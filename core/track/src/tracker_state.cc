#include "lane/track/tracker_state.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <set>
#include <string>

#include "absl/strings/str_cat.h"

namespace lane {
namespace {

// Bounds of a plausible state. Generous: they only keep numbers that no
// tracker writes out of the arithmetic.
constexpr double kMaxMetres = 1000.0;      // offsets and extents
constexpr double kMaxHeading = 5.7;        // tan(80 deg)
constexpr double kMaxCurvature = 1.0;      // 1/m: a 1 m radius
constexpr double kMaxVariance = 1e6;       // any covariance element
constexpr double kMaxVotes = 1e9;          // colour and type votes
constexpr int64_t kMaxFrames = 1LL << 40;  // counters and ages
// A tracker refits at most LaneTrackingOptions::refit_frames frames in a
// row (a handful); anything far beyond is not a tracker's.
constexpr int kMaxRefitsInRow = 1000;
constexpr double kMaxTimeS = 1e12;  // s: Unix time in 33,000 years

absl::Status Bad(const std::string& field, const std::string& why) {
  return absl::InvalidArgumentError(absl::StrCat("resume state: ", field, " ", why));
}

bool Finite(double v) { return std::isfinite(v); }

absl::Status ValidateTrack(const TrackSnapshot& t, const TrackerState& state,
                           const std::string& name) {
  if (t.id < 1 || t.id >= state.next_id) {
    return Bad(name + ".id", absl::StrCat(t.id, " is not in [1, next_id = ", state.next_id, ")"));
  }
  // hits and misses are ints: never beyond kMaxFrames.
  if (t.hits < 1 || t.misses < 0) {
    return Bad(name, absl::StrCat("has hits ", t.hits, " and misses ", t.misses));
  }
  if (t.age_frames < 0 || t.age_frames > kMaxFrames || t.since_hit_frames < 0 ||
      t.since_hit_frames > t.age_frames) {
    return Bad(name, absl::StrCat("has age ", t.age_frames, " and frames since its last hit ",
                                  t.since_hit_frames));
  }
  const Eigen::Vector3d& c = t.curve.coefficients;
  if (!c.allFinite() || std::abs(c(0)) > kMaxMetres || std::abs(c(1)) > kMaxHeading ||
      std::abs(c(2)) > kMaxCurvature) {
    return Bad(name + ".curve", "is not a lane on a road (offset, heading, curvature)");
  }
  if (!Finite(t.curve.y_near) || !Finite(t.curve.y_far) || t.curve.y_near > t.curve.y_far ||
      std::abs(t.curve.y_near) > kMaxMetres || std::abs(t.curve.y_far) > kMaxMetres) {
    return Bad(name + ".curve", "has no extent [y_near, y_far] within 1 km");
  }
  const Eigen::Matrix3d& p = t.covariance;
  if (!p.allFinite() || p.cwiseAbs().maxCoeff() > kMaxVariance || !p.isApprox(p.transpose())) {
    return Bad(name + ".covariance", "is not a finite symmetric matrix");
  }
  const Eigen::Vector3d eigen =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(p, Eigen::EigenvaluesOnly).eigenvalues();
  if (!(eigen.minCoeff() > 0)) return Bad(name + ".covariance", "is not positive definite");
  const auto vote_ok = [](double v) { return Finite(v) && v >= 0 && v <= kMaxVotes; };
  bool votes_ok = vote_ok(t.white_votes) && vote_ok(t.yellow_votes);
  for (double v : t.type_votes) votes_ok = votes_ok && vote_ok(v);
  if (!votes_ok) return Bad(name + ".votes", "are not finite counts");
  return absl::OkStatus();
}

}  // namespace

absl::Status ValidateTrackerState(const TrackerState& state) {
  if (state.version != TrackerState::kVersion) {
    return Bad("version", absl::StrCat(state.version, " is not ", TrackerState::kVersion,
                                       " (a state of another server version)"));
  }
  if (state.next_id < 1 || state.next_id > TrackerState::kMaxId) {
    return Bad("next_id",
               absl::StrCat(state.next_id, " is not in [1, ", TrackerState::kMaxId, "]"));
  }
  if (state.frames > static_cast<uint64_t>(kMaxFrames)) return Bad("frames", "is too large");
  if (state.refits_in_row && (*state.refits_in_row < 0 || *state.refits_in_row > kMaxRefitsInRow)) {
    return Bad("refits_in_row",
               absl::StrCat(*state.refits_in_row, " is not in [0, ", kMaxRefitsInRow, "]"));
  }
  if (!Finite(state.time_s) || std::abs(state.time_s) > kMaxTimeS) {
    return Bad("time_s", "is not a finite time");
  }
  if (state.tracks.size() > TrackerState::kMaxTracks) {
    return Bad("tracks", absl::StrCat("has ", state.tracks.size(), " tracks, more than ",
                                      TrackerState::kMaxTracks));
  }
  if (!state.started && !state.tracks.empty()) {
    return Bad("tracks", "are set on a tracker that has seen no frame");
  }
  std::set<int> ids;
  for (size_t i = 0; i < state.tracks.size(); ++i) {
    const std::string name = absl::StrCat("tracks[", i, "]");
    if (absl::Status s = ValidateTrack(state.tracks[i], state, name); !s.ok()) return s;
    if (!ids.insert(state.tracks[i].id).second) {
      return Bad(name + ".id", absl::StrCat(state.tracks[i].id, " is used twice"));
    }
  }
  return absl::OkStatus();
}

}  // namespace lane
