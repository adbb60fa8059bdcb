// Video-aware detection (lane/track/): the Kalman tracker, association,
// ids, the ego lane with departure, and the marking colour.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "lane/config/config.h"
#include "lane/detector/detector.h"
#include "lane/synthetic.h"
#include "lane/track/ego_lane.h"
#include "lane/track/frame_tracker.h"
#include "lane/track/lane_tracker.h"
#include "lane/track/marking_reader.h"
#include "lane/track/sequence_tracker.h"
#include "lane/track/tracker_state.h"
#include "tracking_test_util.h"

namespace lane {
namespace {

TEST(TrackingTest, GroundCurveFitIsExactForAParabola) {
  const std::optional<GroundCurve> c = FitGroundCurve(GroundLane(1.8, 0.02, 0.003));
  ASSERT_TRUE(c);
  EXPECT_NEAR(c->coefficients(0), 1.8, 1e-6);
  EXPECT_NEAR(c->coefficients(1), 0.02, 1e-7);
  EXPECT_NEAR(c->coefficients(2), 0.003, 1e-8);
  EXPECT_NEAR(c->y_near, 4.0, 1e-9);
  EXPECT_NEAR(c->y_far, 24.0, 1e-9);
}

TEST(TrackingTest, ConstantCurvatureLaneIsFollowedWithOneId) {
  LaneTracker tracker;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.08);
  int id = -1;
  for (int f = 0; f < 60; ++f) {
    const std::vector<LaneIdentity> out =
        tracker.Update({GroundLane(1.8 + noise(rng), 0.01, 0.002)}, f / 30.0);
    ASSERT_EQ(out.size(), 1u);
    if (f == 0) id = out[0].id;
    EXPECT_EQ(out[0].id, id) << "frame " << f;
    EXPECT_EQ(out[0].confirmed, f + 1 >= tracker.options().confirm_frames) << "frame " << f;
  }
  ASSERT_EQ(tracker.tracks().size(), 1u);
  const Eigen::Vector3d c = tracker.tracks()[0].curve.coefficients;
  EXPECT_NEAR(c(0), 1.8, 0.08);  // filtered: well inside the 8 cm noise
  EXPECT_NEAR(c(1), 0.01, 0.01);
  EXPECT_NEAR(c(2), 0.002, 0.001);
}

// The robust update (huber_k): a detection that agrees with the track is
// taken as by the plain Kalman filter, one whose far end runs off (a RANSAC
// draw across a dash and a stain) moves the track less.
TEST(TrackingTest, ARobustUpdateResistsASplineThatRunsOffAtItsFarEnd) {
  LaneTrackingOptions robust_options;
  ASSERT_GT(robust_options.huber_k, 0.0);
  LaneTrackingOptions plain_options = robust_options;
  plain_options.huber_k = 0.0;
  LaneTracker robust(robust_options), plain(plain_options);
  for (int f = 0; f < 30; ++f) {
    robust.Update({GroundLane(1.8, 0, 0)}, f / 30.0);
    plain.Update({GroundLane(1.8, 0, 0)}, f / 30.0);
  }
  ASSERT_EQ(robust.tracks().size(), 1u);
  ASSERT_EQ(plain.tracks().size(), 1u);
  EXPECT_LT((robust.tracks()[0].curve.coefficients - plain.tracks()[0].curve.coefficients).norm(),
            1e-9)
      << "detections that agree with the track are not down-weighted";
  // One frame: right at 4 m, 1 m off at 24 m (the plain filter follows it
  // 0.59 m at 20 m, the robust one 0.42 m).
  robust.Update({GroundLane(1.6, 0.05, 0)}, 1.0);
  plain.Update({GroundLane(1.6, 0.05, 0)}, 1.0);
  ASSERT_EQ(robust.tracks().size(), 1u);
  ASSERT_EQ(plain.tracks().size(), 1u);
  const double robust_far = robust.tracks()[0].curve.X(20.0) - 1.8;
  const double plain_far = plain.tracks()[0].curve.X(20.0) - 1.8;
  EXPECT_GT(plain_far, 0.05) << "the plain filter should follow the skewed fit part way";
  EXPECT_LT(robust_far, 0.8 * plain_far) << "robust " << robust_far << " m, plain " << plain_far;
  EXPECT_GE(robust_far, 0.0);
}

TEST(TrackingTest, AVanishedLaneEndsAfterMMissesAndItsIdIsNotReused) {
  LaneTrackingOptions o;
  LaneTracker tracker(o);
  int id = -1;
  for (int f = 0; f < 10; ++f) id = tracker.Update({GroundLane(-1.7, 0, 0)}, f / 30.0)[0].id;
  for (int miss = 1; miss < o.max_misses; ++miss) {
    tracker.Update({}, (10 + miss) / 30.0);
    EXPECT_EQ(tracker.tracks().size(), 1u) << "after " << miss << " misses";
  }
  tracker.Update({}, (10 + o.max_misses) / 30.0);
  EXPECT_TRUE(tracker.tracks().empty()) << "the track outlived " << o.max_misses << " misses";
  const std::vector<LaneIdentity> back = tracker.Update({GroundLane(-1.7, 0, 0)}, 0.6);
  EXPECT_NE(back[0].id, id);
  EXPECT_FALSE(back[0].confirmed);
}

TEST(TrackingTest, CrossingLanesKeepTheirIds) {
  // Two lanes forming an X on the road (crossing at y = 10 m), drifting.
  LaneTracker tracker;
  int a = -1, b = -1;
  for (int f = 0; f < 30; ++f) {
    const double d = 0.01 * f;
    const std::vector<LaneIdentity> out =
        tracker.Update({GroundLane(-1.0 + d, 0.1, 0), GroundLane(1.0 + d, -0.1, 0)}, f / 30.0);
    if (f == 0) {
      a = out[0].id;
      b = out[1].id;
      EXPECT_NE(a, b);
    }
    EXPECT_EQ(out[0].id, a) << "frame " << f;
    EXPECT_EQ(out[1].id, b) << "frame " << f;
  }
}

TEST(TrackingTest, MergingLanesAreAssociatedOneToOne) {
  // Two boundaries converging (a lane ending); the survivor keeps its id,
  // and while both are seen they never share one.
  LaneTracker tracker;
  int left = -1, right = -1;
  for (int f = 0; f < 40; ++f) {
    const double gap = std::max(0.0, 3.4 - 0.1 * f);  // metres between them
    std::vector<Lane> lanes = {GroundLane(-gap / 2, 0, 0)};
    if (gap > 0.3) lanes.push_back(GroundLane(gap / 2, 0, 0));
    const std::vector<LaneIdentity> out = tracker.Update(lanes, f / 30.0);
    if (f == 0) {
      left = out[0].id;
      right = out[1].id;
    }
    EXPECT_EQ(out[0].id, left) << "frame " << f;
    if (out.size() == 2) {
      EXPECT_EQ(out[1].id, right) << "frame " << f;
    }
  }
}

TEST(TrackingTest, AGapOrTimeGoingBackResets) {
  LaneTracker tracker;
  const int first = tracker.Update({GroundLane(1.7, 0, 0)}, 0.0)[0].id;
  tracker.Update({GroundLane(1.7, 0, 0)}, 0.033);
  EXPECT_EQ(tracker.resets(), 0);
  const int after_jump = tracker.Update({GroundLane(1.7, 0, 0)}, 5.0)[0].id;  // a 5 s gap
  EXPECT_EQ(tracker.resets(), 1);
  EXPECT_NE(after_jump, first);
  tracker.Update({GroundLane(1.7, 0, 0)}, 1.0);  // back in time: a new clip
  EXPECT_EQ(tracker.resets(), 2);
}

TEST(TrackingTest, EgoLaneGeometryAndDeparture) {
  CameraModel camera;  // yaw 0
  // Boundaries at -1.6 m and +2.0 m, heading 0.02 rad, curvature 0.001.
  std::optional<EgoLane> ego = ComputeEgoLane(
      {GroundLane(-1.6, 0.02, 0.001), GroundLane(2.0, 0.02, 0.001), GroundLane(5.6, 0.02, 0.001)},
      camera);
  ASSERT_TRUE(ego);
  EXPECT_NEAR(ego->width_m, 3.6, 1e-6);
  EXPECT_NEAR(ego->offset_m, -0.2, 1e-6);  // the lane centre is 0.2 m to the right
  EXPECT_NEAR(ego->heading_deg, std::atan(0.02) * 180 / M_PI, 1e-6);
  EXPECT_NEAR(ego->curvature_per_m, 0.001, 1e-9);
  EXPECT_EQ(ego->left_index, 0);
  EXPECT_EQ(ego->right_index, 1);
  EXPECT_NEAR(ego->right_distance_m, 2.0, 1e-6);
  // Yaw: the lane's direction is measured from the optical axis, which a
  // camera yawed 3 degrees points 3 degrees right of the road (its ground
  // point lies at x > 0).
  camera.yaw_deg = 3.0;
  const Eigen::Vector2d axis = camera.ImageToGround({camera.cu, camera.cv});
  ASSERT_GT(axis.x(), 0.0);
  EXPECT_NEAR(ComputeEgoLane({GroundLane(-1.6, 0, 0), GroundLane(2.0, 0, 0)}, camera)->heading_deg,
              -std::atan2(axis.x(), axis.y()) * 180 / M_PI, 1e-6);
  // No lane on one side, or an implausible width: none.
  EXPECT_FALSE(ComputeEgoLane({GroundLane(1.0, 0, 0), GroundLane(4.6, 0, 0)}, camera));
  EXPECT_FALSE(ComputeEgoLane({GroundLane(-0.5, 0, 0), GroundLane(0.6, 0, 0)}, camera));

  // The car drifts right at 0.8 m/s: departing once the line is < 0.8 s away.
  SequenceTracker sequence(CameraModel{});
  bool warned_early = false, warned = false;
  for (int f = 0; f < 60; ++f) {
    const double t = f / 30.0;
    const double shift = -0.8 * t;  // the lanes move left as the car moves right
    std::vector<Lane> lanes = {GroundLane(-1.8 + shift, 0, 0), GroundLane(1.8 + shift, 0, 0)};
    const std::optional<EgoLane> e = sequence.Track(lanes, {}, t).ego;
    if (f + 1 < LaneTrackingOptions().confirm_frames) continue;
    ASSERT_TRUE(e.has_value()) << "frame " << f;
    if (e->departing && e->right_distance_m > 1.2) warned_early = true;
    if (e->departing && e->right_distance_m > 0.2) warned = true;
    if (f > 20) {
      EXPECT_NEAR(e->offset_rate_mps, 0.8, 0.1) << "frame " << f;
    }
  }
  EXPECT_TRUE(warned) << "no departure before the crossing";
  EXPECT_FALSE(warned_early) << "a departure 1.5 s before the crossing";
}

TEST(TrackingTest, StraightDrivingIsNoDeparture) {
  SequenceTracker sequence(CameraModel{});
  std::mt19937 rng(9);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (int f = 0; f < 300; ++f) {
    std::vector<Lane> lanes = {GroundLane(-1.7 + noise(rng), 0, 0),
                               GroundLane(1.9 + noise(rng), 0, 0)};
    const std::optional<EgoLane> e = sequence.Track(lanes, {}, f / 30.0).ego;
    // The two boundaries are confirmed after confirm_frames; from then on
    // every frame has the ego lane, and none is a departure.
    if (f + 1 < LaneTrackingOptions().confirm_frames) continue;
    ASSERT_TRUE(e.has_value()) << "frame " << f;
    EXPECT_FALSE(e->departing) << "frame " << f;
  }
}

// A service's frames carry Unix capture times (1.7e9 s): the lateral speed
// and the departure warning are those of the same drive timed from 0.
TEST(TrackingTest, LateralSpeedDoesNotDependOnTheClocksOrigin) {
  SequenceTracker from_zero(CameraModel{});
  SequenceTracker unix_time(CameraModel{});
  int compared = 0;
  for (int f = 0; f < 45; ++f) {
    const double t = f / 30.0;
    const double shift = -0.8 * t;
    const std::vector<Lane> lanes = {GroundLane(-1.8 + shift, 0, 0), GroundLane(1.8 + shift, 0, 0)};
    const std::optional<EgoLane> a = from_zero.Track(lanes, {}, t).ego;
    const std::optional<EgoLane> b = unix_time.Track(lanes, {}, 1.7e9 + t).ego;
    ASSERT_EQ(a.has_value(), b.has_value()) << "frame " << f;
    if (!a || f < 20) continue;
    EXPECT_NEAR(a->offset_rate_mps, 0.8, 0.1) << "frame " << f;
    EXPECT_NEAR(b->offset_rate_mps, a->offset_rate_mps, 0.01) << "frame " << f;
    EXPECT_EQ(b->departing, a->departing) << "frame " << f;
    ++compared;
  }
  EXPECT_GT(compared, 20);
}

// Colour against rendered truth, also under a strong colour cast (a white
// balance off by 30 %).
TEST(TrackingTest, MarkingColourFollowsThePaintUnderAColourCast) {
  CameraModel camera;
  SyntheticOptions so;
  so.yellow_probability = 0.5;
  so.num_lanes = 3;
  int right = 0, total = 0, yellow_right = 0, yellow_total = 0;
  for (int cast = 0; cast < 2; ++cast) {
    for (uint64_t seed = 1; seed <= 25; ++seed) {
      absl::StatusOr<SyntheticFrame> frame = RenderSyntheticFrame(camera, so, seed);
      ASSERT_TRUE(frame.ok());
      cv::Mat bgr = frame->bgr;
      if (cast == 1) {
        std::vector<cv::Mat> ch;
        cv::split(bgr, ch);
        ch[0].convertTo(ch[0], -1, 1.3);  // bluish
        ch[2].convertTo(ch[2], -1, 0.8);
        cv::merge(ch, bgr);
      }
      for (const SyntheticBoundary& b : frame->boundaries) {
        // The ego lane's boundaries and the next ones: those a detector
        // reports (further out they are a few pixels wide at the verge).
        if (std::abs(b.lateral_offset_m) > 5.5) continue;
        Lane lane;
        lane.image = b.image;
        const MarkingColor c = MarkingColorOf(bgr, lane, camera);
        if (c == MarkingColor::kUnknown) continue;  // not enough paint seen
        ++total;
        const bool yellow = c == MarkingColor::kYellow;
        right += yellow == b.yellow;
        if (b.yellow) {
          ++yellow_total;
          yellow_right += yellow;
        }
      }
    }
  }
  std::printf("colour right for %d of %d boundaries; yellow for %d of %d\n", right, total,
              yellow_right, yellow_total);
  ASSERT_GT(total, 60);
  EXPECT_GE(right, 0.95 * total) << right << " of " << total;
  EXPECT_GE(yellow_right, 0.9 * yellow_total) << yellow_right << " of " << yellow_total;
}

// Type against rendered truth (solid or dashed), per frame.
TEST(TrackingTest, MarkingTypeFollowsThePaintPattern) {
  CameraModel camera;
  SyntheticOptions so;
  so.num_lanes = 3;
  int right = 0, total = 0, dashed_right = 0, dashed_total = 0;
  for (uint64_t seed = 1; seed <= 30; ++seed) {
    absl::StatusOr<SyntheticFrame> frame = RenderSyntheticFrame(camera, so, seed);
    ASSERT_TRUE(frame.ok());
    for (const SyntheticBoundary& b : frame->boundaries) {
      if (std::abs(b.lateral_offset_m) > 5.5) continue;  // as for the colour
      Lane lane;
      lane.image = b.image;
      const MarkingType t = MarkingTypeOf(frame->bgr, lane, camera);
      if (t == MarkingType::kUnknown) continue;
      ++total;
      const bool ok = t == (b.dashed ? MarkingType::kDashed : MarkingType::kSolid);
      right += ok;
      if (b.dashed) {
        ++dashed_total;
        dashed_right += ok;
      }
    }
  }
  std::printf("type right for %d of %d boundaries; dashed for %d of %d\n", right, total,
              dashed_right, dashed_total);
  ASSERT_GT(total, 60);
  EXPECT_GE(right, 0.9 * total);
  EXPECT_GE(dashed_right, 0.85 * dashed_total);
}

TEST(TrackingTest, TypeVotesFavourDashedOnceSeen) {
  LaneTracker tracker;
  // A dash fills the view in two frames of three: still a dashed line.
  const std::vector<MarkingType> frames = {MarkingType::kSolid, MarkingType::kDashed,
                                           MarkingType::kSolid};
  MarkingType last = MarkingType::kUnknown;
  for (size_t f = 0; f < frames.size(); ++f) {
    last = tracker.Update({GroundLane(1.8, 0, 0)}, f / 30.0, {}, {frames[f]})[0].type;
  }
  EXPECT_EQ(last, MarkingType::kDashed);
  LaneTracker solid;
  for (int f = 0; f < 5; ++f) {
    last = solid.Update({GroundLane(1.8, 0, 0)}, f / 30.0, {}, {MarkingType::kSolid})[0].type;
  }
  EXPECT_EQ(last, MarkingType::kSolid);
}

}  // namespace
}  // namespace lane
