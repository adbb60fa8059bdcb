// Video-aware detection (lane/track/) with the detector: the tracker's
// prior (windows around the predicted lanes), refits in those windows, and
// the resume state a tracker is carried across reconnections in.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
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

// The tracker's prior (DetectionPrior): with the column-sum Hough unable to
// find anything (its peak threshold out of reach), the lanes are still found
// in windows around where they are, and a window over bare road adds none.
TEST(TrackingPriorTest, PredictedWindowsFindLanesTheHoughMissedAndNothingElse) {
  absl::StatusOr<Config> config = LoadConfigFile(LANE_SOURCE_DIR "/configs/caltech.json");
  ASSERT_TRUE(config.ok()) << config.status();
  SyntheticDriveOptions drive;
  absl::StatusOr<SyntheticFrame> frame = RenderSyntheticDriveFrame(config->camera, drive, 7, 0);
  ASSERT_TRUE(frame.ok()) << frame.status();
  absl::StatusOr<Detector> normal = Detector::Create(config->camera, config->ipm, config->detector);
  ASSERT_TRUE(normal.ok()) << normal.status();
  absl::StatusOr<Detection> reference = normal->Detect(frame->bgr);
  ASSERT_TRUE(reference.ok());
  ASSERT_GE(reference->lanes.size(), 2u);

  DetectorOptions blind = config->detector;
  blind.hough.min_peak = 1e6;
  absl::StatusOr<Detector> detector = Detector::Create(config->camera, config->ipm, blind);
  ASSERT_TRUE(detector.ok()) << detector.status();
  absl::StatusOr<Detection> alone = detector->Detect(frame->bgr);
  ASSERT_TRUE(alone.ok());
  EXPECT_TRUE(alone->lanes.empty());

  // A window along each reference lane (its top-view chord, extended to the
  // view's first and last rows).
  const IpmMapping& ipm = detector->ipm();
  auto window_at = [&](const Lane& lane, double shift_m) {
    const Eigen::Vector2d shift(shift_m / ipm.metres_per_px_x(), 0.0);
    DetectionPrior::Window w;
    w.line = *MakeIpmLine(lane.ipm[0] + shift, lane.ipm[3] - lane.ipm[0], ipm.height());
    w.half_width_m = 0.5;
    return w;
  };
  DetectionPrior prior;
  for (const Lane& lane : reference->lanes) prior.windows.push_back(window_at(lane, 0.0));
  absl::StatusOr<Detection> found = detector->Detect(frame->bgr, &prior);
  ASSERT_TRUE(found.ok());
  ASSERT_EQ(found->lanes.size(), reference->lanes.size());
  for (size_t i = 0; i < found->lanes.size(); ++i) {
    const double mid = 0.5 * (found->lanes[i].ground[0].x() + found->lanes[i].ground[3].x());
    const double want =
        0.5 * (reference->lanes[i].ground[0].x() + reference->lanes[i].ground[3].x());
    EXPECT_NEAR(mid, want, 0.3) << "lane " << i;
  }

  // Windows over the middle of the lanes (1.8 m from each boundary): bare
  // road, nothing found.
  DetectionPrior bare;
  bare.windows.push_back(window_at(reference->lanes[0], 1.8));
  absl::StatusOr<Detection> none = detector->Detect(frame->bgr, &bare);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->lanes.empty());
}

// Lanes of one road are parallel: among three parallel confirmed lanes, a
// fourth running 10 degrees off them (the verge, a curb at a slant) is
// tracked but not reported as confirmed, and the parallel ones are.
TEST(TrackingPriorTest, ATrackThatIsNotParallelToTheOthersIsNotConfirmed) {
  LaneTracker tracker;
  std::vector<LaneIdentity> out;
  for (int f = 0; f < 8; ++f) {
    out = tracker.Update({GroundLane(-5.4, 0.0, 0.0), GroundLane(-1.8, 0.0, 0.0),
                          GroundLane(1.8, 0.0, 0.0), GroundLane(7.0, std::tan(0.175), 0.0)},
                         f / 30.0);
  }
  ASSERT_EQ(out.size(), 4u);
  EXPECT_TRUE(out[0].confirmed);
  EXPECT_TRUE(out[1].confirmed);
  EXPECT_TRUE(out[2].confirmed);
  EXPECT_FALSE(out[3].confirmed);
  EXPECT_GE(out[3].id, 1);
  // 3 degrees off is within the tolerance (4): confirmed.
  LaneTracker tolerant;
  for (int f = 0; f < 8; ++f) {
    out = tolerant.Update({GroundLane(-5.4, 0.0, 0.0), GroundLane(-1.8, 0.0, 0.0),
                           GroundLane(1.8, 0.0, 0.0), GroundLane(5.4, std::tan(0.052), 0.0)},
                          f / 30.0);
  }
  EXPECT_TRUE(out[3].confirmed);
}

// --- Refitted lanes (DetectionPrior::refit, issue 36) ---

// A window with the tracked curve of `lane` (its ground Bezier's fit),
// shifted `shift_m` sideways, which may be refitted.
DetectionPrior::Window RefitWindowAt(const Lane& lane, const IpmMapping& ipm, double shift_m) {
  std::optional<GroundCurve> curve = FitGroundCurve(lane);
  EXPECT_TRUE(curve.has_value());
  curve->coefficients(0) += shift_m;
  DetectionPrior::Window w;
  const Eigen::Vector2d a = ipm.GroundToIpm({curve->X(ipm.y_min()), ipm.y_min()});
  const Eigen::Vector2d b = ipm.GroundToIpm({curve->X(ipm.y_max()), ipm.y_max()});
  w.line = *MakeIpmLine(a, b - a, ipm.height());
  w.half_width_m = 0.4;
  w.curve = *curve;
  w.refit = true;
  return w;
}

double GroundXAt(const Lane& lane, double y) {
  const std::optional<GroundCurve> curve = FitGroundCurve(lane);
  return curve ? curve->X(y) : std::nan("");
}

// The ground x at `y` of the frame's true boundary nearest `x` there.
double NearestTrueX(const SyntheticFrame& frame, const CameraModel& camera, double y, double x) {
  double nearest = std::nan("");
  for (const SyntheticBoundary& b : frame.boundaries) {
    const std::optional<Bezier> ground = MapSpline(
        Bezier{b.image}, 41, [&](const Eigen::Vector2d& p) { return camera.ImageToGround(p); });
    if (!ground) continue;
    Lane lane;
    lane.ground = ground->p;
    const double bx = GroundXAt(lane, y);
    if (std::isnan(nearest) || std::abs(bx - x) < std::abs(nearest - x)) nearest = bx;
  }
  return nearest;
}

TEST(TrackingRefitTest, TrackedLanesAreRefittedAndAWrongWindowIsSearched) {
  absl::StatusOr<Config> config = LoadConfigFile(LANE_SOURCE_DIR "/configs/caltech.json");
  ASSERT_TRUE(config.ok()) << config.status();
  const SyntheticDriveOptions drive;
  absl::StatusOr<SyntheticFrame> frame = RenderSyntheticDriveFrame(config->camera, drive, 7, 0);
  ASSERT_TRUE(frame.ok()) << frame.status();
  absl::StatusOr<Detector> detector =
      Detector::Create(config->camera, config->ipm, config->detector);
  ASSERT_TRUE(detector.ok()) << detector.status();
  const IpmMapping& ipm = detector->ipm();
  absl::StatusOr<Detection> searched = detector->Detect(frame->bgr);
  ASSERT_TRUE(searched.ok());
  const size_t n = searched->lanes.size();
  ASSERT_GE(n, 3u);
  const double y_mid = 0.5 * (ipm.y_min() + ipm.y_max());

  // Every lane's window, 0.15 m off its lane (the tracker's prediction is
  // never exact): each lane is refitted onto its marking, none searched
  // again.
  DetectionPrior prior;
  prior.refit = true;
  for (const Lane& lane : searched->lanes) prior.windows.push_back(RefitWindowAt(lane, ipm, 0.15));
  absl::StatusOr<Detection> refitted = detector->Detect(frame->bgr, &prior);
  ASSERT_TRUE(refitted.ok());
  EXPECT_EQ(refitted->refit_lanes, static_cast<int>(n));
  EXPECT_EQ(refitted->refit_failed, 0);
  ASSERT_EQ(refitted->lanes.size(), n);
  // On the painted line: within 8 cm of the true boundary at mid view, and
  // nearly as close as the search's lane (or closer: the third boundary's
  // search is 18 cm off, its refit 2 cm).
  for (size_t i = 0; i < n; ++i) {
    EXPECT_TRUE(refitted->lanes[i].refit) << i;
    const double refit_x = GroundXAt(refitted->lanes[i], y_mid);
    const double truth = NearestTrueX(*frame, config->camera, y_mid, refit_x);
    EXPECT_NEAR(refit_x, truth, 0.08) << "lane " << i;
    EXPECT_LE(std::abs(refit_x - truth),
              std::abs(GroundXAt(searched->lanes[i], y_mid) - truth) + 0.03)
        << "lane " << i;
  }
  EXPECT_GT(refitted->timings.Ms("refit"), 0.0);

  // The first window 1.8 m off, on bare asphalt: its refit fails, and its
  // lane is found by the search instead, once.
  DetectionPrior wrong = prior;
  wrong.windows[0] = RefitWindowAt(searched->lanes[0], ipm, 1.8);
  absl::StatusOr<Detection> mixed = detector->Detect(frame->bgr, &wrong);
  ASSERT_TRUE(mixed.ok());
  EXPECT_EQ(mixed->refit_lanes, static_cast<int>(n) - 1);
  EXPECT_EQ(mixed->refit_failed, 1);
  ASSERT_EQ(mixed->lanes.size(), n);
  EXPECT_FALSE(mixed->lanes[0].refit);
  EXPECT_NEAR(GroundXAt(mixed->lanes[0], y_mid), GroundXAt(searched->lanes[0], y_mid), 0.15);

  // Without `refit` the windows are only searched.
  prior.refit = false;
  absl::StatusOr<Detection> plain = detector->Detect(frame->bgr, &prior);
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain->refit_lanes, 0);
  EXPECT_EQ(plain->lanes.size(), n);
  for (const Lane& lane : plain->lanes) EXPECT_FALSE(lane.refit);
}

// A FrameTracker refits its confirmed lanes for at most refit_frames frames
// in a row, searches the frame after, and after a reset; the ids hold.
TEST(TrackingRefitTest, AFrameTrackerRefitsBetweenFullSearches) {
  absl::StatusOr<Config> config = LoadConfigFile(LANE_SOURCE_DIR "/configs/caltech.json");
  ASSERT_TRUE(config.ok()) << config.status();
  absl::StatusOr<Detector> detector =
      Detector::Create(config->camera, config->ipm, config->detector);
  ASSERT_TRUE(detector.ok()) << detector.status();
  const SyntheticDriveOptions drive;
  for (const int refit_frames : {0, 2}) {
    LaneTrackingOptions options;
    options.refit_frames = refit_frames;
    FrameTracker tracker(config->camera, options);
    int in_row = 0, frames_with_refits = 0;
    std::vector<int> ids_before;
    for (int i = 0; i < 24; ++i) {
      if (i == 16) tracker.Reset();
      absl::StatusOr<SyntheticFrame> frame = RenderSyntheticDriveFrame(config->camera, drive, 7, i);
      ASSERT_TRUE(frame.ok());
      absl::StatusOr<TrackedFrame> tracked = tracker.Process(*detector, frame->bgr, frame->time_s);
      ASSERT_TRUE(tracked.ok());
      const Detection* d = &tracked->detection;
      int refit = 0;
      for (const Lane& lane : d->lanes) refit += lane.refit;
      EXPECT_EQ(refit, d->refit_lanes) << "frame " << i;
      if (i == 0 || i == 16) {
        EXPECT_EQ(d->refit_lanes, 0) << "frame " << i;
      }
      in_row = d->refit_lanes > 0 ? in_row + 1 : 0;
      frames_with_refits += d->refit_lanes > 0;
      EXPECT_LE(in_row, refit_frames) << "frame " << i;
      // Frames 8-15 hold the same confirmed ids, refitted or searched.
      std::vector<int> ids;
      for (const TrackedLane& lane : tracked->lanes) {
        if (lane.confirmed) ids.push_back(lane.id);
      }
      if (i == 8) ids_before = ids;
      if (i > 8 && i < 16) {
        EXPECT_EQ(ids, ids_before) << "frame " << i;
      }
    }
    if (refit_frames == 0) {
      EXPECT_EQ(frames_with_refits, 0);
    } else {
      EXPECT_GE(frames_with_refits, 8);  // of 24 frames, the first 3 to confirm
    }
  }
}

// A stream handed to another replica: a FrameTracker that resumes from
// another's state, in the middle of a run of refitted frames, goes on
// exactly as the original, full searches at the same frames and the same
// lanes (the refit schedule travels in the state).
TEST(TrackingRefitTest, AResumedFrameTrackerKeepsTheRefitSchedule) {
  absl::StatusOr<Config> config = LoadConfigFile(LANE_SOURCE_DIR "/configs/caltech.json");
  ASSERT_TRUE(config.ok()) << config.status();
  absl::StatusOr<Detector> detector =
      Detector::Create(config->camera, config->ipm, config->detector);
  ASSERT_TRUE(detector.ok()) << detector.status();
  LaneTrackingOptions options;
  options.refit_frames = 3;
  const SyntheticDriveOptions drive;
  FrameTracker original(config->camera, options);
  std::optional<FrameTracker> resumed;
  int compared = 0, handed_mid_run = 0;
  for (int i = 0; i < 20; ++i) {
    absl::StatusOr<SyntheticFrame> frame = RenderSyntheticDriveFrame(config->camera, drive, 7, i);
    ASSERT_TRUE(frame.ok());
    absl::StatusOr<TrackedFrame> a = original.Process(*detector, frame->bgr, frame->time_s);
    ASSERT_TRUE(a.ok());
    if (resumed) {
      absl::StatusOr<TrackedFrame> b = resumed->Process(*detector, frame->bgr, frame->time_s);
      ASSERT_TRUE(b.ok());
      EXPECT_EQ(b->detection.refit_lanes, a->detection.refit_lanes) << "frame " << i;
      ASSERT_EQ(b->lanes.size(), a->lanes.size()) << "frame " << i;
      for (size_t k = 0; k < a->lanes.size(); ++k) {
        EXPECT_EQ(b->lanes[k].id, a->lanes[k].id) << "frame " << i;
        // The state's curves are floats: the same lanes to a fraction of a
        // pixel.
        for (int p = 0; p < 4; ++p) {
          EXPECT_LT((b->lanes[k].lane.image[p] - a->lanes[k].lane.image[p]).norm(), 0.5)
              << "frame " << i;
        }
      }
      ++compared;
      resumed.reset();  // the next handover starts from the original again
    }
    // Hand the stream over after every frame once the lanes are confirmed.
    if (i >= 5) {
      const TrackerState state = original.Save();
      handed_mid_run += state.refits_in_row.value_or(0) > 0;
      resumed.emplace(config->camera, options);
      ASSERT_TRUE(resumed->Resume(state).ok());
    }
  }
  EXPECT_EQ(compared, 14);
  EXPECT_GE(handed_mid_run, 5);  // handovers in the middle of a run of refits
}

// --- Resume state (lane/track/tracker_state.h) ---

// Three parallel lanes of a gentle bend, with noise; the middle one is
// missed in frames 20-21.
std::vector<Lane> BendLanes(int f, std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, 0.05);
  std::vector<Lane> lanes;
  for (double c0 : {-5.4, -1.8, 1.8}) {
    if (c0 == -1.8 && (f == 20 || f == 21)) continue;
    lanes.push_back(GroundLane(c0 + noise(rng), 0.01, 0.001));
  }
  return lanes;
}

TEST(TrackerStateTest, ARestoredTrackerGoesOnExactlyAsTheOriginal) {
  LaneTracker original;
  std::mt19937 rng(11);
  for (int f = 0; f < 22; ++f) original.Update(BendLanes(f, rng), f / 30.0);
  const TrackerState state = original.Snapshot();
  ASSERT_TRUE(ValidateTrackerState(state).ok()) << ValidateTrackerState(state).message();
  ASSERT_EQ(state.tracks.size(), 3u);
  LaneTracker restored;
  restored.Restore(state);
  EXPECT_EQ(restored.next_id(), original.next_id());
  for (int f = 22; f < 40; ++f) {
    const std::vector<Lane> lanes = BendLanes(f, rng);
    const std::vector<LaneIdentity> a = original.Update(lanes, f / 30.0);
    const std::vector<LaneIdentity> b = restored.Update(lanes, f / 30.0);
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].id, b[i].id) << "frame " << f;
      EXPECT_EQ(a[i].confirmed, b[i].confirmed) << "frame " << f;
      EXPECT_TRUE(b[i].confirmed) << "frame " << f;
      EXPECT_NEAR(a[i].curve.coefficients(0), b[i].curve.coefficients(0), 1e-9);
    }
  }
}

TEST(TrackerStateTest, ResumeKeepsItsOwnContinuationAndRefusesBadStates) {
  FrameTracker a{CameraModel()};
  FrameTracker b{CameraModel()};
  const TrackerState fresh_a = a.Save();
  // Its own state, not ahead of it: kept.
  absl::StatusOr<bool> kept = a.Resume(fresh_a);
  ASSERT_TRUE(kept.ok());
  EXPECT_FALSE(*kept);
  // Another tracker's: taken, and then that lineage is this one's.
  absl::StatusOr<bool> taken = b.Resume(fresh_a);
  ASSERT_TRUE(taken.ok());
  EXPECT_TRUE(*taken);
  EXPECT_EQ(b.Save().lineage, fresh_a.lineage);

  LaneTracker source;
  std::mt19937 rng(3);
  for (int f = 0; f < 6; ++f) source.Update(BendLanes(f, rng), f / 30.0);
  const TrackerState good = source.Snapshot();
  ASSERT_TRUE(ValidateTrackerState(good).ok());
  const auto spoil = [&](auto&& change) {
    TrackerState s = good;
    change(s);
    return ValidateTrackerState(s);
  };
  const std::vector<absl::Status> bad = {
      spoil([](TrackerState& s) { s.version = 2; }),
      spoil([](TrackerState& s) { s.next_id = 0; }),
      spoil([](TrackerState& s) { s.time_s = std::nan(""); }),
      spoil([](TrackerState& s) { s.tracks[1].id = s.tracks[0].id; }),
      spoil([](TrackerState& s) { s.tracks[0].id = s.next_id; }),
      spoil([](TrackerState& s) { s.tracks[0].hits = 0; }),
      spoil([](TrackerState& s) { s.tracks[0].since_hit_frames = s.tracks[0].age_frames + 1; }),
      spoil([](TrackerState& s) { s.tracks[0].curve.coefficients(1) = 20; }),
      spoil([](TrackerState& s) { s.tracks[0].curve.y_far = s.tracks[0].curve.y_near - 1; }),
      spoil([](TrackerState& s) { s.tracks[0].covariance(0, 0) = -1; }),
      spoil([](TrackerState& s) { s.tracks[0].covariance(0, 1) = 5; }),
      spoil([](TrackerState& s) { s.tracks[0].white_votes = -1; }),
      spoil([](TrackerState& s) { s.started = false; }),
      spoil([](TrackerState& s) { s.refits_in_row = -1; }),
      spoil([](TrackerState& s) { s.refits_in_row = 5000; }),
      spoil([](TrackerState& s) { s.tracks.resize(TrackerState::kMaxTracks + 1, s.tracks[0]); }),
  };
  for (size_t i = 0; i < bad.size(); ++i) {
    EXPECT_EQ(bad[i].code(), absl::StatusCode::kInvalidArgument) << "case " << i;
  }
  // A refused state leaves a fresh tracker whose ids go on.
  ASSERT_TRUE(b.Resume(good).ok());
  TrackerState broken = good;
  broken.tracks[0].covariance(2, 2) = std::nan("");
  EXPECT_FALSE(b.Resume(broken).ok());
  const TrackerState after = b.Save();
  EXPECT_TRUE(after.tracks.empty());
  EXPECT_EQ(after.next_id, good.next_id);
  b.ReserveIdsBelow(100);
  EXPECT_EQ(b.Save().next_id, 100);
}

TEST(TrackerStateTest, AStateHoldsAtMostMaxTracksTheMostSeenFirst) {
  LaneTracker tracker;
  // Lanes 0.5 m apart are not duplicates of each other only if found in the
  // same frame; 40 of them, each frame.
  std::vector<Lane> lanes;
  for (int i = 0; i < 40; ++i) lanes.push_back(GroundLane(-20.0 + 1.0 * i, 0.0, 0.0));
  tracker.Update(lanes, 0.0);
  std::vector<Lane> fewer(lanes.begin(), lanes.begin() + 10);
  tracker.Update(fewer, 1 / 30.0);
  const TrackerState state = tracker.Snapshot();
  ASSERT_EQ(state.tracks.size(), TrackerState::kMaxTracks);
  EXPECT_TRUE(ValidateTrackerState(state).ok());
  int twice = 0;
  for (const TrackSnapshot& t : state.tracks) twice += t.hits == 2;
  EXPECT_EQ(twice, 10);
}

}  // namespace
}  // namespace lane
