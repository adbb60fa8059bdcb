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

absl::StatusOr<Detection> FrameTracker::Measure(const Detector& detector,
                                                const cv::Mat& frame) const {
  return Measure(detector, frame, Prior(detector));
}

absl::StatusOr<Detection> FrameTracker::Measure(const Detector& detector, const cv::Mat& frame,
                                                const DetectionPrior& prior) const {
  absl::StatusOr<Detection> detection = detector.Detect(frame, &prior);
  if (!detection.ok()) return detection;
  const FrameNeeds& needs = detector.Needs();
  ReadMarkings(frame, detector.ipm().camera(), detection->lanes, needs.top, needs.bottom);
  return detection;
}

void FrameTracker::Commit(const Detector& detector, Detection& detection,
                          std::optional<double> time_s) {
  absl::MutexLock lock(&mu_);
  detection.ego = tracker_.Track(detection.lanes, time_s, &detector.ipm());
  ++frames_;
  refits_in_row_ = detection.refit_lanes > 0 ? refits_in_row_ + 1 : 0;
}

absl::StatusOr<Detection> FrameTracker::Process(const Detector& detector, const cv::Mat& frame,
                                                std::optional<double> time_s) {
  absl::StatusOr<Detection> detection = Measure(detector, frame);
  if (detection.ok()) Commit(detector, *detection, time_s);
  return detection;
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
  refits_in_row_ = kSearchNext;
  lineage_ = state.lineage;
  frames_ = state.frames;
  return true;
}

void FrameTracker::ReserveIdsBelow(int id) {
  absl::MutexLock lock(&mu_);
  tracker_.ReserveIdsBelow(std::min(id, TrackerState::kMaxId));
}

}  // namespace lane
