// Scoring a detector (or a results file) on a labelled data set: per frame,
// per clip and in total, under the paper's rule and the CULane metric.
#ifndef LANE_EVAL_EVALUATE_H_
#define LANE_EVAL_EVALUATE_H_

#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "lane/detector/detector.h"
#include "lane/eval/counts.h"
#include "lane/eval/culane_metric.h"
#include "lane/eval/dataset.h"
#include "lane/eval/paper_rule.h"
#include "lane/eval/results.h"

namespace lane::eval {

struct EvalOptions {
  // kTwo scores only the ego lane's two labelled boundaries (lane/eval/ego.h).
  Mode mode = Mode::kAll;
  PaperRuleOptions paper;
  CulaneOptions culane;
  // 2-lanes mode: the image row at which the ego boundaries are chosen, the
  // bottom of the detector's ROI. Negative: the frame's last row.
  double ego_row = -1;
  // Frame size to assume when neither the results nor the labels give one
  // (the config's camera). 0 = decode the clip's first image to find out.
  int default_width = 0;
  int default_height = 0;

  absl::Status Validate() const;
};

struct FrameScore {
  // Indices into the frame's boundaries of the labels that were scored: all
  // of them, or in 2-lanes mode the ego boundaries (left first).
  std::vector<int> scored_labels;
  // Matchings between the detections and the scored labels; label indices
  // are positions in `scored_labels`.
  Matching paper;
  Matching culane;
};

// Scores one frame's detections against its labels.
FrameScore ScoreFrame(const std::vector<Curve>& detections, const LabelledFrame& frame, int width,
                      int height, const EvalOptions& options);

struct EvalReport {
  std::string dataset;  // the folder given
  // What was scored, for the tables' heading; set by the caller (e.g.
  // "detector, config configs/caltech.json" or "results out/results.jsonl").
  std::string source;
  DatasetFormat format = DatasetFormat::kCulane;
  EvalOptions options;
  std::vector<ClipCounts> clips;  // in data set order
  ClipCounts total;               // clip = "Total"
  // Things the reader of the tables should know (results that matched no
  // frame, ...), one message each.
  std::vector<std::string> warnings;
};

// Everything about one frame, for the caller's progress display, results
// files and overlays. Valid during the callback only.
struct FrameOutcome {
  const Clip* clip = nullptr;
  const LabelledFrame* frame = nullptr;
  int index = 0;  // 0-based over the whole data set (the original results' frame#)
  int total = 0;  // frames in the data set
  int width = 0;  // frame size (0 when unknown)
  int height = 0;
  cv::Mat image;                         // BGR when the detector ran, else empty
  const Detection* detection = nullptr;  // when the detector ran and succeeded
  std::vector<DetectedLane> lanes;       // the detections scored
  std::string error;                     // non-empty: the frame failed
  bool missing_result = false;           // results mode: no record for the frame
  double decode_ms = 0;                  // decoding time when the detector ran
  std::optional<FrameScore> score;       // unset for unlabelled frames
};
using FrameCallback = std::function<void(const FrameOutcome&)>;

// Decodes every frame of the data set, runs the detector and scores it. A
// frame that cannot be decoded, has the wrong size or makes the detector
// fail counts as failed and is scored with no detections. options.mode
// should be the detector's mode.
absl::StatusOr<EvalReport> EvaluateDetector(const Dataset& dataset, const Detector& detector,
                                            const EvalOptions& options,
                                            const FrameCallback& on_frame = {});

// The same for several detectors at once (e.g. one per RANSAC seed): each
// frame is decoded once and detected by every detector, which must share the
// camera's frame size. One report per detector, in order. `on_frame` sees
// the first detector's outcomes only.
absl::StatusOr<std::vector<EvalReport>> EvaluateDetectors(
    const Dataset& dataset, const std::vector<const Detector*>& detectors,
    const EvalOptions& options, const FrameCallback& on_frame = {});

// Scores the records of a results file. Records with an index (original
// .txt format) are the data set's frames in order; others are matched by
// name: the frame's name, else a unique trailing part of it ("00090.jpg"
// for "clip/00090.jpg"). A frame without a record is scored with no
// detections and counted in missing_results. INVALID_ARGUMENT when no record
// matches any frame, a name matches several frames, or an index is out of
// range.
absl::StatusOr<EvalReport> EvaluateResults(const Dataset& dataset,
                                           const std::vector<FrameResult>& results,
                                           const EvalOptions& options,
                                           const FrameCallback& on_frame = {});

}  // namespace lane::eval

#endif  // LANE_EVAL_EVALUATE_H_
