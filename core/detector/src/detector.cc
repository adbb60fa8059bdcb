#include "lane/detector/detector.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "pipeline.h"

namespace lane {
namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace

absl::StatusOr<Detector> Detector::Create(const CameraModel& camera, const IpmOptions& ipm,
                                          const DetectorOptions& options) {
  if (auto s = options.Validate(); !s.ok()) return s;
  auto mapping = IpmMapping::Create(camera, ipm);
  if (!mapping.ok()) return mapping.status();
  FilterKernels kernels =
      MakeFilterKernels(options.filter, mapping->metres_per_px_x(), mapping->metres_per_px_y());
  Detector detector(*std::move(mapping), options, std::move(kernels));
  detector.needs_ = detector.ComputeNeeds();
  return detector;
}

FrameNeeds Detector::ComputeNeeds() const {
  // The union of what the stages read (pipeline.cc's table).
  const pipeline::StageEnv env{ipm_, options_, kernels_};
  double top = ipm_.camera().image_height, bottom = 0;
  bool colour = false;
  for (const pipeline::Stage& stage : pipeline::Stages()) {
    if (stage.inputs == nullptr) continue;
    const pipeline::StageInputs in = stage.inputs(env);
    top = std::min(top, in.top);
    bottom = std::max(bottom, in.bottom);
    colour = colour || in.colour;
  }
  const CameraModel& cam = ipm_.camera();
  FrameNeeds needs;
  needs.top = std::clamp(static_cast<int>(std::floor(top)), 0, cam.image_height - 1);
  needs.bottom = std::clamp(static_cast<int>(std::ceil(bottom)), needs.top + 1, cam.image_height);
  // Without a stage that needs colour, only the red channel is read: the
  // only channel a colour-blind detector reads whole (the others are
  // computed from all three).
  needs.pixels = colour ? FrameNeeds::Pixels::kBgr : FrameNeeds::Pixels::kRed;
  return needs;
}

size_t Detector::MemoryBytes() const {
  return sizeof(*this) + ipm_.MemoryBytes() + kernels_.kx.total() * kernels_.kx.elemSize() +
         kernels_.ky.total() * kernels_.ky.elemSize();
}

cv::Mat Detector::ExtractChannel(const cv::Mat& frame) const {
  if (frame.channels() == 1) return frame;
  cv::Mat out;
  switch (options_.channel) {
    case Channel::kRed:
      cv::extractChannel(frame, out, 2);
      break;
    case Channel::kGreen:
      cv::extractChannel(frame, out, 1);
      break;
    case Channel::kBlue:
      cv::extractChannel(frame, out, 0);
      break;
    case Channel::kGray:
      cv::cvtColor(frame, out, cv::COLOR_BGR2GRAY);
      break;
    case Channel::kMinRedGreen: {
      cv::Mat red, green;
      cv::extractChannel(frame, red, 2);
      cv::extractChannel(frame, green, 1);
      cv::min(red, green, out);
      break;
    }
  }
  return out;
}

ChannelView Detector::ViewChannel(const cv::Mat& frame) const {
  return pipeline::ViewOfChannel(frame, options_.channel);
}

absl::Status Detector::CheckFrame(const cv::Mat& frame) const {
  const CameraModel& cam = ipm_.camera();
  if (frame.empty()) return absl::InvalidArgumentError("empty frame");
  if (frame.depth() != CV_8U || (frame.channels() != 3 && frame.channels() != 1)) {
    return absl::InvalidArgumentError(absl::StrCat("frame must be 8-bit BGR or grey, got ",
                                                   frame.channels(), " channel(s) of depth code ",
                                                   frame.depth()));
  }
  if (frame.cols != cam.image_width || frame.rows != cam.image_height) {
    return absl::InvalidArgumentError(absl::StrCat("frame is ", frame.cols, "x", frame.rows,
                                                   " but the calibration is for ", cam.image_width,
                                                   "x", cam.image_height));
  }
  return absl::OkStatus();
}

absl::StatusOr<Detection> Detector::Detect(const cv::Mat& frame,
                                           const DetectionPrior* prior) const {
  if (absl::Status s = CheckFrame(frame); !s.ok()) return s;
  const auto t_start = Clock::now();
  const pipeline::StageEnv env{ipm_, options_, kernels_};
  pipeline::FrameContext f(frame, prior, options_.seed);
  f.top_row = needs_.top;
  f.bottom_row = needs_.bottom;
  StageTimings timings;
  const absl::Span<const pipeline::Stage> stages = pipeline::Stages();
  for (size_t i = 0; i < stages.size(); ++i) {
    const pipeline::Stage& stage = stages[i];
    if (stage.runs != nullptr && !stage.runs(f)) continue;
    const auto t = Clock::now();
    stage.run(env, f);
    timings.stage_ms[i] = MsSince(t);
    timings.ran[i] = true;
  }
  timings.total_ms = MsSince(t_start);

  Detection det = std::move(f.detection);
  det.timings = timings;
  if (options_.keep_intermediates) {
    Intermediates in;
    in.ipm = f.top_view;
    in.filtered = f.filtered;
    in.thresholded = f.thresholded;
    in.threshold = f.threshold;
    in.peaks = f.peaks;
    in.lines = f.lines;
    for (const auto& c : f.candidates) in.ipm_splines.push_back(c.ipm);
    det.debug = std::move(in);
  }
  return det;
}

}  // namespace lane
