#include "lane/detector.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "lane/candidate_checks.h"
#include "lane/image_extension.h"

namespace lane {
namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

constexpr double kRadToDeg = 180.0 / M_PI;

// Angle of the chord P0->P3 from vertical, degrees.
double AngleFromVerticalDeg(const Bezier& s) {
  const Eigen::Vector2d d = s.p[3] - s.p[0];
  return std::atan2(std::abs(d.x()), std::abs(d.y())) * kRadToDeg;
}

// Orders the control points so that P0 is the upper (farther) end.
Bezier TopDown(Bezier s) {
  if (s.p[0].y() > s.p[3].y()) {
    std::swap(s.p[0], s.p[3]);
    std::swap(s.p[1], s.p[2]);
  }
  return s;
}

// Least-squares Bezier through samples of `s` mapped by `f`.
template <typename Fn>
std::optional<Bezier> MapSpline(const Bezier& s, int n, Fn f) {
  std::vector<Eigen::Vector2d> pts;
  pts.reserve(n);
  for (const auto& p : s.Sample(n)) {
    const Eigen::Vector2d q = f(p);
    if (q.allFinite()) pts.push_back(q);
  }
  return FitBezier(pts);
}

// Mean distance from samples of the shorter spline to the nearest samples of
// the other: small when one lies along the other.
double MeanNearestDistance(const Bezier& a, const Bezier& b) {
  const bool a_shorter = a.Length() < b.Length();
  const auto from = (a_shorter ? a : b).Sample(21);
  const auto to = (a_shorter ? b : a).Sample(101);
  double sum = 0;
  for (const auto& p : from) {
    double best = 1e300;
    for (const auto& q : to) best = std::min(best, (p - q).squaredNorm());
    sum += std::sqrt(best);
  }
  return sum / from.size();
}

bool PassesShapeChecks(const Bezier& s, double min_length, double min_straightness) {
  return s.Length() >= min_length && s.Straightness() >= min_straightness;
}

struct Candidate {
  IpmLine line;
  Bezier ipm;    // spline in the top view
  Bezier image;  // spline in the image
  double score = 0;
};

}  // namespace

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

absl::Status TwoLaneOptions::Validate() const {
  if (!(search_half_width_m > 0 && search_half_width_m < 20)) {
    return absl::InvalidArgumentError("two_lanes.search_half_width_m must lie in (0, 20) metres");
  }
  if (!(lane_width_m > 0 && lane_width_m < 20 && lane_width_sigma_m > 0)) {
    return absl::InvalidArgumentError(
        "two_lanes.lane_width_m must lie in (0, 20) metres and lane_width_sigma_m be > 0");
  }
  if (!(min_pair_score >= 0 && min_pair_score <= 1)) {
    return absl::InvalidArgumentError("two_lanes.min_pair_score must lie in [0, 1]");
  }
  return absl::OkStatus();
}

DetectorOptions DetectorOptions::ForMode(Mode mode) {
  DetectorOptions o;
  o.mode = mode;
  if (mode == Mode::kTwo) {
    // The reference's bracketed 2-lanes values, converted to metres at the
    // Caltech camera's 8.9 IPM px per metre.
    o.threshold.quantile = 0.985;
    o.hough.min_peak *= 1.5;  // reference: 6 instead of 4
    o.hough.group_distance_m = 1.7;
    o.line_ransac.window_half_width_m = 0.9;
    o.line_ransac.iterations = 40;
    o.spline_ransac.window_half_width_m = 0.67;
    o.spline_ransac.iterations = 75;
    o.spline_ransac.k2 = 1.0;
    // The ego lane's band (+-2.9 m) holds its two boundaries: 2 x 0.25 m of
    // kept pixels in 5.8 m is 8.6 % of a row (threshold.h).
    o.threshold.transverse_max_fraction = 0.15;
  }
  return o;
}

absl::Status DetectorOptions::Validate() const {
  for (const absl::Status& s :
       {filter.Validate(), threshold.Validate(), hough.Validate(), line_ransac.Validate(),
        spline_ransac.Validate(), postprocess.Validate(), two_lanes.Validate()}) {
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
  return Detector(*std::move(mapping), options, std::move(kernels));
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
  if (frame.channels() == 1) return ChannelView(frame);
  switch (options_.channel) {
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
  return ChannelView(ExtractChannel(frame));
}

absl::StatusOr<Detection> Detector::Detect(const cv::Mat& frame) const {
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
  const DetectorOptions& opt = options_;
  const PostprocessOptions& pp = opt.postprocess;
  Detection det;
  const auto t_start = Clock::now();
  std::mt19937_64 rng(opt.seed);

  // 1. Channel and top view, mean removed.
  auto t = Clock::now();
  const ChannelView channel = ViewChannel(frame);
  cv::Mat ipm = ipm_.Apply(channel.image, channel.channel, channel.channel2);
  cv::Mat void_mask;  // empty: no void handling beyond the ROI's
  if (opt.filter.void_level >= 0) {
    void_mask = VoidMask(ipm, ipm_.invalid_mask(), opt.filter.void_level);
    const double content_mean = cv::mean(ipm, ~void_mask)[0];
    ipm.setTo(content_mean, void_mask);
    ipm -= content_mean;
  } else {
    ipm -= cv::mean(ipm)[0];
  }
  det.timings.ipm_ms = MsSince(t);

  // 2. Filter.
  t = Clock::now();
  cv::Mat filtered = FilterTopView(ipm, kernels_, opt.filter);
  if (void_mask.empty()) {
    filtered.setTo(0, ipm_.invalid_mask());
  } else {
    filtered.setTo(0, GrowMask(void_mask, kernels_.kx.rows / 2, opt.filter.void_margin_y_px));
  }
  if (opt.filter.bar_side_m > 0) {
    SuppressSteps(ipm, filtered, opt.filter.bar_side_m / ipm_.metres_per_px_x(),
                  static_cast<int>(std::lround(kernels_.sigma_y_px)));
  }
  det.timings.filter_ms = MsSince(t);

  // 3. Threshold.
  t = Clock::now();
  cv::Mat thresholded = filtered.clone();
  const float threshold = ApplyQuantileThreshold(thresholded, opt.threshold.quantile);
  const double cam_col = ipm_.GroundToIpm(Eigen::Vector2d(0, ipm_.y_min())).x();
  cv::Mat searched = ipm_.valid_mask();  // the columns searched for lanes
  if (opt.mode == Mode::kTwo) {
    // Only the band around the camera can hold the ego lane's boundaries.
    const double half = opt.two_lanes.search_half_width_m / ipm_.metres_per_px_x();
    const int c0 = std::clamp(static_cast<int>(std::ceil(cam_col - half)), 0, thresholded.cols);
    const int c1 =
        std::clamp(static_cast<int>(std::floor(cam_col + half)) + 1, 0, thresholded.cols);
    if (c0 > 0) thresholded.colRange(0, c0).setTo(0);
    if (c1 < thresholded.cols) thresholded.colRange(c1, thresholded.cols).setTo(0);
    searched = ipm_.valid_mask().clone();
    if (c0 > 0) searched.colRange(0, c0).setTo(0);
    if (c1 < searched.cols) searched.colRange(c1, searched.cols).setTo(0);
  }
  if (opt.threshold.transverse_max_fraction < 1) {
    SuppressTransverseRows(
        thresholded, searched, opt.threshold.transverse_max_fraction,
        static_cast<int>(std::lround(opt.threshold.transverse_margin_m / ipm_.metres_per_px_y())));
  }
  det.timings.threshold_ms = MsSince(t);

  // 4-5. Column-sum Hough, then RANSAC lines.
  t = Clock::now();
  const double mpp_x = ipm_.metres_per_px_x();
  std::vector<ColumnPeak> peaks =
      FindColumnPeaks(ColumnProfile(thresholded, opt.hough.smooth_sigma_px), opt.hough.min_peak,
                      opt.hough.group_distance_m / mpp_x);
  if (opt.mode == Mode::kTwo && peaks.size() > 1) {
    // The best pair straddling the camera whose spacing looks like one lane.
    double best = -1;
    std::vector<ColumnPeak> chosen;
    for (size_t i = 0; i < peaks.size(); ++i) {
      for (size_t j = i + 1; j < peaks.size(); ++j) {
        if (!(peaks[i].x < cam_col && peaks[j].x > cam_col)) continue;
        const double d = (peaks[j].x - peaks[i].x) * mpp_x - opt.two_lanes.lane_width_m;
        const double s = opt.two_lanes.lane_width_sigma_m;
        const double width_score = std::exp(-d * d / (2 * s * s));
        if (width_score < opt.two_lanes.min_pair_score) continue;
        const double score = width_score * (peaks[i].value + peaks[j].value);
        if (score > best) {
          best = score;
          chosen = {peaks[i], peaks[j]};
        }
      }
    }
    if (chosen.empty()) {
      chosen = {*std::max_element(
          peaks.begin(), peaks.end(),
          [](const ColumnPeak& a, const ColumnPeak& b) { return a.value < b.value; })};
    }
    peaks = chosen;
  }
  std::vector<IpmLine> lines;
  for (const auto& peak : peaks) {
    if (auto line =
            FitLineInWindow(thresholded, peak.x, opt.line_ransac.window_half_width_m / mpp_x,
                            opt.line_ransac, rng)) {
      lines.push_back(*line);
    }
  }
  det.timings.lines_ms = MsSince(t);

  // 6. RANSAC splines around each line; near-duplicates keep the straighter.
  t = Clock::now();
  std::vector<Candidate> cands;
  for (const auto& line : lines) {
    auto fit = FitSplineAroundLine(thresholded, line, opt.spline_ransac.window_half_width_m / mpp_x,
                                   opt.spline_ransac, rng);
    if (!fit) continue;
    cands.push_back({line, TopDown(fit->spline), Bezier{}, fit->score});
  }
  std::vector<Candidate> unique;
  std::sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& b) {
    return a.ipm.Straightness() > b.ipm.Straightness();
  });
  for (const auto& c : cands) {
    bool dup = false;
    for (const auto& u : unique) {
      dup = dup || MeanNearestDistance(c.ipm, u.ipm) < opt.spline_ransac.merge_distance_px;
    }
    if (!dup) unique.push_back(c);
  }
  cands = std::move(unique);
  det.timings.splines_ms = MsSince(t);

  // 7. Post-processing, first in the top view, then in the image.
  t = Clock::now();
  const double ipm_min_len = pp.min_length_fraction * ipm_.height();
  const double scale = cam.image_width / 640.0;
  const ExtensionRows rows = ImageExtensionRows(cam, ipm_.roi(), pp);
  const double min_row = rows.min_row;
  const double max_row = rows.max_row;
  std::vector<Candidate> done;
  std::vector<Bezier> cand_splines;
  for (const Candidate& c : cands) cand_splines.push_back(c.ipm);
  const TopViewCheckContext check_context = MakeTopViewCheckContext(cand_splines, ipm, ipm_, pp);
  for (Candidate c : cands) {
    if (AngleFromVerticalDeg(c.ipm) > pp.ipm_max_angle_from_vertical_deg) continue;
    const Bezier ipm_line = Bezier::Line(c.line.top, c.line.bottom);
    // Top view: localise, check, extend, check.
    double contrast = 0;
    if (auto loc = LocalizeSpline(c.ipm, filtered, pp.localize_points, pp.ipm_normal_search_px, 0.0,
                                  pp.localize_min_cos, &contrast)) {
      c.ipm = TopDown(*loc);
    }
    if (!PassesShapeChecks(c.ipm, ipm_min_len, pp.min_straightness)) c.ipm = ipm_line;
    if (pp.extend_in_ipm && contrast > 0) {
      ExtendOptions eo;
      eo.step_px = pp.ipm_extend_step_px;
      eo.search_px = pp.ipm_normal_search_px;
      eo.sigma_px = 0;
      eo.min_contrast = pp.continuation_threshold * contrast;
      eo.min_cos_start = pp.extend_min_cos_up;
      eo.min_cos_end = pp.extend_min_cos_down;
      c.ipm = TopDown(ExtendSpline(c.ipm, filtered, eo));
      if (!PassesShapeChecks(c.ipm, ipm_min_len, pp.min_straightness)) c.ipm = ipm_line;
    }
    if (AngleFromVerticalDeg(c.ipm) > pp.ipm_max_angle_from_vertical_deg) continue;
    if (pp.min_side_contrast > 0 &&
        BarContrast(c.ipm, ipm, pp.side_offset_m / mpp_x) < pp.min_side_contrast) {
      continue;  // a step (curb, road edge), not a bright marking
    }
    if (!PassesTopViewChecks(c.ipm, ipm, ipm_, pp, check_context)) continue;

    // Image: back-project, localise, check, extend, check.
    auto to_image = [this](const Eigen::Vector2d& p) { return ipm_.IpmToImage(p); };
    const auto image_line = MapSpline(ipm_line, 4, to_image);
    auto image = MapSpline(c.ipm, pp.backproject_samples, to_image);
    if (!image || !image_line) continue;
    c.image = TopDown(*image);
    const Bezier fallback = TopDown(*image_line);
    const double min_len = pp.min_image_length_px * scale;
    contrast = 0;
    if (pp.localize_in_image && pp.localize_geometric) {
      if (auto loc =
              LocalizeInImage(c.image, channel, cam, pp.localize_points, pp.localize_search_m,
                              pp.localize_sigma_m, pp.profile_sigma_px * scale,
                              2 * pp.localize_search_px * scale, pp.localize_min_cos)) {
        c.image = TopDown(*loc);
      }
      if (!PassesShapeChecks(c.image, min_len, pp.min_straightness)) c.image = fallback;
    } else if (pp.localize_in_image) {
      if (auto loc =
              LocalizeSpline(c.image, channel, pp.localize_points, pp.localize_search_px * scale,
                             pp.profile_sigma_px * scale, pp.localize_min_cos, &contrast)) {
        c.image = TopDown(*loc);
      }
      if (!PassesShapeChecks(c.image, min_len, pp.min_straightness)) c.image = fallback;
    }
    if (pp.extend_in_image && pp.extend_geometric) {
      c.image = TopDown(ExtendInImage(
          c.image, channel, cam,
          ImageExtendOptionsFrom(pp, scale, min_row, max_row, opt.filter.marking_width_m)));
      if (!PassesShapeChecks(c.image, min_len, pp.min_straightness)) c.image = fallback;
    } else if (pp.extend_in_image && contrast > 0) {
      ExtendOptions eo;
      eo.step_px = pp.extend_step_px * scale;
      eo.search_px = pp.extend_search_px * scale;
      eo.sigma_px = pp.profile_sigma_px * scale;
      eo.min_contrast = pp.continuation_threshold * contrast;
      eo.min_cos_start = pp.extend_min_cos_up;
      eo.min_cos_end = pp.extend_min_cos_down;
      eo.min_row = min_row;
      eo.max_row = max_row;
      c.image = TopDown(ExtendSpline(c.image, channel, eo));
      if (!PassesShapeChecks(c.image, min_len, pp.min_straightness)) c.image = fallback;
    }
    const std::optional<Bezier> finished =
        FinishImageSpline(c.image, channel, frame, cam, pp, scale);
    if (!finished) continue;
    c.image = *finished;
    bool dup = false;
    for (const auto& d : done) {
      dup = dup || MeanNearestDistance(c.image, d.image) <
                       opt.spline_ransac.merge_distance_px * scale * 2.5;
    }
    if (!dup) done.push_back(c);
  }

  // 8. Every spline in the three frames.
  for (const auto& c : done) {
    Lane lane;
    lane.image = c.image.p;
    const auto ipm_fit =
        MapSpline(c.image, 21, [this](const Eigen::Vector2d& p) { return ipm_.ImageToIpm(p); });
    const auto ground_fit =
        MapSpline(c.image, 21, [&cam](const Eigen::Vector2d& p) { return cam.ImageToGround(p); });
    if (!ipm_fit || !ground_fit) continue;
    lane.ipm = ipm_fit->p;
    lane.ground = ground_fit->p;
    lane.score = c.score;
    det.lanes.push_back(lane);
  }
  std::sort(det.lanes.begin(), det.lanes.end(),
            [](const Lane& a, const Lane& b) { return a.ground[3].x() < b.ground[3].x(); });
  det.timings.postprocess_ms = MsSince(t);
  det.timings.total_ms = MsSince(t_start);

  if (opt.keep_intermediates) {
    Intermediates in;
    in.ipm = ipm;
    in.filtered = filtered;
    in.thresholded = thresholded;
    in.threshold = threshold;
    in.peaks = peaks;
    in.lines = lines;
    for (const auto& c : cands) in.ipm_splines.push_back(c.ipm);
    det.debug = std::move(in);
  }
  return det;
}

}  // namespace lane
