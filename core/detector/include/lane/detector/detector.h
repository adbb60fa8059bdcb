// The whole detector: frame in, lane splines out (its types and options:
// lane/detector/detection.h).
//
//   frame (BGR) -> channel -> IPM -> filter -> threshold -> column-sum Hough
//   -> RANSAC lines -> RANSAC splines -> post-processing -> image splines
#ifndef LANE_DETECTOR_DETECTOR_H_
#define LANE_DETECTOR_DETECTOR_H_

#include <cstddef>
#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "lane/detector/detection.h"
#include "lane/geometry/channel_view.h"
#include "lane/geometry/ipm.h"
#include "lane/stages/filter.h"

namespace lane {

// Immutable after Create; Detect is const and safe to call from many threads.
class Detector {
 public:
  static absl::StatusOr<Detector> Create(const CameraModel& camera, const IpmOptions& ipm,
                                         const DetectorOptions& options);

  // `frame` must be CV_8UC3 (BGR) or CV_8UC1 (the detector's channel, or grey)
  // of the camera's size; only rows Needs().top .. Needs().bottom - 1 are
  // read, the others may hold anything. INVALID_ARGUMENT otherwise.
  // `prior` (may be null): a tracker's prediction for this frame.
  absl::StatusOr<Detection> Detect(const cv::Mat& frame,
                                   const DetectionPrior* prior = nullptr) const;

  const IpmMapping& ipm() const { return ipm_; }
  const DetectorOptions& options() const { return options_; }
  const FilterKernels& kernels() const { return kernels_; }
  // The rows and pixels this detector reads of a frame (from its calibration
  // and options, computed once).
  const FrameNeeds& Needs() const { return needs_; }
  // Bytes this detector holds between frames (its precomputed mapping and
  // kernels); each Detect call allocates its working images on top.
  size_t MemoryBytes() const;

  // The single channel the detector reads from a frame, as a copy.
  cv::Mat ExtractChannel(const cv::Mat& frame) const;
  // The same channel as a view, without a copy (kMinRedGreen and kGray are
  // computed from the BGR pixels where they are read).
  ChannelView ViewChannel(const cv::Mat& frame) const;

 private:
  // The stages themselves are the table of core/detector/src/pipeline.cc;
  // Detect runs them in order over one frame.
  absl::Status CheckFrame(const cv::Mat& frame) const;

  Detector(IpmMapping ipm, DetectorOptions options, FilterKernels kernels)
      : ipm_(std::move(ipm)), options_(std::move(options)), kernels_(std::move(kernels)) {}
  // The union of what the stages read of a frame.
  FrameNeeds ComputeNeeds() const;

  IpmMapping ipm_;
  DetectorOptions options_;
  FilterKernels kernels_;
  FrameNeeds needs_;
};

}  // namespace lane

#endif  // LANE_DETECTOR_DETECTOR_H_
