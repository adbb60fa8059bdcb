// The resume state on the wire (wire/tracker_state_proto.h): what a tracker
// writes decodes to the same state, within float precision, at any size the
// tracker can reach, under the 4096-byte bound.
#include "wire/tracker_state_proto.h"

#include <gtest/gtest.h>

#include <cmath>

#include "lane/v1/lane_service.pb.h"

namespace lane::wire {
namespace {

lane::TrackerState StateWith(int tracks) {
  lane::TrackerState state;
  state.lineage = 0x0123456789abcdefULL;
  state.frames = 123456;
  state.next_id = 1000000;
  state.started = true;
  state.time_s = 1.7e9 + 0.033;
  if (tracks % 2 == 1) state.refits_in_row = 2;  // unset on the others
  for (int i = 0; i < tracks; ++i) {
    lane::TrackSnapshot t;
    t.id = 999000 + i;
    t.confirmed = i % 2 == 0;
    t.hits = 100000 + i;
    t.misses = i % 5;
    t.age_frames = 200000;
    t.since_hit_frames = i % 5;
    t.curve.coefficients << -20.0 + 1.3 * i, 0.0123, -0.00042;
    t.curve.y_near = 3.5;
    t.curve.y_far = 48.25;
    // Strongly correlated, as a tracker's are after many frames.
    t.covariance << 1e-3, -4e-5, 1e-6, -4e-5, 2.0e-6, -5e-8, 1e-6, -5e-8, 1.5e-9;
    t.white_votes = 1234.5;
    t.yellow_votes = 0.25;
    t.type_votes = {0.0, 3.9, 1.2, 0.0, 0.5};
    state.tracks.push_back(t);
  }
  return state;
}

TEST(TrackerStateProtoTest, RoundTripsAtEverySizeUnderTheBound) {
  for (int n : {0, 1, 6, static_cast<int>(lane::TrackerState::kMaxTracks)}) {
    const lane::TrackerState state = StateWith(n);
    ASSERT_TRUE(lane::ValidateTrackerState(state).ok()) << lane::ValidateTrackerState(state);
    const std::string bytes = EncodeTrackerState(state);
    EXPECT_LE(bytes.size(), kMaxResumeStateBytes) << n << " tracks";
    absl::StatusOr<lane::TrackerState> back = DecodeTrackerState(bytes);
    ASSERT_TRUE(back.ok()) << n << " tracks: " << back.status();
    EXPECT_EQ(back->lineage, state.lineage);
    EXPECT_EQ(back->frames, state.frames);
    EXPECT_EQ(back->next_id, state.next_id);
    EXPECT_DOUBLE_EQ(back->time_s, state.time_s);
    EXPECT_EQ(back->refits_in_row, state.refits_in_row);
    ASSERT_EQ(back->tracks.size(), state.tracks.size());
    for (size_t i = 0; i < state.tracks.size(); ++i) {
      const lane::TrackSnapshot& a = state.tracks[i];
      const lane::TrackSnapshot& b = back->tracks[i];
      EXPECT_EQ(b.id, a.id);
      EXPECT_EQ(b.confirmed, a.confirmed);
      EXPECT_EQ(b.hits, a.hits);
      EXPECT_EQ(b.misses, a.misses);
      EXPECT_EQ(b.age_frames, a.age_frames);
      EXPECT_EQ(b.since_hit_frames, a.since_hit_frames);
      EXPECT_NEAR(b.curve.coefficients(0), a.curve.coefficients(0), 1e-5);
      EXPECT_NEAR(b.curve.coefficients(2), a.curve.coefficients(2), 1e-9);
      EXPECT_TRUE(b.covariance.isApprox(a.covariance, 1e-5));
      EXPECT_NEAR(b.type_votes[1], a.type_votes[1], 1e-6);
    }
  }
  // 32 tracks is the most a tracker writes (LaneTracker::Snapshot).
  std::printf("resume state: %zu bytes with 6 tracks, %zu with %zu\n",
              EncodeTrackerState(StateWith(6)).size(),
              EncodeTrackerState(StateWith(lane::TrackerState::kMaxTracks)).size(),
              lane::TrackerState::kMaxTracks);
}

TEST(TrackerStateProtoTest, ACovarianceThatFloatsWouldBreakStaysPositiveDefinite) {
  lane::TrackerState state = StateWith(1);
  // Nearly singular: offset and heading almost perfectly correlated.
  state.tracks[0].covariance << 1.0, 0.1, 0.0, 0.1, 0.0100000001, 0.0, 0.0, 0.0, 1e-9;
  ASSERT_TRUE(lane::ValidateTrackerState(state).ok());
  EXPECT_TRUE(DecodeTrackerState(EncodeTrackerState(state)).ok());
}

TEST(TrackerStateProtoTest, OutOfRangeNumbersAreRefusedNotWrapped) {
  v1::TrackerState proto;
  ASSERT_TRUE(proto.ParseFromString(EncodeTrackerState(StateWith(1))));
  proto.set_next_id(0xffffffffu);
  EXPECT_FALSE(DecodeTrackerState(proto.SerializeAsString()).ok());
  ASSERT_TRUE(proto.ParseFromString(EncodeTrackerState(StateWith(1))));
  proto.mutable_tracks(0)->set_id(0x80000000u);
  EXPECT_FALSE(DecodeTrackerState(proto.SerializeAsString()).ok());
  ASSERT_TRUE(proto.ParseFromString(EncodeTrackerState(StateWith(1))));
  proto.mutable_tracks(0)->set_age_frames(~uint64_t{0});
  EXPECT_FALSE(DecodeTrackerState(proto.SerializeAsString()).ok());
  EXPECT_FALSE(DecodeTrackerState(std::string(4097, 'x')).ok());
}

}  // namespace
}  // namespace lane::wire
