// Wall time of each of the detector's stages on one frame. The stages and
// their names come from one table (the detector's pipeline, in the order
// Detect runs them: DetectorStageName); results (`timing_ms`), the service's
// responses (`StageTimings.<name>_ms`), its metrics (`lanesvc_stage_seconds`'s
// `stage` label) and the benchmark read the names from there, so a new stage
// brings its timing with it.
#ifndef LANE_DETECTOR_STAGE_TIMINGS_H_
#define LANE_DETECTOR_STAGE_TIMINGS_H_

#include <array>
#include <cstddef>

#include "absl/strings/string_view.h"

namespace lane {

// How many stages the detector runs, and each one's name ("ipm", "filter",
// ...), in order. Defined beside the stage table (core/detector/src/pipeline.cc).
size_t DetectorStageCount();
const char* DetectorStageName(size_t stage);

struct StageTimings {
  static constexpr size_t kMaxStages = 16;
  // Milliseconds per stage, indexed as DetectorStageName; 0 for a stage
  // that did not run on this frame (`ran` false: the refit without a
  // tracker's prior).
  std::array<double, kMaxStages> stage_ms{};
  std::array<bool, kMaxStages> ran{};
  // Every stage together, from the frame's check to the last lane.
  double total_ms = 0;

  // The time of the stage called `name`; 0 when there is none.
  double Ms(absl::string_view name) const;
  // The index of the stage called `name`, or DetectorStageCount().
  static size_t IndexOf(absl::string_view name);
};

}  // namespace lane

#endif  // LANE_DETECTOR_STAGE_TIMINGS_H_
