#include "lane/eval/drive.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "absl/strings/str_format.h"
#include "lane/eval/matching.h"
#include "lane/track/marking_reader.h"

namespace lane::eval {

DriveRunner::DriveRunner(const Detector& detector)
    : detector_(detector), tracker_(detector.ipm().camera()) {}

absl::Status DriveRunner::Add(const cv::Mat& frame, double time_s) {
  const CameraModel& camera = detector_.ipm().camera();
  absl::StatusOr<Detection> alone = detector_.Detect(frame);
  if (!alone.ok()) return alone.status();
  const FrameNeeds& needs = detector_.Needs();
  const std::vector<Marking> markings =
      ReadMarkings(frame, camera, alone->lanes, needs.top, needs.bottom);
  DriveOutput untracked;
  for (size_t i = 0; i < alone->lanes.size(); ++i) {
    TrackedLane& lane = untracked.lanes.emplace_back();
    lane.lane = alone->lanes[i];
    lane.color = markings[i].color;
    lane.type = markings[i].type;
  }
  untracked.ego = ComputeEgoLane(alone->lanes, camera);
  untracked_.push_back(std::move(untracked));
  absl::StatusOr<TrackedFrame> tracked = tracker_.Process(detector_, frame, time_s);
  if (!tracked.ok()) return tracked.status();
  tracked_.push_back({std::move(tracked->lanes), tracked->ego});
  return absl::OkStatus();
}

DriveTruthFrame DriveTruthOf(const SyntheticFrame& frame) {
  DriveTruthFrame t;
  t.width = frame.bgr.cols;
  t.height = frame.bgr.rows;
  t.time_s = frame.time_s;
  for (const SyntheticBoundary& b : frame.boundaries) {
    t.boundaries.push_back({Curve::FromBezier(b.image), b.id, b.yellow, b.dashed, b.type_changes});
  }
  for (const auto& e : frame.road_edges) t.road_edges.push_back(Curve::FromBezier(e));
  t.ego = frame.ego;
  return t;
}

namespace {

double Rms(double sum_sq, int n) { return n > 0 ? std::sqrt(sum_sq / n) : 0.0; }

// One frame's counted lanes matched to its true boundaries and road edges.
struct FrameMatch {
  std::vector<int> counted;   // indices into DriveOutput::lanes of the lanes counted
  Matching m;                 // counted lanes vs true boundaries
  std::vector<bool> on_edge;  // per counted lane: unmatched but on an asphalt edge
};

// The state carried across a drive's frames.
struct DriveAccumulator {
  std::map<int, int> last_id;  // true boundary id -> the lane id that last matched it
  double offset_sq = 0, heading_sq = 0, width_sq = 0, curvature_sq = 0;
  std::vector<double> crossings;
  std::vector<double> departing_times;
};

// Matches a frame's counted lanes to its boundaries, and the unmatched ones to its road edges.
FrameMatch MatchFrame(const DriveTruthFrame& t, const DriveOutput& out,
                      const DriveScoreOptions& options) {
  FrameMatch fm;
  // The lanes counted, and their curves.
  std::vector<Curve> curves;
  for (int i = 0; i < static_cast<int>(out.lanes.size()); ++i) {
    if (options.confirmed_only && !out.lanes[i].confirmed) continue;
    fm.counted.push_back(i);
    curves.push_back(Curve::FromBezier(out.lanes[i].lane.image));
  }
  std::vector<Curve> labels;
  for (const DriveTruthBoundary& b : t.boundaries) labels.push_back(b.curve);
  fm.m = MatchPaperRule(curves, labels, t.width, options.rule);
  // Lanes on no boundary: on an asphalt edge, or false positives.
  std::vector<Curve> unmatched;
  std::vector<size_t> unmatched_index;
  for (size_t d = 0; d < fm.counted.size(); ++d) {
    if (fm.m.detection_label[d] >= 0) continue;
    unmatched.push_back(curves[d]);
    unmatched_index.push_back(d);
  }
  fm.on_edge.assign(fm.counted.size(), false);
  if (!unmatched.empty() && !t.road_edges.empty()) {
    const Matching e = MatchPaperRule(unmatched, t.road_edges, t.width, options.rule);
    for (size_t u = 0; u < unmatched.size(); ++u) {
      fm.on_edge[unmatched_index[u]] = e.detection_label[u] >= 0;
    }
  }
  return fm;
}

// Counts frame f's reported, matched, predicted, road-edge and false-positive lanes.
void CountLanes(size_t f, const DriveOutput& out, const FrameMatch& fm, DriveScore& score) {
  score.reported += static_cast<int>(fm.counted.size());
  score.matched += fm.m.MatchedLabels();
  for (size_t d = 0; d < fm.counted.size(); ++d) {
    const bool predicted = out.lanes[static_cast<size_t>(fm.counted[d])].predicted;
    score.predicted += predicted ? 1 : 0;
    if (fm.m.detection_label[d] >= 0) continue;
    if (fm.on_edge[d]) {
      ++score.on_road_edges;
      continue;
    }
    ++score.false_positives;
    score.false_positive_frames.push_back(static_cast<int>(f));
    score.predicted_false_positives += predicted ? 1 : 0;
  }
}

// Scores a matched lane's colour and type against its true boundary.
void ScoreMarking(const TrackedLane& lane, const DriveTruthBoundary& b, DriveScore& score) {
  ++score.colour_scored;
  if (lane.color == (b.yellow ? MarkingColor::kYellow : MarkingColor::kWhite)) {
    ++score.colour_right;
  }
  if (!b.type_changes) {
    ++score.type_scored;
    if (lane.type == (b.dashed ? MarkingType::kDashed : MarkingType::kSolid)) {
      ++score.type_right;
    } else {
      ++score.type_errors[{b.id, absl::StrFormat("%s read %s", b.dashed ? "dashed" : "solid",
                                                 MarkingTypeName(lane.type))}];
    }
  }
}

// Scores frame f's matched boundaries (colour, type, id switches); per boundary its lane or -1.
std::vector<int> ScoreBoundaries(size_t f, const DriveTruthFrame& t, const DriveOutput& out,
                                 const FrameMatch& fm, std::map<int, int>& last_id,
                                 DriveScore& score) {
  std::vector<int> lane_of(t.boundaries.size(), -1);
  for (size_t k = 0; k < t.boundaries.size(); ++k) {
    const int d = fm.m.label_detection[k];
    if (d < 0) continue;
    const TrackedLane& lane = out.lanes[static_cast<size_t>(fm.counted[static_cast<size_t>(d)])];
    lane_of[k] = fm.counted[static_cast<size_t>(d)];
    const DriveTruthBoundary& b = t.boundaries[k];
    ScoreMarking(lane, b, score);
    if (lane.id >= 0) {
      auto it = last_id.find(b.id);
      if (it != last_id.end() && it->second != lane.id) {
        ++score.id_switches;
        score.switches.push_back({static_cast<int>(f), b.id, it->second, lane.id});
      }
      last_id[b.id] = lane.id;
    }
  }
  return lane_of;
}

// Scores frame f's ego lane and notes its lane change crossing and departure warning.
void ScoreEgo(size_t f, const std::vector<DriveTruthFrame>& truth, const DriveOutput& out,
              const std::vector<int>& lane_of, DriveAccumulator& acc, DriveScore& score) {
  const DriveTruthFrame& t = truth[f];
  if (t.ego) {
    ++score.ego_frames;
    if (f > 0 && truth[f - 1].ego && truth[f - 1].ego->lane != t.ego->lane) {
      acc.crossings.push_back(0.5 * (truth[f - 1].time_s + t.time_s));
    }
    int true_left = -1, true_right = -1;
    for (size_t k = 0; k < t.boundaries.size(); ++k) {
      if (t.boundaries[k].id == t.ego->lane) true_left = lane_of[k];
      if (t.boundaries[k].id == t.ego->lane + 1) true_right = lane_of[k];
    }
    if (out.ego && true_left >= 0 && out.ego->left_index == true_left &&
        out.ego->right_index == true_right) {
      ++score.ego_matched;
      acc.offset_sq += std::pow(out.ego->offset_m - t.ego->offset_m, 2);
      acc.heading_sq += std::pow(out.ego->heading_deg - t.ego->heading_deg, 2);
      acc.width_sq += std::pow(out.ego->width_m - t.ego->width_m, 2);
      acc.curvature_sq += std::pow(out.ego->curvature_per_m - t.ego->curvature_per_m, 2);
    }
  }
  if (out.ego && out.ego->departing) acc.departing_times.push_back(t.time_s);
}

// The drive's ego RMS errors, departure warning leads and false departures.
void FinishDrive(const DriveAccumulator& acc, const DriveScoreOptions& options, DriveScore& score) {
  score.offset_rms_m = Rms(acc.offset_sq, score.ego_matched);
  score.heading_rms_deg = Rms(acc.heading_sq, score.ego_matched);
  score.width_rms_m = Rms(acc.width_sq, score.ego_matched);
  score.curvature_rms_per_m = Rms(acc.curvature_sq, score.ego_matched);
  for (const double c : acc.crossings) {
    std::optional<double> lead;
    for (const double d : acc.departing_times) {
      if (d < c && c - d <= options.departure_lead_s) lead = std::max(lead.value_or(0.0), c - d);
    }
    score.departure_leads_s.push_back(lead);
  }
  for (const double d : acc.departing_times) {
    const bool near = std::any_of(acc.crossings.begin(), acc.crossings.end(), [&](double c) {
      return std::abs(c - d) <= options.departure_lead_s;
    });
    if (!near) ++score.false_departure_frames;
  }
}

}  // namespace

DriveScore ScoreDrive(const std::vector<DriveTruthFrame>& truth,
                      const std::vector<DriveOutput>& outputs, const DriveScoreOptions& options) {
  DriveScore score;
  const size_t n = std::min(truth.size(), outputs.size());
  DriveAccumulator acc;
  for (size_t f = 0; f < n; ++f) {
    const DriveTruthFrame& t = truth[f];
    const DriveOutput& out = outputs[f];
    ++score.frames;
    score.labels += static_cast<int>(t.boundaries.size());
    const FrameMatch fm = MatchFrame(t, out, options);
    CountLanes(f, out, fm, score);
    const std::vector<int> lane_of = ScoreBoundaries(f, t, out, fm, acc.last_id, score);
    ScoreEgo(f, truth, out, lane_of, acc, score);
  }
  FinishDrive(acc, options, score);
  return score;
}

std::string DriveScore::Summary() const {
  std::string s = absl::StrFormat(
      "frames %d, boundaries %d: recall %.3f, lanes reported %d, on asphalt edges %d, false "
      "positives %d (%.3f per frame; predicted lanes %d, of which false positives %d)\n"
      "colour right %d/%d (%.3f), type right %d/%d (%.3f), id switches %d (%.2f per 100 "
      "boundary-frames)\n"
      "ego: %d/%d frames bounded by the true lanes; RMS offset %.3f m, heading %.3f deg, width "
      "%.3f m, curvature %.5f 1/m\n",
      frames, labels, Recall(), reported, on_road_edges, false_positives, FalsePositivesPerFrame(),
      predicted, predicted_false_positives, colour_right, colour_scored, ColourAccuracy(),
      type_right, type_scored, TypeAccuracy(), id_switches, IdSwitchesPer100BoundaryFrames(),
      ego_matched, ego_frames, offset_rms_m, heading_rms_deg, width_rms_m, curvature_rms_per_m);
  for (size_t i = 0; i < departure_leads_s.size(); ++i) {
    if (departure_leads_s[i]) {
      s += absl::StrFormat("lane change %d: departure warned %.2f s before the crossing\n",
                           static_cast<int>(i) + 1, *departure_leads_s[i]);
    } else {
      s += absl::StrFormat("lane change %d: no departure warning before the crossing\n",
                           static_cast<int>(i) + 1);
    }
  }
  s += absl::StrFormat("departing frames away from any lane change: %d\n", false_departure_frames);
  if (!type_errors.empty()) {
    s += "type errors:";
    for (const auto& [key, count] : type_errors) {
      s += absl::StrFormat(" boundary %d %s x%d;", key.first, key.second, count);
    }
    s += "\n";
  }
  return s;
}

}  // namespace lane::eval
