#include "wire/tracker_state_proto.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <limits>

#include "absl/strings/str_cat.h"
#include "lane/v1/lane_service.pb.h"

namespace lane::wire {
namespace {

constexpr int kCurveFields = 5;       // offset, heading, curvature, y_near, y_far
constexpr int kCovarianceFields = 6;  // upper triangle of 3x3
constexpr int kVoteFields = 7;        // white, yellow, 5 types

// (row, column) of the encoded covariance's elements.
constexpr int kUpper[kCovarianceFields][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};

Eigen::Matrix3d AsFloats(const Eigen::Matrix3d& p) { return p.cast<float>().cast<double>(); }

bool PositiveDefinite(const Eigen::Matrix3d& p) {
  const Eigen::Matrix3d sym = 0.5 * (p + p.transpose());
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(sym, Eigen::EigenvaluesOnly)
             .eigenvalues()
             .minCoeff() > 0;
}

// A saturating conversion: counters of a state stay in range on the wire.
uint32_t ToU32(int64_t v) {
  return static_cast<uint32_t>(std::clamp<int64_t>(v, 0, std::numeric_limits<uint32_t>::max()));
}

}  // namespace

std::string EncodeTrackerState(const lane::TrackerState& state) {
  v1::TrackerState out;
  out.set_version(state.version);
  out.set_lineage(state.lineage);
  out.set_frames(state.frames);
  out.set_next_id(ToU32(state.next_id));
  out.set_started(state.started);
  out.set_time_s(state.time_s);
  if (state.refits_in_row) out.set_refits_in_row(ToU32(*state.refits_in_row));
  for (const lane::TrackSnapshot& t : state.tracks) {
    v1::TrackedLane* lane = out.add_tracks();
    lane->set_id(ToU32(t.id));
    lane->set_confirmed(t.confirmed);
    lane->set_hits(ToU32(t.hits));
    lane->set_misses(ToU32(t.misses));
    lane->set_age_frames(static_cast<uint64_t>(std::max<int64_t>(0, t.age_frames)));
    lane->set_since_hit_frames(static_cast<uint64_t>(std::max<int64_t>(0, t.since_hit_frames)));
    for (int k = 0; k < 3; ++k) lane->add_curve(static_cast<float>(t.curve.coefficients(k)));
    lane->add_curve(static_cast<float>(t.curve.y_near));
    lane->add_curve(static_cast<float>(t.curve.y_far));
    Eigen::Matrix3d p = 0.5 * (t.covariance + t.covariance.transpose());
    for (int tries = 0; tries < 8 && !PositiveDefinite(AsFloats(p)) && p.trace() > 0; ++tries) {
      p += Eigen::Matrix3d::Identity() * (1e-6 * p.trace());
    }
    for (const auto& rc : kUpper) lane->add_covariance(static_cast<float>(p(rc[0], rc[1])));
    lane->add_votes(static_cast<float>(t.white_votes));
    lane->add_votes(static_cast<float>(t.yellow_votes));
    for (double v : t.type_votes) lane->add_votes(static_cast<float>(v));
  }
  return out.SerializeAsString();
}

absl::StatusOr<lane::TrackerState> DecodeTrackerState(std::string_view bytes) {
  if (bytes.size() > kMaxResumeStateBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("resume state: ", bytes.size(), " bytes, more than ", kMaxResumeStateBytes));
  }
  v1::TrackerState in;
  if (!in.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) {
    return absl::InvalidArgumentError("resume state: not a lane.v1.TrackerState");
  }
  if (static_cast<size_t>(in.tracks_size()) > lane::TrackerState::kMaxTracks) {
    return absl::InvalidArgumentError(absl::StrCat(
        "resume state: ", in.tracks_size(), " tracks, more than ", lane::TrackerState::kMaxTracks));
  }
  lane::TrackerState state;
  state.version = in.version();
  state.lineage = in.lineage();
  state.frames = in.frames();
  // Out-of-range values fail validation rather than wrap.
  state.next_id =
      static_cast<int>(std::min<uint32_t>(in.next_id(), lane::TrackerState::kMaxId + 1u));
  state.started = in.started();
  state.time_s = in.time_s();
  // Out-of-range counts fail validation rather than wrap.
  if (in.has_refits_in_row()) {
    state.refits_in_row = static_cast<int>(std::min<uint32_t>(in.refits_in_row(), 1u << 30));
  }
  constexpr uint64_t kBig = uint64_t{1} << 62;
  for (int i = 0; i < in.tracks_size(); ++i) {
    const v1::TrackedLane& lane = in.tracks(i);
    if (lane.curve_size() != kCurveFields || lane.covariance_size() != kCovarianceFields ||
        lane.votes_size() != kVoteFields) {
      return absl::InvalidArgumentError(absl::StrCat(
          "resume state: tracks[", i, "] has ", lane.curve_size(), " curve, ",
          lane.covariance_size(), " covariance and ", lane.votes_size(), " vote values, not ",
          kCurveFields, ", ", kCovarianceFields, " and ", kVoteFields));
    }
    lane::TrackSnapshot t;
    t.id = static_cast<int>(std::min<uint32_t>(lane.id(), lane::TrackerState::kMaxId + 1u));
    t.confirmed = lane.confirmed();
    t.hits = static_cast<int>(std::min<uint32_t>(lane.hits(), 1u << 30));
    t.misses = static_cast<int>(std::min<uint32_t>(lane.misses(), 1u << 30));
    t.age_frames = static_cast<int64_t>(std::min(lane.age_frames(), kBig));
    t.since_hit_frames = static_cast<int64_t>(std::min(lane.since_hit_frames(), kBig));
    for (int k = 0; k < 3; ++k) t.curve.coefficients(k) = lane.curve(k);
    t.curve.y_near = lane.curve(3);
    t.curve.y_far = lane.curve(4);
    for (int k = 0; k < kCovarianceFields; ++k) {
      t.covariance(kUpper[k][0], kUpper[k][1]) = lane.covariance(k);
      t.covariance(kUpper[k][1], kUpper[k][0]) = lane.covariance(k);
    }
    t.white_votes = lane.votes(0);
    t.yellow_votes = lane.votes(1);
    for (size_t k = 0; k < t.type_votes.size(); ++k) {
      t.type_votes[k] = lane.votes(static_cast<int>(k) + 2);
    }
    state.tracks.push_back(t);
  }
  if (absl::Status valid = lane::ValidateTrackerState(state); !valid.ok()) return valid;
  return state;
}

}  // namespace lane::wire
