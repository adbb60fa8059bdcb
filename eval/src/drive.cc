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
  ReadMarkings(frame, camera, alone->lanes, needs.top, needs.bottom);
  untracked_.push_back({alone->lanes, ComputeEgoLane(alone->lanes, camera)});
  absl::StatusOr<Detection> tracked = tracker_.Process(detector_, frame, time_s);
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

}  // namespace

DriveScore ScoreDrive(const std::vector<DriveTruthFrame>& truth,
                      const std::vector<DriveOutput>& outputs, const DriveScoreOptions& options) {
  DriveScore score;
  const size_t n = std::min(truth.size(), outputs.size());
  std::map<int, int> last_id;  // true boundary id -> the lane id that last matched it
  double offset_sq = 0, heading_sq = 0, width_sq = 0, curvature_sq = 0;
  std::vector<double> crossings;
  std::vector<double> departing_times;
  for (size_t f = 0; f < n; ++f) {
    const DriveTruthFrame& t = truth[f];
    const DriveOutput& out = outputs[f];
    ++score.frames;
    score.labels += static_cast<int>(t.boundaries.size());
    // The lanes counted, and their curves.
    std::vector<int> counted;
    std::vector<Curve> curves;
    for (int i = 0; i < static_cast<int>(out.lanes.size()); ++i) {
      if (options.confirmed_only && !out.lanes[i].confirmed) continue;
      counted.push_back(i);
      curves.push_back(Curve::FromBezier(out.lanes[i].image));
    }
    std::vector<Curve> labels;
    for (const DriveTruthBoundary& b : t.boundaries) labels.push_back(b.curve);
    const Matching m = MatchPaperRule(curves, labels, t.width, options.rule);
    // Lanes on no boundary: on an asphalt edge, or false positives.
    std::vector<Curve> unmatched;
    std::vector<size_t> unmatched_index;
    for (size_t d = 0; d < counted.size(); ++d) {
      if (m.detection_label[d] >= 0) continue;
      unmatched.push_back(curves[d]);
      unmatched_index.push_back(d);
    }
    std::vector<bool> on_edge(counted.size(), false);
    if (!unmatched.empty() && !t.road_edges.empty()) {
      const Matching e = MatchPaperRule(unmatched, t.road_edges, t.width, options.rule);
      for (size_t u = 0; u < unmatched.size(); ++u) {
        on_edge[unmatched_index[u]] = e.detection_label[u] >= 0;
      }
    }
    score.reported += static_cast<int>(counted.size());
    score.matched += m.MatchedLabels();
    for (size_t d = 0; d < counted.size(); ++d) {
      const bool predicted = out.lanes[static_cast<size_t>(counted[d])].predicted;
      score.predicted += predicted ? 1 : 0;
      if (m.detection_label[d] >= 0) continue;
      if (on_edge[d]) {
        ++score.on_road_edges;
        continue;
      }
      ++score.false_positives;
      score.false_positive_frames.push_back(static_cast<int>(f));
      score.predicted_false_positives += predicted ? 1 : 0;
    }
    // Per true boundary: the lane (index into out.lanes) that matched it.
    std::vector<int> lane_of(t.boundaries.size(), -1);
    for (size_t k = 0; k < t.boundaries.size(); ++k) {
      const int d = m.label_detection[k];
      if (d < 0) continue;
      const Lane& lane = out.lanes[static_cast<size_t>(counted[static_cast<size_t>(d)])];
      lane_of[k] = counted[static_cast<size_t>(d)];
      const DriveTruthBoundary& b = t.boundaries[k];
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
      if (lane.id >= 0) {
        auto it = last_id.find(b.id);
        if (it != last_id.end() && it->second != lane.id) {
          ++score.id_switches;
          score.switches.push_back({static_cast<int>(f), b.id, it->second, lane.id});
        }
        last_id[b.id] = lane.id;
      }
    }
    // Ego lane.
    if (t.ego) {
      ++score.ego_frames;
      if (f > 0 && truth[f - 1].ego && truth[f - 1].ego->lane != t.ego->lane) {
        crossings.push_back(0.5 * (truth[f - 1].time_s + t.time_s));
      }
      int true_left = -1, true_right = -1;
      for (size_t k = 0; k < t.boundaries.size(); ++k) {
        if (t.boundaries[k].id == t.ego->lane) true_left = lane_of[k];
        if (t.boundaries[k].id == t.ego->lane + 1) true_right = lane_of[k];
      }
      if (out.ego && true_left >= 0 && out.ego->left_index == true_left &&
          out.ego->right_index == true_right) {
        ++score.ego_matched;
        offset_sq += std::pow(out.ego->offset_m - t.ego->offset_m, 2);
        heading_sq += std::pow(out.ego->heading_deg - t.ego->heading_deg, 2);
        width_sq += std::pow(out.ego->width_m - t.ego->width_m, 2);
        curvature_sq += std::pow(out.ego->curvature_per_m - t.ego->curvature_per_m, 2);
      }
    }
    if (out.ego && out.ego->departing) departing_times.push_back(t.time_s);
  }
  score.offset_rms_m = Rms(offset_sq, score.ego_matched);
  score.heading_rms_deg = Rms(heading_sq, score.ego_matched);
  score.width_rms_m = Rms(width_sq, score.ego_matched);
  score.curvature_rms_per_m = Rms(curvature_sq, score.ego_matched);
  for (const double c : crossings) {
    std::optional<double> lead;
    for (const double d : departing_times) {
      if (d < c && c - d <= options.departure_lead_s) lead = std::max(lead.value_or(0.0), c - d);
    }
    score.departure_leads_s.push_back(lead);
  }
  for (const double d : departing_times) {
    const bool near = std::any_of(crossings.begin(), crossings.end(), [&](double c) {
      return std::abs(c - d) <= options.departure_lead_s;
    });
    if (!near) ++score.false_departure_frames;
  }
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
