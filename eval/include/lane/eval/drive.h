// Scoring a detector and tracker on a rendered drive (`lane render
// --sequence`): per frame the reported lanes are matched one to one with
// the true boundaries by the paper's rule (the truth runs to 40 m, further
// than a top view's lanes reach, which the CULane IoU would count against
// the lane rather than the tracking); over the drive it counts
// recall and false positives, colour and type, identity switches, the ego
// lane's errors and the lane change's departure warning (docs/tracking.md).
#ifndef LANE_EVAL_DRIVE_H_
#define LANE_EVAL_DRIVE_H_

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "lane/detector/detector.h"
#include "lane/eval/curve.h"
#include "lane/eval/paper_rule.h"
#include "lane/synthetic.h"
#include "lane/track/ego_lane.h"
#include "lane/track/frame_tracker.h"
#include "lane/track/tracked_frame.h"

namespace lane::eval {

struct DriveTruthBoundary {
  Curve curve;
  int id = -1;
  bool yellow = false;
  bool dashed = false;
  bool type_changes = false;
};

struct DriveTruthFrame {
  int width = 0;
  int height = 0;
  double time_s = 0;
  std::vector<DriveTruthBoundary> boundaries;
  // The asphalt's edges: a lane on one (by the paper's rule) that matched
  // no boundary is a road edge found, not a false positive, nor a hit.
  std::vector<Curve> road_edges;
  std::optional<SyntheticEgo> ego;
};

DriveTruthFrame DriveTruthOf(const SyntheticFrame& frame);

// What the system reported for one frame: its lanes (untracked: without
// ids, colour and type read in the frame) and the ego lane.
struct DriveOutput {
  std::vector<TrackedLane> lanes;
  std::optional<EgoLane> ego;
};

struct DriveScoreOptions {
  // Count only confirmed lanes (a tracker's output as a user filters it).
  bool confirmed_only = false;
  PaperRuleOptions rule;
  // A departure warning counts for a lane change when it comes at most this
  // long before the crossing; a warning farther from any crossing is a
  // false departure.
  double departure_lead_s = 2.0;
};

struct DriveScore {
  int frames = 0;
  int labels = 0;    // true boundaries over all frames
  int reported = 0;  // lanes counted (confirmed ones with confirmed_only)
  int matched = 0;   // of those, on a true boundary
  int false_positives = 0;
  int predicted = 0;  // of the lanes counted, predicted ones (TrackedLane::predicted)
  int predicted_false_positives = 0;
  int on_road_edges = 0;                   // lanes on no boundary but on an asphalt edge
  std::vector<int> false_positive_frames;  // one entry per false positive
  // Of the matched lanes: colour right (white/yellow; unknown is wrong),
  // and type right (solid/dashed, boundaries whose pattern is not changing).
  int colour_scored = 0, colour_right = 0;
  int type_scored = 0, type_right = 0;
  // The type's errors by true boundary id: (true dashed, reported type
  // name) -> count.
  std::map<std::pair<int, std::string>, int> type_errors;
  // A true boundary matched by a lane whose id differs from the id that
  // last matched it.
  int id_switches = 0;
  struct IdSwitch {
    int frame, boundary, from_id, to_id;
  };
  std::vector<IdSwitch> switches;
  // Ego lane: frames with a true ego lane, frames where the reported ego
  // lane is bounded by the lanes matched to its true boundaries, and the
  // errors over those.
  int ego_frames = 0;
  int ego_matched = 0;
  double offset_rms_m = 0;
  double heading_rms_deg = 0;
  double width_rms_m = 0;
  double curvature_rms_per_m = 0;
  // Lane changes (the true ego lane changes between frames): each one's
  // warning lead (seconds before the crossing of the first departing
  // frame within departure_lead_s; none without a warning).
  std::vector<std::optional<double>> departure_leads_s;
  int false_departure_frames = 0;

  double Recall() const { return labels > 0 ? static_cast<double>(matched) / labels : 0; }
  double FalsePositivesPerFrame() const {
    return frames > 0 ? double(false_positives) / frames : 0;
  }
  double ColourAccuracy() const {
    return colour_scored > 0 ? double(colour_right) / colour_scored : 0;
  }
  double TypeAccuracy() const { return type_scored > 0 ? double(type_right) / type_scored : 0; }
  // Identity switches per 100 frames per boundary (labels / frames
  // boundaries on average).
  double IdSwitchesPer100BoundaryFrames() const {
    return labels > 0 ? 100.0 * id_switches / labels : 0;
  }
  // A multi-line human summary.
  std::string Summary() const;
};

// A detector run over a drive's frames in order, as the drive test and
// `lane eval --drive` score it: each frame alone (untracked: colour and type
// read from the frame, the ego lane of its own lanes) and with a tracker
// (detected with the tracker's prior, then tracked at the frame's time).
class DriveRunner {
 public:
  explicit DriveRunner(const Detector& detector);
  // The next frame (BGR, the detector's size) at `time_s`.
  absl::Status Add(const cv::Mat& frame, double time_s);
  const std::vector<DriveOutput>& untracked() const { return untracked_; }
  const std::vector<DriveOutput>& tracked() const { return tracked_; }

 private:
  const Detector& detector_;
  FrameTracker tracker_;
  std::vector<DriveOutput> untracked_, tracked_;
};

// `truth` and `outputs` are the same frames in the same order.
DriveScore ScoreDrive(const std::vector<DriveTruthFrame>& truth,
                      const std::vector<DriveOutput>& outputs,
                      const DriveScoreOptions& options = {});

}  // namespace lane::eval

#endif  // LANE_EVAL_DRIVE_H_
