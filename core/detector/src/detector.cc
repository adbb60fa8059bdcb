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

LanePathCounts CountLanePaths(const Detection& detection) {
  LanePathCounts counts;
  for (const Lane& lane : detection.lanes) {
    if (lane.inferred) continue;
    ++(lane.refit ? counts.refit : counts.searched);
  }
  return counts;
}

std::optional<Lane> LaneAlongCurve(const GroundCurve& curve, const IpmMapping& ipm,
                                   bool near_first) {
  constexpr int kSamples = 12;
  const CameraModel& camera = ipm.camera();
  const double horizon = camera.HorizonRow();
  const double y_from = near_first ? curve.y_near : curve.y_far;
  const double y_to = near_first ? curve.y_far : curve.y_near;
  std::vector<Eigen::Vector2d> ground, image, top;
  for (int i = 0; i < kSamples; ++i) {
    const double y = y_from + (y_to - y_from) * i / (kSamples - 1);
    const Eigen::Vector2d g(curve.X(y), y);
    const Eigen::Vector2d p = camera.GroundToImage(g);
    if (!p.allFinite() || p.y() <= horizon) continue;
    ground.push_back(g);
    image.push_back(p);
    top.push_back(ipm.GroundToIpm(g));
  }
  if (ground.size() < 4) return std::nullopt;
  const auto g = FitBezier(ground);
  const auto m = FitBezier(image);
  const auto t = FitBezier(top);
  if (!g || !m || !t) return std::nullopt;
  Lane lane;
  lane.ground = g->p;
  lane.image = m->p;
  lane.ipm = t->p;
  return lane;
}

const char* ModeName(Mode mode) { return mode == Mode::kTwo ? "two" : "all"; }

std::optional<Mode> ParseMode(const std::string& name) {
  if (name == "all") return Mode::kAll;
  if (name == "two") return Mode::kTwo;
  return std::nullopt;
}

const char* ChannelName(Channel channel) {
  switch (channel) {
    case Channel::kRed:
      return "red";
    case Channel::kGreen:
      return "green";
    case Channel::kBlue:
      return "blue";
    case Channel::kGray:
      return "gray";
    case Channel::kMinRedGreen:
      return "min_rg";
  }
  return "red";
}

std::optional<Channel> ParseChannel(const std::string& name) {
  if (name == "red") return Channel::kRed;
  if (name == "green") return Channel::kGreen;
  if (name == "blue") return Channel::kBlue;
  if (name == "gray" || name == "grey") return Channel::kGray;
  if (name == "min_rg") return Channel::kMinRedGreen;
  return std::nullopt;
}

DetectorOptions DetectorOptions::ForMode(Mode mode) {
  DetectorOptions o;
  o.mode = mode;
  if (mode == Mode::kTwo) {
    // The reference's bracketed 2-lanes values, converted to metres at the
    // Caltech camera's 8.9 IPM px per metre, except the quantile (threshold.h:
    // the reference's 98.5 % lost worn boundaries).
    o.hough.min_peak *= 1.5;  // reference: 6 instead of 4
    o.hough.group_distance_m = 1.7;
    o.line_ransac.window_half_width_m = 0.9;
    o.line_ransac.ransac.iterations = 40;
    o.spline_ransac.window_half_width_m = 0.67;
    o.spline_ransac.ransac.iterations = 75;
    o.spline_ransac.k2 = 1.0;
    // The ego lane's band (+-2.9 m) holds its two boundaries: 2 x 0.25 m of
    // kept pixels in 5.8 m is 8.6 % of a row (threshold.h).
    o.threshold.transverse_max_fraction = 0.15;
    // The band seldom reaches a curb, the stricter contrast's target in
    // all-lanes mode; the paper's-era 0.015 keeps more of the ego lane's
    // worn boundaries (cordova1 2-lanes: 96.57 % correct / 2.49 % FP against
    // 96.09 % / 2.49 % at 0.027; docs/accuracy-log.md entry 35).
    o.postprocess.min_side_contrast = 0.015;
  }
  return o;
}

absl::Status DetectorOptions::Validate() const {
  for (const absl::Status& s :
       {filter.Validate(), threshold.Validate(), hough.Validate(), line_ransac.Validate(),
        spline_ransac.Validate(), postprocess.Validate(), two_lanes.Validate(),
        road_model.Validate()}) {
    if (!s.ok()) return s;
  }
  return absl::OkStatus();
}

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
