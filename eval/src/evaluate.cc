#include "lane/eval/evaluate.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <filesystem>
#include <map>
#include <opencv2/imgcodecs.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "lane/eval/ego.h"

namespace lane::eval {
namespace {

std::vector<Curve> Curves(const std::vector<DetectedLane>& lanes) {
  std::vector<Curve> out;
  out.reserve(lanes.size());
  for (const DetectedLane& l : lanes) out.push_back(l.curve);
  return out;
}

// Scores one filled-in outcome and adds it to `counts`.
void Tally(const LabelledFrame& frame, const EvalOptions& options, FrameOutcome& outcome,
           ClipCounts& counts) {
  if (!outcome.error.empty()) {
    ++counts.failed_frames;
    outcome.lanes.clear();
  }
  if (frame.labelled) {
    outcome.score =
        ScoreFrame(Curves(outcome.lanes), frame, outcome.width, outcome.height, options);
    ++counts.frames;
    counts.missing_results += outcome.missing_result ? 1 : 0;
    counts.paper.Add(outcome.score->paper);
    counts.culane.Add(outcome.score->culane);
  } else {
    ++counts.unlabelled_frames;
  }
}

EvalReport EmptyReport(const Dataset& dataset, const EvalOptions& options) {
  EvalReport report;
  report.dataset = dataset.root;
  report.format = dataset.format;
  report.options = options;
  report.warnings = dataset.warnings;
  report.total.clip = "Total";
  return report;
}

// Runs `fill` on every frame, scores it, hands it to `on_frame` and counts
// it. `fill(frame, outcome)` sets the outcome's size, lanes, error, image
// and detection.
template <class Fill>
EvalReport Run(const Dataset& dataset, const EvalOptions& options, const FrameCallback& on_frame,
               Fill fill) {
  EvalReport report = EmptyReport(dataset, options);
  const int total = dataset.FrameCount();
  int index = 0;
  for (const Clip& clip : dataset.clips) {
    ClipCounts counts;
    counts.clip = clip.name;
    for (const LabelledFrame& frame : clip.frames) {
      FrameOutcome outcome;
      outcome.clip = &clip;
      outcome.frame = &frame;
      outcome.index = index++;
      outcome.total = total;
      fill(frame, outcome);
      Tally(frame, options, outcome, counts);
      if (on_frame) on_frame(outcome);
    }
    report.total += counts;
    report.clips.push_back(std::move(counts));
  }
  report.total.clip = "Total";
  return report;
}

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// "a/b/c.jpg" -> "a/b/c.jpg", "b/c.jpg", "c.jpg".
std::vector<std::string> Suffixes(const std::string& name) {
  const std::vector<std::string> parts = absl::StrSplit(name, '/', absl::SkipEmpty());
  std::vector<std::string> out;
  for (size_t k = 0; k < parts.size(); ++k) {
    out.push_back(absl::StrJoin(parts.begin() + k, parts.end(), "/"));
  }
  return out;
}

std::string NormalName(const std::string& name) {
  std::string n = std::filesystem::path(name).lexically_normal().generic_string();
  while (n.rfind("./", 0) == 0) n.erase(0, 2);
  return n;
}

}  // namespace

absl::Status EvalOptions::Validate() const {
  if (absl::Status s = paper.Validate(); !s.ok()) return s;
  return culane.Validate();
}

FrameScore ScoreFrame(const std::vector<Curve>& detections, const LabelledFrame& frame, int width,
                      int height, const EvalOptions& options) {
  FrameScore score;
  if (options.mode == Mode::kTwo) {
    std::vector<Curve> all;
    all.reserve(frame.boundaries.size());
    for (const LabelledBoundary& b : frame.boundaries) all.push_back(b.curve);
    const double last_row = height - 1.0;
    const double row = options.ego_row >= 0 ? std::min(options.ego_row, last_row) : last_row;
    const EgoBoundaries ego = SelectEgoBoundaries(all, width / 2.0, row);
    if (ego.left >= 0) score.scored_labels.push_back(ego.left);
    if (ego.right >= 0) score.scored_labels.push_back(ego.right);
  } else {
    for (size_t i = 0; i < frame.boundaries.size(); ++i) {
      score.scored_labels.push_back(static_cast<int>(i));
    }
  }
  std::vector<Curve> labels;
  labels.reserve(score.scored_labels.size());
  for (int i : score.scored_labels) labels.push_back(frame.boundaries[i].curve);
  score.paper = MatchPaperRule(detections, labels, width, options.paper);
  score.culane = MatchCulane(detections, labels, width, height, options.culane);
  return score;
}

absl::StatusOr<std::vector<EvalReport>> EvaluateDetectors(
    const Dataset& dataset, const std::vector<const Detector*>& detectors,
    const EvalOptions& options, const FrameCallback& on_frame) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (detectors.empty()) return absl::InvalidArgumentError("no detector to evaluate");
  for (const Detector* d : detectors) {
    const CameraModel& a = d->ipm().camera();
    const CameraModel& b = detectors.front()->ipm().camera();
    if (a.image_width != b.image_width || a.image_height != b.image_height) {
      return absl::InvalidArgumentError("the detectors evaluated together must share a frame size");
    }
  }
  const CameraModel& camera = detectors.front()->ipm().camera();
  std::vector<EvalReport> reports(detectors.size(), EmptyReport(dataset, options));
  const int total = dataset.FrameCount();
  int index = 0;
  for (const Clip& clip : dataset.clips) {
    std::vector<ClipCounts> counts(detectors.size());
    for (ClipCounts& c : counts) c.clip = clip.name;
    for (const LabelledFrame& frame : clip.frames) {
      // Decoded once, detected by each detector.
      cv::Mat image;
      std::string read_error;
      const auto start = std::chrono::steady_clock::now();
      try {
        image = cv::imread(frame.image_path, cv::IMREAD_COLOR);
      } catch (const cv::Exception&) {
        image.release();
      }
      const double decode_ms = MillisecondsSince(start);
      if (image.empty()) {
        read_error = absl::StrCat("cannot read image ", frame.image_path);
      } else if (image.cols != camera.image_width || image.rows != camera.image_height) {
        read_error = absl::StrCat("frame is ", image.cols, "x", image.rows,
                                  " but the camera expects ", camera.image_width, "x",
                                  camera.image_height, " (camera.image_width/image_height)");
      }
      for (size_t d = 0; d < detectors.size(); ++d) {
        FrameOutcome outcome;
        outcome.clip = &clip;
        outcome.frame = &frame;
        outcome.index = index;
        outcome.total = total;
        outcome.width = camera.image_width;
        outcome.height = camera.image_height;
        outcome.image = image;
        outcome.decode_ms = decode_ms;
        outcome.error = read_error;
        std::optional<Detection> detection;
        if (read_error.empty()) {
          try {
            absl::StatusOr<Detection> result = detectors[d]->Detect(image);
            if (result.ok()) {
              detection = std::move(*result);
            } else {
              outcome.error = std::string(result.status().message());
            }
          } catch (const std::exception& e) {
            outcome.error = absl::StrCat("detector error: ", e.what());
          }
        }
        if (detection) {
          outcome.detection = &*detection;
          for (const Lane& lane : detection->lanes) {
            outcome.lanes.push_back({Curve::FromBezier(lane.image), lane.score});
          }
        }
        Tally(frame, options, outcome, counts[d]);
        if (d == 0 && on_frame) on_frame(outcome);
      }
      ++index;
    }
    for (size_t d = 0; d < detectors.size(); ++d) {
      reports[d].total += counts[d];
      reports[d].clips.push_back(std::move(counts[d]));
      reports[d].total.clip = "Total";
    }
  }
  return reports;
}

absl::StatusOr<EvalReport> EvaluateDetector(const Dataset& dataset, const Detector& detector,
                                            const EvalOptions& options,
                                            const FrameCallback& on_frame) {
  absl::StatusOr<std::vector<EvalReport>> reports =
      EvaluateDetectors(dataset, {&detector}, options, on_frame);
  if (!reports.ok()) return reports.status();
  return std::move(reports->front());
}

namespace {

using RecordMap = std::map<const LabelledFrame*, const FrameResult*>;

// Every frame of the data set, over all clips in order.
std::vector<const LabelledFrame*> AllFrames(const Dataset& dataset) {
  std::vector<const LabelledFrame*> frames;
  for (const Clip& clip : dataset.clips) {
    for (const LabelledFrame& f : clip.frames) frames.push_back(&f);
  }
  return frames;
}

// Maps records to frames by their frame index over the whole data set.
absl::Status MatchRecordsByIndex(const std::vector<FrameResult>& results,
                                 const std::vector<const LabelledFrame*>& frames,
                                 RecordMap& record_of) {
  const int total = static_cast<int>(frames.size());
  for (const FrameResult& r : results) {
    if (r.index >= total) {
      return absl::InvalidArgumentError(
          absl::StrCat("results frame#", r.index, " is beyond the data set's ", total,
                       " frames (frames are numbered from 0 over all clips in order; use --clip to "
                       "score one clip)"));
    }
    record_of[frames[r.index]] = &r;
  }
  return absl::OkStatus();
}

// Maps records to frames by name (exact, or a unique path suffix); unmatched names the rest.
absl::Status MatchRecordsByName(const Dataset& dataset, const std::vector<FrameResult>& results,
                                const std::vector<const LabelledFrame*>& frames,
                                RecordMap& record_of, std::vector<std::string>& unmatched) {
  const int total = static_cast<int>(frames.size());
  std::map<std::string, int> exact;
  std::map<std::string, std::vector<int>> by_suffix;
  for (int i = 0; i < total; ++i) {
    exact[frames[i]->name] = i;
    for (const std::string& s : Suffixes(frames[i]->name)) by_suffix[s].push_back(i);
  }
  for (const FrameResult& r : results) {
    const std::string name = NormalName(r.frame);
    int index = -1;
    if (const auto it = exact.find(name); it != exact.end()) {
      index = it->second;
    } else if (const auto s = by_suffix.find(name); s != by_suffix.end()) {
      if (s->second.size() > 1) {
        return absl::InvalidArgumentError(
            absl::StrCat("results frame \"", r.frame, "\" could be ", frames[s->second[0]]->name,
                         " or ", frames[s->second[1]]->name,
                         ": name frames by their path relative to the data set folder"));
      }
      index = s->second.front();
    }
    if (index < 0) {
      unmatched.push_back(r.frame);
      continue;
    }
    if (!record_of.emplace(frames[index], &r).second) {
      return absl::InvalidArgumentError(
          absl::StrCat("the results hold two records for frame ", frames[index]->name));
    }
  }
  if (record_of.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("no results record names a frame of ", dataset.root, " (results name e.g. \"",
                     results.front().frame, "\", the data set has e.g. \"",
                     total > 0 ? frames.front()->name : std::string(), "\")"));
  }
  return absl::OkStatus();
}

// Fills outcomes from the records; sizes they lack from the labels, options or clip's images.
class RecordFiller {
 public:
  RecordFiller(const RecordMap& record_of, const EvalOptions& options)
      : record_of_(record_of), options_(options) {}

  void operator()(const LabelledFrame& frame, FrameOutcome& outcome) {
    const auto it = record_of_.find(&frame);
    const FrameResult* record = it == record_of_.end() ? nullptr : it->second;
    outcome.missing_result = record == nullptr;
    if (record != nullptr) {
      outcome.lanes = record->lanes;
      outcome.error = record->error;
      outcome.width = record->width;
      outcome.height = record->height;
    }
    if (outcome.width <= 0 || outcome.height <= 0) {
      outcome.width = frame.width;
      outcome.height = frame.height;
    }
    if (outcome.width <= 0 || outcome.height <= 0) {
      outcome.width = options_.default_width;
      outcome.height = options_.default_height;
    }
    if (outcome.width <= 0 || outcome.height <= 0) FillClipSize(frame, outcome);
  }

 private:
  // The clip's image size (read once per clip until one decodes), or an error.
  void FillClipSize(const LabelledFrame& frame, FrameOutcome& outcome) {
    if (size_clip_ != outcome.clip || clip_size_.empty()) {
      size_clip_ = outcome.clip;
      clip_size_ = cv::Size();
      try {
        const cv::Mat image = cv::imread(frame.image_path, cv::IMREAD_COLOR);
        clip_size_ = image.size();
      } catch (const cv::Exception&) {
      }
    }
    outcome.width = clip_size_.width;
    outcome.height = clip_size_.height;
    if (clip_size_.empty() && outcome.error.empty()) {
      outcome.error = absl::StrCat("frame size unknown: cannot read image ", frame.image_path,
                                   " (give a config)");
    }
  }

  const RecordMap& record_of_;
  const EvalOptions& options_;
  const Clip* size_clip_ = nullptr;
  cv::Size clip_size_;
};

// Warns of records that matched no frame and of labelled frames without a record.
void AddResultsWarnings(const std::vector<std::string>& unmatched, EvalReport& report) {
  if (!unmatched.empty()) {
    report.warnings.push_back(absl::StrCat(unmatched.size(),
                                           " results record(s) match no frame of the data set, "
                                           "e.g. \"",
                                           unmatched.front(), "\" (ignored)"));
  }
  if (report.total.missing_results > 0) {
    report.warnings.push_back(absl::StrCat(report.total.missing_results,
                                           " labelled frame(s) have no results record (scored "
                                           "as no detections)"));
  }
}

}  // namespace

absl::StatusOr<EvalReport> EvaluateResults(const Dataset& dataset,
                                           const std::vector<FrameResult>& results,
                                           const EvalOptions& options,
                                           const FrameCallback& on_frame) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (results.empty()) return absl::InvalidArgumentError("the results file holds no frame");
  const std::vector<const LabelledFrame*> frames = AllFrames(dataset);
  // The record of each data set frame.
  RecordMap record_of;
  std::vector<std::string> unmatched;
  const bool by_index = std::all_of(results.begin(), results.end(),
                                    [](const FrameResult& r) { return r.index >= 0; });
  const absl::Status matched =
      by_index ? MatchRecordsByIndex(results, frames, record_of)
               : MatchRecordsByName(dataset, results, frames, record_of, unmatched);
  if (!matched.ok()) return matched;
  absl::StatusOr<EvalReport> report =
      Run(dataset, options, on_frame, RecordFiller(record_of, options));
  if (report.ok()) AddResultsWarnings(unmatched, *report);
  return report;
}

}  // namespace lane::eval
