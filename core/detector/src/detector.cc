#include "lane/detector.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "lane/postprocess/candidate_checks.h"
#include "lane/postprocess/image_extension.h"

namespace lane {
namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Lanes left to right by their near end on the ground.
void SortLeftToRight(std::vector<Lane>& lanes) {
  std::sort(lanes.begin(), lanes.end(),
            [](const Lane& a, const Lane& b) { return a.ground[3].x() < b.ground[3].x(); });
}

}  // namespace

LanePathCounts CountLanePaths(const Detection& detection) {
  LanePathCounts counts;
  for (const Lane& lane : detection.lanes) {
    if (lane.predicted || lane.inferred) continue;
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

const char* MarkingColorName(MarkingColor color) {
  switch (color) {
    case MarkingColor::kWhite:
      return "white";
    case MarkingColor::kYellow:
      return "yellow";
    case MarkingColor::kUnknown:
      break;
  }
  return "unknown";
}

const char* MarkingTypeName(MarkingType type) {
  switch (type) {
    case MarkingType::kSolid:
      return "solid";
    case MarkingType::kDashed:
      return "dashed";
    case MarkingType::kDouble:
      return "double";
    case MarkingType::kRoadEdge:
      return "road_edge";
    case MarkingType::kUnknown:
      break;
  }
  return "unknown";
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
  // The top view's rows, and those of post-processing in the image: the
  // extension's rows, widened by the longest profile across a lane (its
  // search either side, twice over for the bar's sides and smoothing), since
  // a slanted lane's profiles reach up and down.
  const CameraModel& cam = ipm_.camera();
  const PostprocessOptions& pp = options_.postprocess;
  const double scale = cam.image_width / 640.0;
  const auto [ipm_top, ipm_bottom] = ipm_.ImageRows();
  const ExtensionRows ext = ImageExtensionRows(cam, ipm_.roi(), pp);
  const double margin =
      std::ceil(2 * std::max(pp.extend_search_px, pp.localize_search_px) * scale) + 8;
  const double top = std::min<double>(ipm_top, std::min(ext.min_row, ipm_.roi().top) - margin);
  const double bottom =
      std::max<double>(ipm_bottom + 1, std::max(ext.max_row, ipm_.roi().bottom) + margin + 1);
  FrameNeeds needs;
  needs.top = std::clamp(static_cast<int>(std::floor(top)), 0, cam.image_height - 1);
  needs.bottom = std::clamp(static_cast<int>(std::ceil(bottom)), needs.top + 1, cam.image_height);
  if (pp.max_redness >= 1 && options_.channel == Channel::kRed) {
    needs.pixels = FrameNeeds::Pixels::kRed;  // no colour check: red is all it reads
  }
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

cv::Mat Detector::TopView(const ChannelView& channel, cv::Mat* void_mask) const {
  cv::Mat ipm = ipm_.Apply(channel.image, channel.channel, channel.channel2);
  if (options_.filter.void_level >= 0) {
    *void_mask = VoidMask(ipm, ipm_.invalid_mask(), options_.filter.void_level);
    const double content_mean = cv::mean(ipm, ~*void_mask)[0];
    ipm.setTo(content_mean, *void_mask);
    ipm -= content_mean;
  } else {
    ipm -= cv::mean(ipm)[0];
  }
  return ipm;
}

cv::Mat Detector::Filter(const cv::Mat& top_view, const cv::Mat& void_mask) const {
  const FilterOptions& fo = options_.filter;
  cv::Mat filtered = FilterTopView(top_view, kernels_, fo);
  if (void_mask.empty()) {
    CV_Assert(filtered.isContinuous() && filtered.type() == CV_32FC1);
    float* f = filtered.ptr<float>(0);
    for (const int32_t i : ipm_.invalid_pixels()) f[i] = 0.f;
  } else {
    filtered.setTo(0, GrowMask(void_mask, kernels_.kx.rows / 2, fo.void_margin_y_px));
  }
  if (fo.bar_side_m > 0) {
    SuppressSteps(top_view, filtered, fo.bar_side_m / ipm_.metres_per_px_x(),
                  static_cast<int>(std::lround(kernels_.sigma_y_px)));
  }
  return filtered;
}

cv::Mat Detector::Threshold(const cv::Mat& filtered, float* threshold) const {
  cv::Mat thresholded;
  *threshold = ApplyQuantileThreshold(filtered, thresholded, options_.threshold.quantile);
  cv::Mat searched = ipm_.valid_mask();  // the columns searched for lanes
  if (options_.mode == Mode::kTwo) {
    // Only the band around the camera can hold the ego lane's boundaries.
    const ColumnBand band =
        EgoBand(CameraColumn(), ipm_.metres_per_px_x(), thresholded.cols, options_.two_lanes);
    KeepBand(band, thresholded);
    searched = ipm_.valid_mask().clone();
    KeepBand(band, searched);
  }
  if (options_.threshold.transverse_max_fraction < 1) {
    SuppressTransverseRows(thresholded, searched, options_.threshold.transverse_max_fraction,
                           static_cast<int>(std::lround(options_.threshold.transverse_margin_m /
                                                        ipm_.metres_per_px_y())));
  }
  return thresholded;
}

double Detector::WindowHalfWidthM(const DetectionPrior::Window& w) const {
  return std::clamp(w.half_width_m, 0.05, options_.line_ransac.window_half_width_m);
}

double Detector::CameraColumn() const {
  return ipm_.GroundToIpm(Eigen::Vector2d(0, ipm_.y_min())).x();
}

std::vector<IpmLine> Detector::FindLines(const cv::Mat& thresholded, std::mt19937_64& rng,
                                         std::vector<ColumnPeak>* peaks,
                                         const std::vector<ColumnSpan>& skip) const {
  const DetectorOptions& opt = options_;
  const double mpp_x = ipm_.metres_per_px_x();
  *peaks = FindColumnPeaks(ColumnProfile(thresholded, opt.hough.smooth_sigma_px),
                           opt.hough.min_peak, opt.hough.group_distance_m / mpp_x);
  if (opt.mode == Mode::kTwo) *peaks = SelectEgoPair(*peaks, CameraColumn(), mpp_x, opt.two_lanes);
  // After the grouping and the ego pair, as without `skip`: only the peaks
  // of lanes found otherwise go.
  peaks->erase(std::remove_if(peaks->begin(), peaks->end(),
                              [&](const ColumnPeak& p) {
                                return std::any_of(skip.begin(), skip.end(),
                                                   [&](const ColumnSpan& s) {
                                                     return std::abs(p.x - s.centre) <= s.half;
                                                   });
                              }),
               peaks->end());
  std::vector<IpmLine> lines;
  for (const auto& peak : *peaks) {
    if (auto line =
            FitLineInWindow(thresholded, peak.x, opt.line_ransac.window_half_width_m / mpp_x,
                            opt.line_ransac, rng)) {
      lines.push_back(*line);
    }
  }
  return lines;
}

std::vector<IpmLine> Detector::FindPriorLines(const cv::Mat& thresholded,
                                              const DetectionPrior& prior,
                                              const std::vector<IpmLine>& lines,
                                              std::vector<double>* half_widths_px,
                                              std::mt19937_64& rng) const {
  const DetectorOptions& opt = options_;
  const double mpp_x = ipm_.metres_per_px_x();
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
  const double camera = CameraColumn();
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
  std::vector<IpmLine> added;
  for (const DetectionPrior::Window* w : todo) {
    const double half_px = WindowHalfWidthM(*w) / mpp_x;
    if (found_near(w->line, half_px, lines) || found_near(w->line, half_px, added)) continue;
    if (auto line = FitLineAlong(thresholded, w->line, half_px, opt.line_ransac, rng)) {
      added.push_back(*line);
      half_widths_px->push_back(std::min(half_px, spline_window_px));
    }
  }
  return added;
}

std::vector<SplineCandidate> Detector::FitSplines(const cv::Mat& thresholded,
                                                  const std::vector<IpmLine>& lines,
                                                  const std::vector<double>& half_widths_px,
                                                  std::mt19937_64& rng) const {
  const SplineRansacOptions& so = options_.spline_ransac;
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

std::vector<Lane> Detector::ToLanes(const std::vector<SplineCandidate>& done) const {
  // Post-processing in the image changed the curve (localisation, extension),
  // so the top-view and ground forms are refitted from the final image
  // spline, which is the one that is reported and drawn.
  const CameraModel& cam = ipm_.camera();
  std::vector<Lane> lanes;
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
    lanes.push_back(lane);
  }
  SortLeftToRight(lanes);
  return lanes;
}

void Detector::AddInferredLanes(std::vector<Lane>& lanes) const {
  // Off (the default) or 2-lanes: nothing to do on this frame's path.
  if (options_.mode != Mode::kAll || !options_.road_model.infer_hidden) return;
  std::vector<Bezier> ground;
  ground.reserve(lanes.size());
  for (const Lane& lane : lanes) ground.push_back(Bezier{lane.ground});
  const std::vector<InferredBoundary> hidden = InferHiddenBoundaries(ground, options_.road_model);
  if (hidden.empty()) return;
  const CameraModel& cam = ipm_.camera();
  for (const InferredBoundary& h : hidden) {
    const auto image_fit =
        MapSpline(h.ground, 21, [&cam](const Eigen::Vector2d& p) { return cam.GroundToImage(p); });
    if (!image_fit) continue;
    const auto ipm_fit =
        MapSpline(*image_fit, 21, [this](const Eigen::Vector2d& p) { return ipm_.ImageToIpm(p); });
    if (!ipm_fit) continue;
    Lane lane;
    lane.image = image_fit->p;
    lane.ipm = ipm_fit->p;
    lane.ground = h.ground.p;
    lane.score = std::min(lanes[static_cast<size_t>(h.left)].score,
                          lanes[static_cast<size_t>(h.right)].score);
    lane.inferred = true;
    lanes.push_back(lane);
  }
  SortLeftToRight(lanes);
}

DetectionPrior Detector::RoadModelWindows(const std::vector<Lane>& lanes) const {
  DetectionPrior windows;
  RoadModelOptions model = options_.road_model;
  if (options_.mode != Mode::kAll || (!model.search_hidden && !model.search_outer) ||
      lanes.empty()) {
    return windows;
  }
  std::vector<Bezier> ground;
  ground.reserve(lanes.size());
  for (const Lane& lane : lanes) ground.push_back(Bezier{lane.ground});
  model.infer_hidden = true;  // where to search, whether or not inferred lanes are reported
  std::vector<Bezier> places;
  if (model.search_hidden) {
    for (const InferredBoundary& h : InferHiddenBoundaries(ground, model)) {
      places.push_back(h.ground);
    }
  }
  if (model.search_outer) {
    for (const Bezier& b : OuterBoundaryGuesses(ground, model)) places.push_back(b);
  }
  for (const Bezier& place : places) {
    const std::optional<LateralProfile> profile = LateralProfile::FromGround(place);
    if (!profile) continue;
    const double y0 = std::max(profile->y_near(), ipm_.y_min());
    const double y1 = std::min(profile->y_far(), ipm_.y_max());
    if (y1 - y0 < 1.0) continue;
    const Eigen::Vector2d a = ipm_.GroundToIpm({profile->XAt(y0), y0});
    const Eigen::Vector2d b = ipm_.GroundToIpm({profile->XAt(y1), y1});
    if (!a.allFinite() || !b.allFinite() || std::abs(a.y() - b.y()) < 1.0) continue;
    const std::optional<IpmLine> line = MakeIpmLine(a, b - a, ipm_.height());
    if (!line) continue;
    DetectionPrior::Window w;
    w.line = *line;
    w.half_width_m = model.search_half_width_m;
    windows.windows.push_back(w);
  }
  return windows;
}

cv::Mat Detector::ThresholdInWindows(const cv::Mat& filtered, const DetectionPrior& windows,
                                     float frame_threshold) const {
  cv::Mat out = cv::Mat::zeros(filtered.size(), CV_32F);
  const cv::Mat& valid = ipm_.valid_mask();
  const double mpp_x = ipm_.metres_per_px_x();
  std::vector<float> values;
  for (const DetectionPrior::Window& w : windows.windows) {
    const double half_px = w.half_width_m / mpp_x;
    auto span = [&](int r) {
      const double x = w.line.XAt(r);
      return std::pair<int, int>{std::max(0, static_cast<int>(std::ceil(x - half_px))),
                                 std::min(filtered.cols - 1, static_cast<int>(x + half_px))};
    };
    values.clear();
    for (int r = 0; r < filtered.rows; ++r) {
      const auto [c0, c1] = span(r);
      const float* f = filtered.ptr<float>(r);
      const uchar* v = valid.ptr<uchar>(r);
      for (int c = c0; c <= c1; ++c) {
        if (v[c] != 0) values.push_back(f[c]);
      }
    }
    if (values.size() < 16) continue;
    const float local =
        std::max(Quantile(values, options_.road_model.search_quantile),
                 static_cast<float>(options_.road_model.search_min_fraction * frame_threshold));
    for (int r = 0; r < filtered.rows; ++r) {
      const auto [c0, c1] = span(r);
      const float* f = filtered.ptr<float>(r);
      const uchar* v = valid.ptr<uchar>(r);
      float* o = out.ptr<float>(r);
      for (int c = c0; c <= c1; ++c) {
        if (v[c] != 0 && f[c] > local && f[c] > 0) o[c] = f[c];
      }
    }
  }
  return out;
}

namespace {

// Detector::Refit's limits. What a refit must show before it replaces the
// search: support in at least this share of the window's rows (a dashed
// line's dashes cover a quarter of its length, and the view can fall on a
// gap but for one dash) and over at least this many metres along the
// road; and points that lie on one line, within this share of a marking's
// width (RMS) of the refitted curve.
constexpr double kRefitMinRowShare = 0.15;
constexpr double kRefitMinSupportM = 1.5;
constexpr double kRefitMaxRmsMarkings = 0.75;
// A turn (heading change) is fitted only when the support spans at least
// this share of the rows; otherwise only a shift.
constexpr double kRefitMinSpanForTurn = 0.4;

// One row's response in a refit window: the column offset from the
// prediction (px) and its weight.
struct RefitPoint {
  double row = 0;
  double dx = 0;
  double weight = 0;
};

// Weighted least squares dx = a + b (row - mean row) over `points` (b = 0
// without `turn`), each point's weight times `keep`. Returns {a, b, mean}.
std::array<double, 3> FitShift(const std::vector<RefitPoint>& points, const std::vector<char>& keep,
                               bool turn) {
  double w = 0, wr = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if (!keep[i]) continue;
    w += points[i].weight;
    wr += points[i].weight * points[i].row;
  }
  const double mean = wr / w;
  double wx = 0, wrr = 0, wrx = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if (!keep[i]) continue;
    const double r = points[i].row - mean;
    wx += points[i].weight * points[i].dx;
    wrr += points[i].weight * r * r;
    wrx += points[i].weight * r * points[i].dx;
  }
  const double b = turn && wrr > 1e-9 ? wrx / wrr : 0.0;
  return {wx / w, b, mean};
}

// Each top-view row r0..r1's strongest response within half_px of
// `curve`, localised (the response's centroid over 5 columns around its
// peak), as its offset from the curve.
std::vector<RefitPoint> PeaksAlong(const cv::Mat& thresholded, const IpmMapping& ipm,
                                   const GroundCurve& curve, double half_px, int r0, int r1) {
  std::vector<RefitPoint> points;
  for (int r = r0; r <= r1; ++r) {
    const double y = ipm.IpmToGround({0.0, static_cast<double>(r)}).y();
    const double xp = ipm.GroundToIpm({curve.X(y), y}).x();
    const int c0 = std::max(0, static_cast<int>(std::ceil(xp - half_px)));
    const int c1 = std::min(thresholded.cols - 1, static_cast<int>(std::floor(xp + half_px)));
    const float* v = thresholded.ptr<float>(r);
    int best = -1;
    for (int c = c0; c <= c1; ++c) {
      if (v[c] > 0 && (best < 0 || v[c] > v[best])) best = c;
    }
    if (best < 0) continue;
    double sw = 0, swx = 0;
    for (int c = std::max(c0, best - 2); c <= std::min(c1, best + 2); ++c) {
      if (v[c] <= 0) continue;
      sw += v[c];
      swx += v[c] * c;
    }
    points.push_back({static_cast<double>(r), swx / sw - xp, static_cast<double>(v[best])});
  }
  return points;
}

}  // namespace

std::optional<Lane> Detector::RefitWindow(const cv::Mat& thresholded,
                                          const DetectionPrior::Window& w) const {
  if (!w.curve) return std::nullopt;
  const GroundCurve& curve = *w.curve;
  const double mpp_x = ipm_.metres_per_px_x();
  const double mpp_y = ipm_.metres_per_px_y();
  const double max_rms_px = kRefitMaxRmsMarkings * options_.filter.marking_width_m / mpp_x;
  auto row_of = [&](double y) { return ipm_.GroundToIpm({0.0, y}).y(); };
  const double y0 = std::max(curve.y_near, ipm_.y_min());
  const double y1 = std::min(curve.y_far, ipm_.y_max());
  const int r0 = std::max(0, static_cast<int>(std::ceil(row_of(y1))));
  const int r1 = std::min(thresholded.rows - 1, static_cast<int>(std::floor(row_of(y0))));
  const int rows = r1 - r0 + 1;
  if (rows <= 0) return std::nullopt;
  const double half_px = WindowHalfWidthM(w) / mpp_x;
  const std::vector<RefitPoint> points = PeaksAlong(thresholded, ipm_, curve, half_px, r0, r1);
  auto supported = [&](size_t n) {
    return static_cast<double>(n) >= kRefitMinRowShare * rows &&
           static_cast<double>(n) * mpp_y >= kRefitMinSupportM;
  };
  if (!supported(points.size())) return std::nullopt;
  const bool turn = points.back().row - points.front().row >= kRefitMinSpanForTurn * (rows - 1);
  std::vector<char> keep(points.size(), 1);
  std::array<double, 3> fit = FitShift(points, keep, turn);
  auto rms = [&]() {
    double sw = 0, swe = 0;
    for (size_t i = 0; i < points.size(); ++i) {
      if (!keep[i]) continue;
      const double e = points[i].dx - fit[0] - fit[1] * (points[i].row - fit[2]);
      sw += points[i].weight;
      swe += points[i].weight * e * e;
    }
    return std::sqrt(swe / sw);
  };
  // Once more without the points farther than two RMS (at least a marking's
  // width) from the first fit: a stray blob in the window.
  const double cut = std::max(2.0 * rms(), max_rms_px / kRefitMaxRmsMarkings);
  size_t kept = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const double e = points[i].dx - fit[0] - fit[1] * (points[i].row - fit[2]);
    keep[i] = std::abs(e) <= cut;
    kept += keep[i];
  }
  if (!supported(kept)) return std::nullopt;
  fit = FitShift(points, keep, turn);
  if (rms() > max_rms_px) return std::nullopt;

  // dx (px) is linear in the row and the row in y: a shift and a turn of
  // the curve on the ground.
  GroundCurve refit = curve;
  refit.coefficients(0) += mpp_x * (fit[0] + fit[1] * (row_of(0.0) - fit[2]));
  refit.coefficients(1) += -mpp_x * fit[1] / mpp_y;
  std::optional<Lane> lane = LaneAlongCurve(refit, ipm_, /*near_first=*/false);
  if (!lane) return std::nullopt;
  lane->refit = true;
  for (size_t i = 0; i < points.size(); ++i) {
    if (keep[i]) lane->score += points[i].weight;
  }
  return lane;
}

Detector::Refitted Detector::RefitTracked(const cv::Mat& thresholded,
                                          const DetectionPrior& prior) const {
  const DetectorOptions& opt = options_;
  const double mpp_x = ipm_.metres_per_px_x();
  Refitted out;
  for (const DetectionPrior::Window& w : prior.windows) {
    std::optional<Lane> lane = w.refit ? RefitWindow(thresholded, w) : std::nullopt;
    if (!lane) {
      out.failed += w.refit && w.curve.has_value();
      out.rest.windows.push_back(w);
      continue;
    }
    const double half_m = WindowHalfWidthM(w);
    out.lanes.push_back(*lane);
    out.half_widths_m.push_back(half_m);
    // The column a column sum puts the lane at: its mean over the rows.
    double sum = 0;
    for (int r = 0; r < thresholded.rows; ++r) {
      const double y = ipm_.IpmToGround({0.0, static_cast<double>(r)}).y();
      sum += ipm_.GroundToIpm({w.curve->X(y), y}).x();
    }
    out.columns.push_back({sum / thresholded.rows, (half_m + opt.filter.marking_width_m) / mpp_x});
  }
  return out;
}

void Detector::JoinRefitted(const Refitted& refitted, std::vector<Lane>& lanes) const {
  // What the search found along a refitted lane (beyond its window, or by
  // its extension in the image) is that lane again.
  auto duplicate = [&](const Lane& lane) {
    for (size_t i = 0; i < refitted.lanes.size(); ++i) {
      if (MeanNearestDistanceBelow(Bezier{lane.ground}, Bezier{refitted.lanes[i].ground},
                                   refitted.half_widths_m[i])) {
        return true;
      }
    }
    return false;
  };
  lanes.erase(std::remove_if(lanes.begin(), lanes.end(), duplicate), lanes.end());
  lanes.insert(lanes.end(), refitted.lanes.begin(), refitted.lanes.end());
  SortLeftToRight(lanes);
}

void Detector::SearchRoadModelWindows(const cv::Mat& filtered, float threshold,
                                      const std::vector<IpmLine>& lines,
                                      const PostprocessFrame& images, std::mt19937_64& rng,
                                      std::vector<Lane>& lanes) const {
  const DetectorOptions& opt = options_;
  const DetectionPrior hidden = RoadModelWindows(lanes);
  if (hidden.windows.empty()) return;
  const cv::Mat local = ThresholdInWindows(filtered, hidden, threshold);
  std::vector<double> more_half_px;
  const std::vector<IpmLine> more = FindPriorLines(local, hidden, lines, &more_half_px, rng);
  if (more.empty()) return;
  const std::vector<SplineCandidate> extra = FitSplines(local, more, more_half_px, rng);
  const std::vector<Lane> seen =
      ToLanes(PostprocessCandidates(extra, images, opt.postprocess, opt.filter.marking_width_m,
                                    opt.spline_ransac.merge_distance_px));
  // What survives the same post-processing is kept where it fits the road.
  std::vector<Bezier> found;
  for (const Lane& lane : lanes) found.push_back(Bezier{lane.ground});
  const size_t first = lanes.size();
  for (const Lane& lane : seen) {
    if (!FitsRoadModel(Bezier{lane.ground}, found, ipm_.y_min(), ipm_.y_max(), opt.road_model)) {
      continue;
    }
    lanes.push_back(lane);
    found.push_back(Bezier{lane.ground});
  }
  if (lanes.size() > first) SortLeftToRight(lanes);
}

absl::StatusOr<Detection> Detector::Detect(const cv::Mat& frame,
                                           const DetectionPrior* prior) const {
  if (absl::Status s = CheckFrame(frame); !s.ok()) return s;
  const DetectorOptions& opt = options_;
  Detection det;
  StageTimings& time = det.timings;
  const auto t_start = Clock::now();
  std::mt19937_64 rng(opt.seed);
  auto t = Clock::now();
  // Times the stage that just ended into `field`.
  auto lap = [&t](double& field) {
    field = MsSince(t);
    t = Clock::now();
  };

  // 1. Channel (the rows this detector reads) and top view, mean removed.
  ChannelView channel = ViewChannel(frame);
  channel.row_begin = needs_.top;
  channel.row_end = needs_.bottom;
  cv::Mat void_mask;  // empty: no void handling beyond the ROI's
  const cv::Mat top_view = TopView(channel, &void_mask);
  lap(time.ipm_ms);
  // 2. Filter.
  const cv::Mat filtered = Filter(top_view, void_mask);
  lap(time.filter_ms);
  // 3. Threshold (2-lanes: the ego band only).
  float threshold = 0;
  const cv::Mat thresholded = Threshold(filtered, &threshold);
  lap(time.threshold_ms);
  // 3b. Tracked frames (prior->refit): each confirmed lane seen last frame
  // refitted in its window, which the search then leaves alone; the other
  // windows are searched below.
  Refitted refitted;
  if (prior != nullptr && prior->refit) {
    refitted = RefitTracked(thresholded, *prior);
    prior = &refitted.rest;
    det.refit_lanes = static_cast<int>(refitted.lanes.size());
    det.refit_failed = refitted.failed;
    lap(time.refit_ms);
  }
  // 4-5. Column-sum Hough (2-lanes: the ego pair), then RANSAC lines.
  std::vector<ColumnPeak> peaks;
  std::vector<IpmLine> lines = FindLines(thresholded, rng, &peaks, refitted.columns);
  // 4b. A tracker's predicted lanes that the Hough missed: their windows.
  const double spline_window_px = opt.spline_ransac.window_half_width_m / ipm_.metres_per_px_x();
  std::vector<double> spline_half_px(lines.size(), spline_window_px);
  if (prior != nullptr && !prior->windows.empty()) {
    const std::vector<IpmLine> more =
        FindPriorLines(thresholded, *prior, lines, &spline_half_px, rng);
    lines.insert(lines.end(), more.begin(), more.end());
  }
  lap(time.lines_ms);
  // 6. RANSAC splines around each line.
  const std::vector<SplineCandidate> candidates =
      FitSplines(thresholded, lines, spline_half_px, rng);
  lap(time.splines_ms);
  // 7. Post-processing in the top view and the image; 8. the three frames.
  const PostprocessFrame images{ipm_, top_view, filtered, channel, frame};
  det.lanes =
      ToLanes(PostprocessCandidates(candidates, images, opt.postprocess, opt.filter.marking_width_m,
                                    opt.spline_ransac.merge_distance_px));
  if (!refitted.lanes.empty()) JoinRefitted(refitted, det.lanes);
  // 7b. Where the road model puts a boundary the first pass missed: search
  // its window again.
  SearchRoadModelWindows(filtered, threshold, lines, images, rng, det.lanes);
  AddInferredLanes(det.lanes);
  lap(time.postprocess_ms);
  time.total_ms = MsSince(t_start);

  if (opt.keep_intermediates) {
    Intermediates in;
    in.ipm = top_view;
    in.filtered = filtered;
    in.thresholded = thresholded;
    in.threshold = threshold;
    in.peaks = peaks;
    in.lines = lines;
    for (const auto& c : candidates) in.ipm_splines.push_back(c.ipm);
    det.debug = std::move(in);
  }
  return det;
}

}  // namespace lane
