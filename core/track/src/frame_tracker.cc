#include "lane/track/frame_tracker.h"

#include <algorithm>
#include <random>
#include <utility>

#include "lane/track/marking_reader.h"

namespace lane {

FrameTracker::FrameTracker(const CameraModel& camera, LaneTrackingOptions lanes, EgoOptions ego)
    : tracker_(camera, lanes, ego) {
  std::random_device seed;
  lineage_ = (uint64_t{seed()} << 32) ^ seed();
}

DetectionPrior FrameTracker::Prior(const Detector& detector) const {
  absl::MutexLock lock(&mu_);
  DetectionPrior prior = tracker_.Prior(detector.ipm());
  prior.refit = refits_in_row_ < tracker_.lane_tracker().options().refit_frames;
  return prior;
}

absl::StatusOr<MeasuredFrame> FrameTracker::Measure(const Detector& detector,
                                                    const cv::Mat& frame) const {
  return Measure(detector, frame, Prior(detector));
}

absl::StatusOr<MeasuredFrame> FrameTracker::Measure(const Detector& detector, const cv::Mat& frame,
                                                    const DetectionPrior& prior) const {
  absl::StatusOr<Detection> detection = detector.Detect(frame, &prior);
  if (!detection.ok()) return detection.status();
  const FrameNeeds& needs = detector.Needs();
  MeasuredFrame measured;
  measured.markings =
      ReadMarkings(frame, detector.ipm().camera(), detection->lanes, needs.top, needs.bottom);
  measured.detection = *std::move(detection);
  return measured;
}

TrackedFrame FrameTracker::Commit(const Detector& detector, MeasuredFrame measured,
                                  std::optional<double> time_s) {
  absl::MutexLock lock(&mu_);
  SequenceTracker::Frame tracked =
      tracker_.Track(measured.detection.lanes, measured.markings, time_s, &detector.ipm());
  ++frames_;
  refits_in_row_ = measured.detection.refit_lanes > 0 ? refits_in_row_ + 1 : 0;
  return TrackedFrame{std::move(measured.detection), std::move(tracked.lanes), tracked.ego};
}

absl::StatusOr<TrackedFrame> FrameTracker::Process(const Detector& detector, const cv::Mat& frame,
                                                   std::optional<double> time_s) {
  absl::StatusOr<MeasuredFrame> measured = Measure(detector, frame);
  if (!measured.ok()) return measured.status();
  return Commit(detector, *std::move(measured), time_s);
}

void FrameTracker::Reset() {
  absl::MutexLock lock(&mu_);
  tracker_.Reset();
  refits_in_row_ = kSearchNext;
}

TrackerState FrameTracker::Save() const {
  absl::MutexLock lock(&mu_);
  TrackerState state = tracker_.Snapshot();
  state.lineage = lineage_;
  state.frames = frames_;
  if (refits_in_row_ < kSearchNext) state.refits_in_row = refits_in_row_;
  return state;
}

absl::StatusOr<bool> FrameTracker::Resume(const TrackerState& state) {
  absl::MutexLock lock(&mu_);
  if (absl::Status valid = ValidateTrackerState(state); !valid.ok()) {
    tracker_.Reset();
    return valid;
  }
  if (state.lineage == lineage_ && state.frames <= frames_) return false;
  tracker_.Restore(state);
  refits_in_row_ = state.refits_in_row.value_or(kSearchNext);
  lineage_ = state.lineage;
  frames_ = state.frames;
  return true;
}

void FrameTracker::ReserveIdsBelow(int id) {
  absl::MutexLock lock(&mu_);
  tracker_.ReserveIdsBelow(std::min(id, TrackerState::kMaxId));
}

}  // namespace lane
