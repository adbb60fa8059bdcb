// The detector's pipeline: named stages run in order over one frame's
// context (docs/design.md, "Adding a stage"). Detector::Detect runs the
// table of pipeline.cc; each stage reads what the stages before it left in
// the FrameContext and adds its own part, declares what it reads of a frame
// (Detector::Needs is the union), and is timed under its name
// (StageTimings). Internal to the detector layer.
#ifndef LANE_DETECTOR_SRC_PIPELINE_H_
#define LANE_DETECTOR_SRC_PIPELINE_H_

#include <cstdint>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "absl/types/span.h"
#include "lane/detector/detection.h"

namespace lane::pipeline {

// What every stage sees of the detector: its calibration, options and
// kernels, fixed at Create and shared by every frame.
struct StageEnv {
  const IpmMapping& ipm;
  const DetectorOptions& options;
  const FilterKernels& kernels;

  // The camera's column in the top view (x = 0 at its near edge).
  double CameraColumn() const;
  // A prior window's half width, metres: at least 5 cm, at most the line
  // RANSAC's window.
  double WindowHalfWidthM(const DetectionPrior::Window& w) const;
};

// Top-view columns centre +- half (px).
struct ColumnSpan {
  double centre = 0;
  double half = 0;
};

// Stage "refit": the tracked lanes refitted in their windows.
struct Refitted {
  std::vector<Lane> lanes;
  std::vector<double> half_widths_m;  // each lane's window
  std::vector<ColumnSpan> columns;    // where the Hough's peaks are theirs
  DetectionPrior rest;                // the windows left to search
  int failed = 0;                     // refits tried that failed
};

// One frame as the stages run over it: what Detect hands them, what each
// stage leaves for the next (the stage that writes a field is named beside
// it), and the detection they build.
struct FrameContext {
  FrameContext(const cv::Mat& frame_in, const DetectionPrior* prior_in, uint64_t seed)
      : frame(frame_in), prior(prior_in), rng(seed), channel(frame_in) {}

  const cv::Mat& frame;         // BGR or one channel, the camera's size
  const DetectionPrior* prior;  // a tracker's prediction, or null; after
                                // "refit", the windows it left to search
  std::mt19937_64 rng;          // one stream per frame, drawn in stage order
  int top_row = 0;              // the rows the detector reads (Needs())
  int bottom_row = -1;

  ChannelView channel;                      // ipm: the detector's channel, its rows
  cv::Mat top_view;                         // ipm: CV_32F, mean removed
  cv::Mat void_mask;                        // ipm: empty unless void handling is on
  cv::Mat filtered;                         // filter
  cv::Mat thresholded;                      // threshold
  float threshold = 0;                      // threshold: the frame's quantile
  Refitted refitted;                        // refit
  std::vector<ColumnPeak> peaks;            // lines: the column sums' peaks
  std::vector<IpmLine> lines;               // lines: from the peaks, then the prior
  std::vector<double> spline_half_px;       // lines: each line's spline window
  std::vector<SplineCandidate> candidates;  // splines
  Detection detection;                      // postprocess: the lanes; refit: its counts
};

// What a stage reads of a frame: rows [top, bottom) (before clamping to
// the image) and whether it needs all three colour channels rather than the
// detector's channel alone.
struct StageInputs {
  double top = 0;
  double bottom = 0;
  bool colour = false;
};

struct Stage {
  const char* name;  // its timing's key
  // What it reads of a frame; null: nothing beyond the other stages.
  StageInputs (*inputs)(const StageEnv& env);
  // Whether it runs on this frame; null: always.
  bool (*runs)(const FrameContext& frame);
  void (*run)(const StageEnv& env, FrameContext& frame);
};

// The stages, in the order Detect runs them (pipeline.cc).
absl::Span<const Stage> Stages();

// --- The stages (pipeline.cc unless named) ---
StageInputs TopViewInputs(const StageEnv& env);
void TopView(const StageEnv& env, FrameContext& f);
void Filter(const StageEnv& env, FrameContext& f);
void Threshold(const StageEnv& env, FrameContext& f);
bool HasRefitPrior(const FrameContext& f);         // refit.cc
void Refit(const StageEnv& env, FrameContext& f);  // refit.cc
void Lines(const StageEnv& env, FrameContext& f);
void Splines(const StageEnv& env, FrameContext& f);
StageInputs PostprocessInputs(const StageEnv& env);
void Postprocess(const StageEnv& env, FrameContext& f);

// --- Steps the stages share ---

// The detector's channel of `frame` as a view, without a copy (kMinRedGreen
// and kGray are computed from the BGR pixels where they are read).
ChannelView ViewOfChannel(const cv::Mat& frame, Channel channel);

// Lines in the prior's windows that `lines` does not already hold, each
// with the half width (px) of its spline window: its prior window, at most
// the usual spline window.
struct PriorLines {
  std::vector<IpmLine> lines;
  std::vector<double> half_widths_px;
};
PriorLines FindPriorLines(const StageEnv& env, const cv::Mat& thresholded,
                          const DetectionPrior& prior, const std::vector<IpmLine>& lines,
                          std::mt19937_64& rng);
// RANSAC splines around each line within its window (`half_widths_px`);
// near-duplicates keep the straighter.
std::vector<SplineCandidate> FitSplines(const StageEnv& env, const cv::Mat& thresholded,
                                        const std::vector<IpmLine>& lines,
                                        const std::vector<double>& half_widths_px,
                                        std::mt19937_64& rng);
// Post-processed candidates as lanes in the three frames, left to right.
std::vector<Lane> ToLanes(const StageEnv& env, const std::vector<SplineCandidate>& done);
// Lanes left to right by their near end on the ground.
void SortLeftToRight(std::vector<Lane>& lanes);

// The search's `lanes` without those along a refitted lane, and the
// refitted lanes, sorted left to right (refit.cc).
void JoinRefitted(const Refitted& refitted, std::vector<Lane>& lanes);

// All-lanes mode, road_model_search.cc. Where the road model puts a
// boundary that `lanes` lack: line and spline RANSAC again inside its
// window, thresholded at the window's own quantile; what passes
// post-processing and fits the road is added.
void SearchRoadModelWindows(const StageEnv& env, FrameContext& f, const PostprocessFrame& images,
                            std::vector<Lane>& lanes);
// The road model's hidden boundaries (lane/detector/road_model.h), added to `lanes`
// (sorted left to right) with `inferred` set.
void AddInferredLanes(const StageEnv& env, std::vector<Lane>& lanes);

}  // namespace lane::pipeline

#endif  // LANE_DETECTOR_SRC_PIPELINE_H_
