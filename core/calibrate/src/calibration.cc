#include "lane/calibrate/calibration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "frame_intake.h"
#include "lane/calibrate/vanishing_point.h"

namespace lane {
namespace {

// The upper of the two middle values for an even count, 0 for none.
double UpperMedian(std::vector<double> v) {
  if (v.empty()) return 0;
  const size_t h = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(h), v.end());
  return v[h];
}

}  // namespace

CameraModel CameraFromVanishingPoint(const CameraModel& intrinsics, const Eigen::Vector2d& vp) {
  CameraModel c = intrinsics;
  const double pitch = std::atan((c.cv - vp.y()) / c.fv);
  const double yaw = std::atan((c.cu - vp.x()) * std::cos(pitch) / c.fu);
  c.pitch_deg = pitch / kDegToRad;
  c.yaw_deg = yaw / kDegToRad;
  return c;
}

// ---------------------------------------------------------------------------
// RoadRowFinder

void RoadRowFinder::Add(const cv::Mat& frame) {
  cv::Mat grey = frame;
  if (frame.channels() == 3) cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
  cv::Mat small;
  cv::resize(grey, small,
             cv::Size(std::max(1, grey.cols / kScale), std::max(1, grey.rows / kScale)), 0, 0,
             cv::INTER_AREA);
  cv::Mat x;
  small.convertTo(x, CV_64F);
  if (frames_ == 0 || x.size() != mean_.size()) {
    mean_ = cv::Mat::zeros(x.size(), CV_64F);
    m2_ = cv::Mat::zeros(x.size(), CV_64F);
    frames_ = 0;
    height_ = grey.rows;
    width_ = grey.cols;
  }
  ++frames_;
  const cv::Mat delta = x - mean_;
  mean_ += delta / frames_;
  m2_ += delta.mul(x - mean_);
}

std::vector<double> RoadRowFinder::RowSpread() const {
  std::vector<double> spread;
  if (frames_ < 2) return spread;
  for (int r = 0; r < m2_.rows; ++r) {
    std::vector<double> s(static_cast<size_t>(m2_.cols));
    const double* m = m2_.ptr<double>(r);
    for (int c = 0; c < m2_.cols; ++c) s[static_cast<size_t>(c)] = std::sqrt(m[c] / (frames_ - 1));
    spread.push_back(UpperMedian(std::move(s)));
  }
  return spread;
}

double RoadRowFinder::RoadLevel(const std::vector<double>& spread) const {
  const int rows = static_cast<int>(spread.size());
  std::vector<double> road(spread.begin() + rows / 2, spread.begin() + rows * 7 / 8);
  return UpperMedian(road);
}

int RoadRowFinder::RoadBottomRow() const {
  if (frames_ < kMinFrames) return height_;
  int bottom = height_;
  const std::vector<double> spread = RowSpread();
  const int rows = static_cast<int>(spread.size());
  const double level = RoadLevel(spread);
  if (level <= 0) return bottom;
  // From the bottom up: the first run of 2 rows at half the road's level or
  // more ends the still band.
  for (int r = rows - 1; r >= 1; --r) {
    if (spread[static_cast<size_t>(r)] >= 0.5 * level &&
        spread[static_cast<size_t>(r - 1)] >= 0.5 * level) {
      if (r < rows - 1) bottom = std::min(bottom, (r + 1) * kScale);
      break;
    }
  }
  return bottom;
}

RoadOutline RoadRowFinder::Outline() const {
  RoadOutline outline;
  if (frames_ < kMinFrames) return outline;
  const double level = RoadLevel(RowSpread());
  if (level <= 0) return outline;
  const int rows = m2_.rows, cols = m2_.cols;
  const int bands = std::max(1, cols / kBandColumns);
  // Per band, the still rows at its bottom, as RoadBottomRow finds them for
  // the whole image: the band's spread per row is the median over its columns.
  std::vector<double> band_bottom(static_cast<size_t>(bands));
  std::vector<double> s;
  for (int b = 0; b < bands; ++b) {
    const int c0 = b * cols / bands, c1 = (b + 1) * cols / bands;
    auto band_spread = [&](int r) {
      s.clear();
      const double* m = m2_.ptr<double>(r);
      for (int c = c0; c < c1; ++c) s.push_back(std::sqrt(m[c] / (frames_ - 1)));
      return UpperMedian(s);
    };
    // No moving rows at all: the band shows no road (outside a lens's
    // image circle, a mount).
    band_bottom[static_cast<size_t>(b)] = 0;
    bool previous = band_spread(rows - 1) >= 0.5 * level;
    for (int r = rows - 2; r >= 0; --r) {
      const bool moving = band_spread(r) >= 0.5 * level;
      if (moving && previous) {
        band_bottom[static_cast<size_t>(b)] = r + 1 < rows - 1 ? (r + 2) * kScale : height_;
        break;
      }
      previous = moving;
    }
  }
  // A hood is smooth across the image: a band's lone value is noise.
  std::vector<double> smooth(band_bottom.size());
  for (int b = 0; b < bands; ++b) {
    std::vector<double> w;
    for (int k = std::max(0, b - 2); k <= std::min(bands - 1, b + 2); ++k) {
      w.push_back(band_bottom[static_cast<size_t>(k)]);
    }
    smooth[static_cast<size_t>(b)] = UpperMedian(std::move(w));
  }
  // Linear between the bands' centres (in full-size columns).
  outline.first_row_below.resize(static_cast<size_t>(width_));
  const double band_width = static_cast<double>(width_) / bands;
  for (int u = 0; u < width_; ++u) {
    const double t = std::clamp((u + 0.5) / band_width - 0.5, 0.0, bands - 1.0);
    const int b0 = static_cast<int>(std::floor(t));
    const int b1 = std::min(bands - 1, b0 + 1);
    const double f = t - b0;
    outline.first_row_below[static_cast<size_t>(u)] =
        (1 - f) * smooth[static_cast<size_t>(b0)] + f * smooth[static_cast<size_t>(b1)];
  }
  return outline;
}

// ---------------------------------------------------------------------------
// Ground view

absl::StatusOr<GroundView> ChooseGroundView(const CameraModel& camera, double lane_width_m,
                                            const RoadOutline& outline) {
  GroundViewRule rule;
  rule.lane_width_m = lane_width_m;
  absl::StatusOr<DerivedGroundView> d = DeriveGroundView(camera, outline, rule);
  if (!d.ok()) return d.status();
  return d->view;
}

// ---------------------------------------------------------------------------
// CameraCalibrator

absl::Status CameraCalibrator::AddFirstPass(const cv::Mat& frame) {
  if (absl::Status s = calibrate_internal::CheckCalibrationFrame(frame, width_, height_); !s.ok()) {
    return s;
  }
  if (width_ == 0) {
    width_ = frame.cols;
    height_ = frame.rows;
    intrinsics_ = calibrate_internal::StartingCamera(options_, width_, height_);
    focal_assumed_ = !options_.focal_px;
    if (absl::Status s = intrinsics_.Validate(); !s.ok()) return s;
  }
  const cv::Mat paint = PaintChannel(frame);
  // A frame (nearly) equal to the previous one: the car stands.
  cv::Mat small = calibrate_internal::StandstillThumbnail(paint);
  const bool still = calibrate_internal::SameView(small, previous_);
  previous_ = std::move(small);
  stationary_.push_back(still);
  if (!still) {
    road_rows_.Add(paint);
    static_finder_.Add(paint);
  }
  MarkingSegmentOptions o;
  o.top_row = static_cast<int>(0.6 * height_);
  o.fixed_widths_px = FixedBarWidths(width_);
  first_segments_.push_back(FindMarkingSegments(paint, o));
  return absl::OkStatus();
}

absl::Status CameraCalibrator::FinishFirstPass() {
  road_bottom_ = road_rows_.RoadBottomRow();
  outline_ = road_rows_.Outline();
  if (options_.road_bottom_row) {
    road_bottom_ = std::clamp(*options_.road_bottom_row, 1, height_);
    outline_ = RoadOutline::Flat(road_bottom_, width_);
  }
  first_pass_ = {};
  first_pass_.static_structure = static_finder_.Finish();
  std::vector<std::vector<ImageSegment>> moving;
  std::vector<int> moving_frames;
  for (size_t i = 0; i < first_segments_.size(); ++i) {
    if (stationary_[i]) continue;
    std::vector<ImageSegment>& segs = first_segments_[i];
    // Not the hood: it mirrors the road.
    segs.erase(
        std::remove_if(segs.begin(), segs.end(),
                       [&](const ImageSegment& s) { return s.bottom_row >= road_bottom_ - 1; }),
        segs.end());
    // Nor what is fixed to the camera: it votes for one point in every frame.
    for (ImageSegment& s : first_pass_.static_structure.TakeCovered(segs)) {
      first_pass_.static_segments.emplace_back(static_cast<int>(i), std::move(s));
    }
    moving.push_back(std::move(segs));
    moving_frames.push_back(static_cast<int>(i));
  }
  first_segments_.clear();
  static_segments_ = static_cast<int>(first_pass_.static_segments.size());
  VanishingPointOptions vo = options_.vanishing_point;
  vo.focal_px = intrinsics_.fu;
  vo.bounds = SearchBounds();
  const std::optional<PooledVanishingPoint> p = EstimatePooledVanishingPoint(moving, vo);
  if (!p) {
    return absl::FailedPreconditionError(
        "no frame showed two or more straight lane markings below the horizon");
  }
  first_point_ = p->point;
  first_pass_.point = p->point;
  for (const auto& [frame, k] : p->supporting) {
    const size_t f = static_cast<size_t>(frame);
    first_pass_.support.emplace_back(moving_frames[f], moving[f][static_cast<size_t>(k)]);
  }
  first_done_ = true;
  return absl::OkStatus();
}

cv::Rect2d CameraCalibrator::SearchBounds() const {
  // A forward-looking road camera sees the vanishing point in its frame, or
  // a little outside it: a quarter of the size to each side and above.
  return {-0.25 * width_, -0.25 * height_, 1.5 * width_, 1.25 * height_};
}

MarkingSegmentOptions CameraCalibrator::SecondPassSegments() const {
  MarkingSegmentOptions o;
  o.horizon_row = first_point_.y();
  o.height_m = options_.height_m;
  o.top_row = static_cast<int>(std::ceil(first_point_.y() + std::max(10.0, 0.04 * height_)));
  o.bottom_row = road_bottom_;
  return o;
}

absl::StatusOr<FrameVanishingPoint> CameraCalibrator::AddSecondPass(
    const cv::Mat& frame, std::vector<ImageSegment>* segments_out) {
  if (!first_done_) return absl::FailedPreconditionError("the first pass is not finished");
  if (frame.cols != width_ || frame.rows != height_) {
    return absl::InvalidArgumentError(absl::StrCat("frame is ", frame.cols, "x", frame.rows,
                                                   ", the first was ", width_, "x", height_));
  }
  const size_t index = static_cast<size_t>(second_frames_++);
  ++frames_;
  if (index < stationary_.size() && stationary_[index]) {
    ++stationary_count_;
    FrameVanishingPoint still;
    still.result = VpFrameResult::kStationary;
    return still;
  }
  std::vector<ImageSegment> segs = FindMarkingSegments(frame, SecondPassSegments());
  static_segments_ += static_cast<int>(first_pass_.static_structure.TakeCovered(segs).size());
  VanishingPointOptions vo = options_.vanishing_point;
  vo.focal_px = intrinsics_.fu;
  vo.prior = first_point_;
  vo.bounds = SearchBounds();
  FrameVanishingPoint p = EstimateFrameVanishingPoint(segs, vo);
  switch (p.result) {
    case VpFrameResult::kOk:
      points_.push_back(p.point);
      point_frames_.push_back(static_cast<int>(index));
      segments_ += p.inliers;
      break;
    case VpFrameResult::kCurved:
      ++curved_;
      break;
    case VpFrameResult::kNoMarkings:
      ++no_markings_;
      break;
    case VpFrameResult::kElsewhere:
      elsewhere_points_.push_back(p.point);
      break;
    case VpFrameResult::kStationary:
      break;
  }
  if (segments_out) *segments_out = std::move(segs);
  return p;
}

absl::StatusOr<CalibrationResult> CameraCalibrator::Finish() const {
  const int elsewhere = static_cast<int>(elsewhere_points_.size());
  if (elsewhere > static_cast<int>(points_.size())) {
    const std::optional<CombinedVanishingPoint> other = CombineVanishingPoints(elsewhere_points_);
    return absl::FailedPreconditionError(absl::StrFormat(
        "the first pass put the vanishing point at (%.1f, %.1f), but only %d frames' markings "
        "meet there and %d frames' meet elsewhere (median near (%.1f, %.1f)): the first pass "
        "was led by edges that are not lane markings",
        first_point_.x(), first_point_.y(), static_cast<int>(points_.size()), elsewhere,
        other->point.x(), other->point.y()));
  }
  const std::optional<CombinedVanishingPoint> c = CombineVanishingPoints(points_, 1.0);
  if (!c) {
    return absl::FailedPreconditionError(
        absl::StrCat("none of ", frames_, " frames gave a vanishing point (", no_markings_,
                     " without two consistent markings, ", curved_, " on curves, ",
                     stationary_count_, " standing still)"));
  }
  if (c->frames_used < kMinFramesUsed) {
    return absl::FailedPreconditionError(absl::StrCat(
        "only ", c->frames_used, " of ", frames_, " frames gave a vanishing point (", no_markings_,
        " without two consistent markings, ", curved_, " on curves, ", stationary_count_,
        " standing still); at least ", kMinFramesUsed, " are needed"));
  }
  CalibrationResult r;
  r.vanishing_point = *c;
  r.first_pass_point = first_point_;
  r.camera = CameraFromVanishingPoint(intrinsics_, c->point);
  r.focal_assumed = focal_assumed_;
  r.frames = frames_;
  r.frames_no_markings = no_markings_;
  r.frames_curved = curved_;
  r.frames_elsewhere = elsewhere;
  r.frames_stationary = stationary_count_;
  r.segments = segments_;
  r.static_segments = static_segments_;
  // The rows a top view may read: from the horizon's margin to the hood.
  r.static_mask = first_pass_.static_structure.BoxesInRows(
      c->point.y() + IpmOptions().horizon_margin_px, road_bottom_);
  r.road_bottom_row = road_bottom_;
  r.outline = outline_;
  r.far_point = r.camera.GroundToImage({0.0, 1e5});
  for (int k : c->used) r.used_frames.push_back(point_frames_[static_cast<size_t>(k)]);
  const Eigen::Vector2d systematic(intrinsics_.fu * std::tan(kSystematicIntervalDeg * kDegToRad),
                                   intrinsics_.fv * std::tan(kSystematicIntervalDeg * kDegToRad));
  const Eigen::Vector2d spread = BootstrapInterval(points_, 1.0);
  r.interval_px = (spread.cwiseProduct(spread) + systematic.cwiseProduct(systematic)).cwiseSqrt();
  // The interval in degrees: the cameras at the interval's ends.
  const CameraModel du =
      CameraFromVanishingPoint(intrinsics_, c->point + Eigen::Vector2d(r.interval_px.x(), 0));
  const CameraModel dv =
      CameraFromVanishingPoint(intrinsics_, c->point + Eigen::Vector2d(0, r.interval_px.y()));
  r.yaw_interval_deg = std::abs(du.yaw_deg - r.camera.yaw_deg);
  r.pitch_interval_deg = std::abs(dv.pitch_deg - r.camera.pitch_deg);
  absl::StatusOr<GroundView> view = ChooseGroundView(r.camera, options_.lane_width_m, outline_);
  if (!view.ok()) return view.status();
  r.view = *view;
  return r;
}

// ---------------------------------------------------------------------------
// Self-check

LaneGeometryCheckOptions GeometryCheckForWidth(double lane_width_m) {
  LaneGeometryCheckOptions o;
  o.min_lane_width_m = std::min(o.min_lane_width_m, lane_width_m - 0.5);
  o.max_lane_width_m = std::max(o.max_lane_width_m, lane_width_m + 0.5);
  return o;
}

std::vector<GroundChord> LaneChords(const std::vector<Lane>& lanes) {
  std::vector<GroundChord> out;
  for (const Lane& l : lanes) {
    GroundChord c{l.ground[0], l.ground[3]};
    if (c.near.y() > c.far.y()) std::swap(c.near, c.far);
    out.push_back(c);
  }
  return out;
}

std::vector<GroundChord> LaneChords(const std::vector<std::array<Eigen::Vector2d, 2>>& image_ends,
                                    const CameraModel& camera) {
  std::vector<GroundChord> out;
  const double horizon = camera.HorizonRow();
  for (const std::array<Eigen::Vector2d, 2>& e : image_ends) {
    if (e[0].y() <= horizon + 1.0 || e[1].y() <= horizon + 1.0) continue;  // above the road
    GroundChord c{camera.ImageToGround(e[0]), camera.ImageToGround(e[1])};
    if (c.near.y() > c.far.y()) std::swap(c.near, c.far);
    out.push_back(c);
  }
  return out;
}

absl::StatusOr<CalibrationSelfCheck> CalibrationSelfCheck::Create(const CalibrationResult& result,
                                                                  double lane_width_m) {
  absl::StatusOr<Detector> detector = Detector::Create(result.camera, GroundViewIpm(result.view),
                                                       DetectorOptions::ForMode(Mode::kAll));
  if (!detector.ok()) return detector.status();
  return CalibrationSelfCheck(*std::move(detector), GeometryCheckForWidth(lane_width_m));
}

absl::Status CalibrationSelfCheck::AddFrame(const cv::Mat& frame) {
  absl::StatusOr<Detection> d = detector_.Detect(frame);
  if (!d.ok()) return d.status();
  check_.AddFrame(LaneChords(d->lanes));
  return absl::OkStatus();
}

// ---------------------------------------------------------------------------
// Online refinement

std::optional<Eigen::Vector2d> LanesVanishingPoint(const std::vector<Lane>& lanes,
                                                   double max_bend_px, double min_spread_deg) {
  std::vector<Eigen::Vector2d> points, dirs;
  std::vector<double> weights;
  double lo = M_PI, hi = -M_PI;
  for (const Lane& lane : lanes) {
    const Eigen::Vector2d a = lane.image[0], b = lane.image[3];
    const Eigen::Vector2d chord = b - a;
    const double length = chord.norm();
    if (length < 20.0) continue;
    const Eigen::Vector2d d = chord / length;
    const Eigen::Vector2d normal(-d.y(), d.x());
    const double bend =
        std::max(std::abs(normal.dot(lane.image[1] - a)), std::abs(normal.dot(lane.image[2] - a)));
    if (bend > max_bend_px) continue;
    points.push_back(0.5 * (a + b));
    dirs.push_back(d);
    weights.push_back(length);
    const Eigen::Vector2d up = d.y() > 0 ? Eigen::Vector2d(-d) : d;
    const double angle = std::atan2(up.x(), -up.y());
    lo = std::min(lo, angle);
    hi = std::max(hi, angle);
  }
  if (points.size() < 2 || hi - lo < min_spread_deg * kDegToRad) return std::nullopt;
  return IntersectLines(points, dirs, weights);
}

OnlineCalibrator::OnlineCalibrator(const CameraModel& initial, OnlineCalibrationOptions options)
    : initial_(initial), applied_(initial), options_(options), vp_(initial.VanishingPoint()) {}

CameraModel OnlineCalibrator::camera() const { return CameraFromVanishingPoint(initial_, vp_); }

bool OnlineCalibrator::Observe(const std::vector<Lane>& lanes) {
  ++frames_seen_;
  if (options_.check_frames > 0) {
    std::vector<std::array<Eigen::Vector2d, 2>> ends;
    for (const Lane& l : lanes) ends.push_back({l.image[0], l.image[3]});
    recent_.push_back(std::move(ends));
    while (static_cast<int>(recent_.size()) > options_.check_frames) recent_.pop_front();
  }
  const std::optional<Eigen::Vector2d> p =
      LanesVanishingPoint(lanes, options_.max_bend_px, options_.min_spread_deg);
  if (!p) return false;
  const double fu = initial_.fu, fv = initial_.fv;
  const Eigen::Vector2d delta = *p - vp_;
  const Eigen::Vector2d delta_deg(std::atan(delta.x() / fu) / kDegToRad,
                                  std::atan(delta.y() / fv) / kDegToRad);
  if (delta_deg.norm() > options_.gate_deg) return false;
  ++frames_used_;
  const double sq = delta_deg.squaredNorm();
  if (frames_used_ * options_.gain < 1.0) {
    var_deg2_ += (sq - var_deg2_) / frames_used_;
  } else {
    var_deg2_ += options_.gain * (sq - var_deg2_);
  }
  // A bounded step towards the frame's point.
  const double max_u = fu * std::tan(options_.max_step_deg * kDegToRad);
  const double max_v = fv * std::tan(options_.max_step_deg * kDegToRad);
  const Eigen::Vector2d step(std::clamp(options_.gain * delta.x(), -max_u, max_u),
                             std::clamp(options_.gain * delta.y(), -max_v, max_v));
  vp_ += step;
  // Never further than max_drift_deg from the initial camera.
  CameraModel c = camera();
  const double d = options_.max_drift_deg;
  c.pitch_deg = std::clamp(c.pitch_deg, initial_.pitch_deg - d, initial_.pitch_deg + d);
  c.yaw_deg = std::clamp(c.yaw_deg, initial_.yaw_deg - d, initial_.yaw_deg + d);
  vp_ = c.VanishingPoint();
  if (std::abs(c.pitch_deg - applied_.pitch_deg) >= options_.rederive_deg ||
      std::abs(c.yaw_deg - applied_.yaw_deg) >= options_.rederive_deg) {
    if (options_.check_frames > 0) {
      // The candidate passes, or at least improves on the camera in use (a
      // session started with a camera that is off moves towards the truth
      // through candidates that are still off).
      auto report = [&](const CameraModel& camera) {
        LaneGeometryCheck check(options_.check);
        for (const auto& frame : recent_) check.AddFrame(LaneChords(frame, camera));
        return check.Report();
      };
      LaneGeometryReport candidate = report(c);
      if (!candidate.verdict.ok()) {
        const LaneGeometryReport applied = report(applied_);
        auto error = [](const LaneGeometryReport& r) {
          return std::abs(r.heading_deg) + std::abs(r.divergence_deg);
        };
        const bool improves = candidate.frames_with_pair >= options_.check.min_frames &&
                              candidate.frames_with_pair >= applied.frames_with_pair &&
                              (applied.frames_with_pair == 0 || error(candidate) < error(applied));
        if (!improves) {
          ++refused_;
          last_refusal_ = std::move(candidate.verdict);
          return false;
        }
      }
    }
    ++rederived_;
    applied_ = c;
    return true;
  }
  return false;
}

double OnlineCalibrator::uncertainty_deg() const {
  if (frames_used_ == 0) return std::numeric_limits<double>::infinity();
  const double n_eff = std::min<double>(frames_used_, (2.0 - options_.gain) / options_.gain);
  return std::sqrt(var_deg2_ / n_eff);
}

double OnlineCalibrator::confidence() const {
  if (frames_used_ == 0) return 0;
  return std::clamp(1.0 - uncertainty_deg(), 0.0, 1.0);
}

}  // namespace lane
