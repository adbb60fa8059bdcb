#include "pipeline.h"

#include <algorithm>
#include <cmath>
#include <iterator>

#include "lane/postprocess/image_extension.h"

namespace lane {
namespace pipeline {

// The stage table: the order Detect runs them, their names (each one's
// timing key), what they read of a frame and when they run. A new stage is
// a line here, its functions (declared in pipeline.h) and its timing's
// proto field (StageTimings.<name>_ms).
constexpr Stage kStages[] = {
    // 1. The detector's channel of the frame and the top view, mean removed.
    {"ipm", TopViewInputs, nullptr, TopView},
    // 2. Second derivative across the lane, smoothing along it.
    {"filter", nullptr, nullptr, Filter},
    // 3. The quantile threshold (2-lanes: the ego band only).
    {"threshold", nullptr, nullptr, Threshold},
    // 3b. Tracked frames: confirmed lanes refitted in their windows.
    {"refit", nullptr, HasRefitPrior, Refit},
    // 4-5. Column-sum Hough (2-lanes: the ego pair), RANSAC lines; the
    // prior's windows the Hough missed.
    {"lines", nullptr, nullptr, Lines},
    // 6. RANSAC cubic Beziers around each line.
    {"splines", nullptr, nullptr, Splines},
    // 7. Post-processing in the top view and the image; 8. the lanes in
    // image, top view and ground; the road model's second search.
    {"postprocess", PostprocessInputs, nullptr, Postprocess},
};
static_assert(std::size(kStages) <= StageTimings::kMaxStages, "raise StageTimings::kMaxStages");

absl::Span<const Stage> Stages() { return kStages; }

double StageEnv::CameraColumn() const {
  return ipm.GroundToIpm(Eigen::Vector2d(0, ipm.y_min())).x();
}

double StageEnv::WindowHalfWidthM(const DetectionPrior::Window& w) const {
  return std::clamp(w.half_width_m, 0.05, options.line_ransac.window_half_width_m);
}

void SortLeftToRight(std::vector<Lane>& lanes) {
  std::sort(lanes.begin(), lanes.end(),
            [](const Lane& a, const Lane& b) { return a.ground[3].x() < b.ground[3].x(); });
}

ChannelView ViewOfChannel(const cv::Mat& frame, Channel channel) {
  if (frame.channels() == 1) return ChannelView(frame);
  switch (channel) {
    case Channel::kRed:
      return ChannelView(frame, 2);
    case Channel::kGreen:
      return ChannelView(frame, 1);
    case Channel::kBlue:
      return ChannelView(frame, 0);
    case Channel::kMinRedGreen:
      return ChannelView(frame, 2, 1);
    case Channel::kGray:
      return ChannelView(frame, 0, kGrayOfBgr);  // computed where read
  }
  return ChannelView(frame, 2);
}

StageInputs TopViewInputs(const StageEnv& env) {
  const auto [top, bottom] = env.ipm.ImageRows();
  // Red alone needs only that channel; every other channel is computed
  // from the three.
  return {static_cast<double>(top), static_cast<double>(bottom) + 1,
          env.options.channel != Channel::kRed};
}

void TopView(const StageEnv& env, FrameContext& f) {
  f.channel = ViewOfChannel(f.frame, env.options.channel);
  f.channel.row_begin = f.top_row;
  f.channel.row_end = f.bottom_row;
  cv::Mat ipm = env.ipm.Apply(f.channel.image, f.channel.channel, f.channel.channel2);
  if (env.options.filter.void_level >= 0) {
    f.void_mask = VoidMask(ipm, env.ipm.invalid_mask(), env.options.filter.void_level);
    const double content_mean = cv::mean(ipm, ~f.void_mask)[0];
    ipm.setTo(content_mean, f.void_mask);
    ipm -= content_mean;
  } else {
    ipm -= cv::mean(ipm)[0];
  }
  f.top_view = ipm;
}

void Filter(const StageEnv& env, FrameContext& f) {
  const FilterOptions& fo = env.options.filter;
  cv::Mat filtered = FilterTopView(f.top_view, env.kernels, fo);
  if (f.void_mask.empty()) {
    CV_Assert(filtered.isContinuous() && filtered.type() == CV_32FC1);
    float* values = filtered.ptr<float>(0);
    for (const int32_t i : env.ipm.invalid_pixels()) values[i] = 0.f;
  } else {
    filtered.setTo(0, GrowMask(f.void_mask, env.kernels.kx.rows / 2, fo.void_margin_y_px));
  }
  if (fo.bar_side_m > 0) {
    SuppressSteps(f.top_view, filtered, fo.bar_side_m / env.ipm.metres_per_px_x(),
                  static_cast<int>(std::lround(env.kernels.sigma_y_px)));
  }
  f.filtered = filtered;
}

void Threshold(const StageEnv& env, FrameContext& f) {
  const DetectorOptions& opt = env.options;
  cv::Mat thresholded;
  f.threshold = ApplyQuantileThreshold(f.filtered, thresholded, opt.threshold.quantile);
  cv::Mat searched = env.ipm.valid_mask();  // the columns searched for lanes
  if (opt.mode == Mode::kTwo) {
    // Only the band around the camera can hold the ego lane's boundaries.
    const ColumnBand band =
        EgoBand(env.CameraColumn(), env.ipm.metres_per_px_x(), thresholded.cols, opt.two_lanes);
    KeepBand(band, thresholded);
    searched = env.ipm.valid_mask().clone();
    KeepBand(band, searched);
  }
  if (opt.threshold.transverse_max_fraction < 1) {
    SuppressTransverseRows(thresholded, searched, opt.threshold.transverse_max_fraction,
                           static_cast<int>(std::lround(opt.threshold.transverse_margin_m /
                                                        env.ipm.metres_per_px_y())));
  }
  f.thresholded = thresholded;
}

namespace {

// The column sums' peaks (2-lanes: the ego pair) without those inside
// `skip` (the refitted lanes'), and a RANSAC line in each one's window.
struct PeakLines {
  std::vector<ColumnPeak> peaks;
  std::vector<IpmLine> lines;
};

PeakLines FindLines(const StageEnv& env, const cv::Mat& thresholded, std::mt19937_64& rng,
                    const std::vector<ColumnSpan>& skip) {
  const DetectorOptions& opt = env.options;
  const double mpp_x = env.ipm.metres_per_px_x();
  PeakLines out;
  out.peaks = FindColumnPeaks(ColumnProfile(thresholded, opt.hough.smooth_sigma_px),
                              opt.hough.min_peak, opt.hough.group_distance_m / mpp_x);
  if (opt.mode == Mode::kTwo) {
    out.peaks = SelectEgoPair(out.peaks, env.CameraColumn(), mpp_x, opt.two_lanes);
  }
  // After the grouping and the ego pair, as without `skip`: only the peaks
  // of lanes found otherwise go.
  out.peaks.erase(std::remove_if(out.peaks.begin(), out.peaks.end(),
                                 [&](const ColumnPeak& p) {
                                   return std::any_of(skip.begin(), skip.end(),
                                                      [&](const ColumnSpan& s) {
                                                        return std::abs(p.x - s.centre) <= s.half;
                                                      });
                                 }),
                  out.peaks.end());
  for (const auto& peak : out.peaks) {
    if (auto line =
            FitLineInWindow(thresholded, peak.x, opt.line_ransac.window_half_width_m / mpp_x,
                            opt.line_ransac, rng)) {
      out.lines.push_back(*line);
    }
  }
  return out;
}

}  // namespace

void Lines(const StageEnv& env, FrameContext& f) {
  PeakLines found = FindLines(env, f.thresholded, f.rng, f.refitted.columns);
  f.peaks = std::move(found.peaks);
  f.lines = std::move(found.lines);
  const double spline_window_px =
      env.options.spline_ransac.window_half_width_m / env.ipm.metres_per_px_x();
  f.spline_half_px.assign(f.lines.size(), spline_window_px);
  // 4b. A tracker's predicted lanes that the Hough missed: their windows.
  if (f.prior != nullptr && !f.prior->windows.empty()) {
    PriorLines more = FindPriorLines(env, f.thresholded, *f.prior, f.lines, f.rng);
    f.lines.insert(f.lines.end(), more.lines.begin(), more.lines.end());
    f.spline_half_px.insert(f.spline_half_px.end(), more.half_widths_px.begin(),
                            more.half_widths_px.end());
  }
}

PriorLines FindPriorLines(const StageEnv& env, const cv::Mat& thresholded,
                          const DetectionPrior& prior, const std::vector<IpmLine>& lines,
                          std::mt19937_64& rng) {
  const DetectorOptions& opt = env.options;
  const double mpp_x = env.ipm.metres_per_px_x();
  const double spline_window_px = opt.spline_ransac.window_half_width_m / mpp_x;
  const double mid_row = 0.5 * (thresholded.rows - 1);
  // A predicted lane counts as found when a line of this frame runs inside
  // its window at mid height. The Hough keeps only the stronger of two
  // peaks closer than group_distance_m, so a line beside a stronger edge
  // (a yellow line 0.5 m from the asphalt's edge) is searched for in its
  // window, which is narrower.
  auto found_near = [&](const IpmLine& p, double half_px, const std::vector<IpmLine>& in) {
    return std::any_of(in.begin(), in.end(), [&](const IpmLine& l) {
      return std::abs(l.XAt(mid_row) - p.XAt(mid_row)) < half_px;
    });
  };
  // 2-lanes: only for a side of the camera that has no line yet, the
  // predicted lane nearest the camera on that side.
  const double camera = env.CameraColumn();
  std::vector<const DetectionPrior::Window*> todo;
  if (opt.mode == Mode::kTwo) {
    for (const int side : {-1, 1}) {
      const bool have = std::any_of(lines.begin(), lines.end(), [&](const IpmLine& l) {
        return (l.bottom.x() - camera) * side > 0;
      });
      if (have) continue;
      const DetectionPrior::Window* nearest = nullptr;
      for (const auto& w : prior.windows) {
        const double d = (w.line.bottom.x() - camera) * side;
        if (d > 0 && (nearest == nullptr || d < (nearest->line.bottom.x() - camera) * side)) {
          nearest = &w;
        }
      }
      if (nearest != nullptr) todo.push_back(nearest);
    }
  } else {
    for (const auto& w : prior.windows) todo.push_back(&w);
  }
  PriorLines added;
  for (const DetectionPrior::Window* w : todo) {
    const double half_px = env.WindowHalfWidthM(*w) / mpp_x;
    if (found_near(w->line, half_px, lines) || found_near(w->line, half_px, added.lines)) continue;
    if (auto line = FitLineAlong(thresholded, w->line, half_px, opt.line_ransac, rng)) {
      added.lines.push_back(*line);
      added.half_widths_px.push_back(std::min(half_px, spline_window_px));
    }
  }
  return added;
}

void Splines(const StageEnv& env, FrameContext& f) {
  f.candidates = FitSplines(env, f.thresholded, f.lines, f.spline_half_px, f.rng);
}

std::vector<SplineCandidate> FitSplines(const StageEnv& env, const cv::Mat& thresholded,
                                        const std::vector<IpmLine>& lines,
                                        const std::vector<double>& half_widths_px,
                                        std::mt19937_64& rng) {
  const SplineRansacOptions& so = env.options.spline_ransac;
  std::vector<SplineCandidate> candidates;
  for (size_t i = 0; i < lines.size(); ++i) {
    const IpmLine& line = lines[i];
    auto fit = FitSplineAroundLine(thresholded, line, half_widths_px[i], so, rng);
    if (!fit) continue;
    candidates.push_back({line, TopDown(fit->spline), Bezier{}, fit->score});
  }
  // Near-duplicates keep the straighter.
  std::sort(candidates.begin(), candidates.end(),
            [](const SplineCandidate& a, const SplineCandidate& b) {
              return a.ipm.Straightness() > b.ipm.Straightness();
            });
  std::vector<SplineCandidate> unique;
  for (const auto& c : candidates) {
    bool dup = false;
    for (const auto& u : unique) {
      dup = dup || MeanNearestDistanceBelow(c.ipm, u.ipm, so.merge_distance_px);
    }
    if (!dup) unique.push_back(c);
  }
  return unique;
}

StageInputs PostprocessInputs(const StageEnv& env) {
  // The extension's rows and the ROI's, widened by the longest profile
  // across a lane (its search either side, twice over for the bar's sides
  // and smoothing), since a slanted lane's profiles reach up and down.
  const CameraModel& cam = env.ipm.camera();
  const PostprocessOptions& pp = env.options.postprocess;
  const double scale = cam.image_width / 640.0;
  const ExtensionRows ext = ImageExtensionRows(cam, env.ipm.roi(), pp);
  const double margin =
      std::ceil(2 * std::max(pp.extend_search_px, pp.localize_search_px) * scale) + 8;
  // The colour check (max_redness < 1) reads all three channels.
  return {std::min(ext.min_row, env.ipm.roi().top) - margin,
          std::max(ext.max_row, env.ipm.roi().bottom) + margin + 1, pp.max_redness < 1};
}

void Postprocess(const StageEnv& env, FrameContext& f) {
  const DetectorOptions& opt = env.options;
  const PostprocessFrame images{env.ipm, f.top_view, f.filtered, f.channel, f.frame};
  std::vector<Lane> lanes = ToLanes(
      env, PostprocessCandidates(f.candidates, images, opt.postprocess, opt.filter.marking_width_m,
                                 opt.spline_ransac.merge_distance_px));
  if (!f.refitted.lanes.empty()) JoinRefitted(f.refitted, lanes);
  // 7b. Where the road model puts a boundary the first pass missed: search
  // its window again.
  SearchRoadModelWindows(env, f, images, lanes);
  AddInferredLanes(env, lanes);
  f.detection.lanes = std::move(lanes);
}

std::vector<Lane> ToLanes(const StageEnv& env, const std::vector<SplineCandidate>& done) {
  // Post-processing in the image changed the curve (localisation, extension),
  // so the top-view and ground forms are refitted from the final image
  // spline, which is the one that is reported and drawn.
  const CameraModel& cam = env.ipm.camera();
  const IpmMapping& ipm = env.ipm;
  std::vector<Lane> lanes;
  for (const auto& c : done) {
    Lane lane;
    lane.image = c.image.p;
    const auto ipm_fit =
        MapSpline(c.image, 21, [&ipm](const Eigen::Vector2d& p) { return ipm.ImageToIpm(p); });
    const auto ground_fit =
        MapSpline(c.image, 21, [&cam](const Eigen::Vector2d& p) { return cam.ImageToGround(p); });
    if (!ipm_fit || !ground_fit) continue;
    lane.ipm = ipm_fit->p;
    lane.ground = ground_fit->p;
    lane.score = c.score;
    lanes.push_back(lane);
  }
  SortLeftToRight(lanes);
  return lanes;
}

}  // namespace pipeline

size_t DetectorStageCount() { return std::size(pipeline::kStages); }

const char* DetectorStageName(size_t stage) {
  return stage < std::size(pipeline::kStages) ? pipeline::kStages[stage].name : "";
}

size_t StageTimings::IndexOf(absl::string_view name) {
  for (size_t i = 0; i < std::size(pipeline::kStages); ++i) {
    if (name == pipeline::kStages[i].name) return i;
  }
  return std::size(pipeline::kStages);
}

double StageTimings::Ms(absl::string_view name) const {
  const size_t i = IndexOf(name);
  return i < std::size(pipeline::kStages) ? stage_ms[i] : 0.0;
}

}  // namespace lane
