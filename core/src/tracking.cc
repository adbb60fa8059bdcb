#include "lane/tracking.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <tuple>

#include "lane/bezier.h"

namespace lane {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

// The camera's image <-> ground maps as homographies, built once per call
// from four points (the camera's own transforms evaluate trigonometry at
// every point).
struct PlaneMaps {
  Eigen::Matrix3d to_ground, to_image;

  explicit PlaneMaps(const CameraModel& camera) {
    const double v0 = std::max(camera.HorizonRow() + 10.0, 0.0);
    const double v1 = std::max<double>(camera.image_height - 1, v0 + 1.0);
    std::vector<cv::Point2f> image = {
        {0.0f, static_cast<float>(v0)},
        {static_cast<float>(camera.image_width - 1), static_cast<float>(v0)},
        {0.0f, static_cast<float>(v1)},
        {static_cast<float>(camera.image_width - 1), static_cast<float>(v1)}};
    std::vector<cv::Point2f> ground;
    for (const cv::Point2f& q : image) {
      const Eigen::Vector2d g = camera.ImageToGround({q.x, q.y});
      ground.emplace_back(static_cast<float>(g.x()), static_cast<float>(g.y()));
    }
    const cv::Mat h = cv::getPerspectiveTransform(image, ground);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) to_ground(r, c) = h.at<double>(r, c);
    }
    to_image = to_ground.inverse();
  }
  static Eigen::Vector2d Apply(const Eigen::Matrix3d& m, const Eigen::Vector2d& p) {
    const Eigen::Vector3d q = m * Eigen::Vector3d(p.x(), p.y(), 1.0);
    return q.head<2>() / q.z();
  }
  Eigen::Vector2d Ground(const Eigen::Vector2d& p) const { return Apply(to_ground, p); }
  Eigen::Vector2d Image(const Eigen::Vector2d& g) const { return Apply(to_image, g); }
};

// Where to read a 15 cm marking at image point p of a lane: its row and
// column, its width in pixels, the paint window (a quarter width each side)
// and the road windows 1.5 widths to its left and right. None when the
// marking is narrower than min_width_px or wider than an eighth of the
// frame, or a window leaves the frame.
struct BarWindows {
  int row = 0, u = 0;
  double width_px = 0;
  int half = 0, off = 0, span = 0;  // paint u +- half; road u -+ off .. off + span
};

std::optional<BarWindows> BarWindowsAt(const PlaneMaps& maps, const Eigen::Vector2d& p, int cols,
                                       double min_width_px) {
  BarWindows b;
  b.row = static_cast<int>(std::lround(p.y()));
  const Eigen::Vector2d g = maps.Ground(p);
  b.width_px = (maps.Image(g + Eigen::Vector2d(0.15, 0.0)) - p).norm();
  const double w = b.width_px;
  if (!(w >= min_width_px) || w > cols / 8.0) return std::nullopt;
  b.u = static_cast<int>(std::lround(p.x()));
  b.half = std::max(0, static_cast<int>(w / 4));
  b.off = static_cast<int>(std::ceil(1.5 * w));
  b.span = std::max(1, static_cast<int>(w / 2));
  if (b.u - b.off - b.span < 0 || b.u + b.off + b.span >= cols) return std::nullopt;
  return b;
}

Bezier GroundBezier(const Lane& lane) {
  Bezier b;
  for (int k = 0; k < 4; ++k) b.p[k] = lane.ground[k];
  return b;
}

// Mean |a(y) - b(y)| over the common extent (or b's when they barely meet).
double LateralDistance(const GroundCurve& a, const GroundCurve& b) {
  double lo = std::max(a.y_near, b.y_near), hi = std::min(a.y_far, b.y_far);
  if (hi - lo < 1.0) {
    lo = b.y_near;
    hi = b.y_far;
  }
  double sum = 0;
  constexpr int kSamples = 8;
  for (int i = 0; i < kSamples; ++i) {
    const double y = lo + (hi - lo) * i / (kSamples - 1);
    sum += std::abs(a.X(y) - b.X(y));
  }
  return sum / kSamples;
}

// Kalman update of a track with a detected lane: the measurement is the
// lane's lateral position at points spread over its extent, each with
// standard deviation measured_x_sd + measured_x_sd_per_m * y, so that a
// short lane says little of the curvature and the heading it implies at
// the camera. Robust (Huber): a point whose innovation lies more than
// huber_k standard deviations from the prediction has its variance scaled
// by |r| / huber_k, so that it pulls the track as if it lay huber_k
// standard deviations off (one pass, the points taken one by one: a
// spline that runs off at its far end, across a dash and a stain).
void KalmanUpdate(const Lane& lane, const LaneTrackingOptions& options, Track* track) {
  constexpr int kPoints = 6;
  const std::vector<Eigen::Vector2d> pts = GroundBezier(lane).Sample(kPoints);
  Eigen::Matrix<double, kPoints, 3> h;
  Eigen::Matrix<double, kPoints, 1> z;
  for (int i = 0; i < kPoints; ++i) {
    const double y = pts[static_cast<size_t>(i)].y();
    h.row(i) << 1.0, y, 0.5 * y * y;
    z(i) = pts[static_cast<size_t>(i)].x();
  }
  if (!h.allFinite() || !z.allFinite()) return;
  const Eigen::Matrix3d& p = track->covariance;
  const Eigen::Matrix<double, kPoints, 1> innovation = z - h * track->curve.coefficients;
  Eigen::Matrix<double, kPoints, kPoints> s = h * p * h.transpose();
  for (int i = 0; i < kPoints; ++i) {
    const double e = options.measured_x_sd + options.measured_x_sd_per_m * std::max(0.0, h(i, 1));
    double variance = e * e;
    if (options.huber_k > 0) {
      const double r = std::abs(innovation(i)) / std::sqrt(s(i, i) + variance);
      if (r > options.huber_k) variance *= r / options.huber_k;
    }
    s(i, i) += variance;
  }
  const Eigen::Matrix<double, 3, kPoints> gain = p * h.transpose() * s.inverse();
  track->curve.coefficients += gain * innovation;
  track->covariance = (Eigen::Matrix3d::Identity() - gain * h) * p;
}

LaneIdentity IdentityOf(const Track& track) {
  LaneIdentity out;
  out.id = track.id;
  out.confirmed = track.Reported();
  out.curve = track.curve;
  out.covariance = track.covariance;
  const std::array<double, 5>& v = track.type_votes;
  const double solid = v[static_cast<size_t>(MarkingType::kSolid)];
  const double dashed = v[static_cast<size_t>(MarkingType::kDashed)];
  size_t best = 0;
  for (size_t k = 1; k < v.size(); ++k) {
    if (v[k] > v[best]) best = k;
  }
  out.type = v[best] > 0 ? static_cast<MarkingType>(best) : MarkingType::kUnknown;
  if ((out.type == MarkingType::kSolid || out.type == MarkingType::kDashed) && dashed > 0 &&
      dashed >= 0.3 * (solid + dashed)) {
    out.type = MarkingType::kDashed;
  }
  if (track.yellow_votes > track.white_votes) {
    out.color = MarkingColor::kYellow;
  } else if (track.white_votes > track.yellow_votes) {
    out.color = MarkingColor::kWhite;
  }
  return out;
}

}  // namespace

std::optional<GroundCurve> FitGroundCurve(const Lane& lane) {
  const std::vector<Eigen::Vector2d> pts = GroundBezier(lane).Sample(20);
  double lo = pts[0].y(), hi = pts[0].y();
  for (const Eigen::Vector2d& p : pts) {
    lo = std::min(lo, p.y());
    hi = std::max(hi, p.y());
  }
  if (!(hi - lo >= 1.0) || !std::isfinite(lo) || !std::isfinite(hi)) return std::nullopt;
  // Curvature only when the lane is long enough to show it.
  const int terms = hi - lo >= 6.0 ? 3 : 2;
  Eigen::MatrixXd a(static_cast<Eigen::Index>(pts.size()), terms);
  Eigen::VectorXd x(static_cast<Eigen::Index>(pts.size()));
  for (size_t i = 0; i < pts.size(); ++i) {
    const double y = pts[i].y();
    const auto r = static_cast<Eigen::Index>(i);
    a(r, 0) = 1.0;
    a(r, 1) = y;
    if (terms == 3) a(r, 2) = 0.5 * y * y;
    x(r) = pts[i].x();
  }
  const Eigen::VectorXd c = a.colPivHouseholderQr().solve(x);
  if (!c.allFinite()) return std::nullopt;
  GroundCurve g;
  g.coefficients.head(terms) = c;
  g.y_near = lo;
  g.y_far = hi;
  return g;
}

// ---------------------------------------------------------------------------
// LaneTracker

LaneTracker::LaneTracker(LaneTrackingOptions options) : options_(options) {}

void LaneTracker::Reset() {
  tracks_.clear();
  started_ = false;
  ++resets_;
}

void LaneTracker::MarkParallel() {
  constexpr double kPi = 3.14159265358979323846;
  constexpr double kMinExtentM = 4.0;  // shorter pieces say little of a direction
  for (Track& t : tracks_) t.parallel = true;
  if (options_.parallel_max_deg <= 0) return;
  const double max_rad = options_.parallel_max_deg * kPi / 180.0;
  auto slope_at = [](const Track& t, double y) {
    return t.curve.coefficients(1) + t.curve.coefficients(2) * y;
  };
  std::vector<bool> parallel(tracks_.size(), true);
  for (size_t i = 0; i < tracks_.size(); ++i) {
    const Track& t = tracks_[i];
    const double ym = 0.5 * (t.curve.y_near + t.curve.y_far);
    std::vector<double> others;
    for (size_t k = 0; k < tracks_.size(); ++k) {
      const Track& o = tracks_[k];
      if (k == i || !o.confirmed || o.misses > 0 || o.curve.y_far - o.curve.y_near < kMinExtentM) {
        continue;
      }
      others.push_back(std::atan(slope_at(o, ym)));
    }
    if (others.size() < 2) continue;
    const auto mid = others.begin() + static_cast<std::ptrdiff_t>(others.size() / 2);
    std::nth_element(others.begin(), mid, others.end());
    double median = *mid;
    if (others.size() % 2 == 0) median = 0.5 * (median + *std::max_element(others.begin(), mid));
    parallel[i] = std::abs(std::atan(slope_at(t, ym)) - median) <= max_rad;
  }
  for (size_t i = 0; i < tracks_.size(); ++i) tracks_[i].parallel = parallel[i];
}

void LaneTracker::Predict(double dt) {
  const Eigen::Vector3d q(options_.offset_noise, options_.heading_noise, options_.curvature_noise);
  const Eigen::Matrix3d noise = (q.cwiseProduct(q) * dt).asDiagonal();
  for (Track& t : tracks_) t.covariance += noise;
}

std::vector<LaneIdentity> LaneTracker::Update(const std::vector<Lane>& lanes,
                                              std::optional<double> time_s,
                                              const std::vector<MarkingColor>& colors,
                                              const std::vector<MarkingType>& types) {
  const double frame_dt = 1.0 / std::max(1e-3, options_.default_fps);
  const double t = time_s.value_or(started_ ? time_s_ + frame_dt : 0.0);
  double dt = started_ ? t - time_s_ : frame_dt;
  if (started_ && (dt < 0 || dt > options_.max_gap_s)) {
    Reset();  // a new clip, or the camera was away too long
    dt = frame_dt;
  }
  started_ = true;
  ++frame_;
  time_s_ = t;
  Predict(dt);

  std::vector<std::optional<GroundCurve>> curves;
  for (const Lane& lane : lanes) curves.push_back(FitGroundCurve(lane));

  // One to one, best pairs first, within the gate.
  std::vector<std::tuple<double, size_t, size_t>> pairs;
  for (size_t i = 0; i < tracks_.size(); ++i) {
    for (size_t j = 0; j < curves.size(); ++j) {
      if (!curves[j]) continue;
      const double cost = LateralDistance(tracks_[i].curve, *curves[j]);
      if (cost < options_.gate_m) pairs.emplace_back(cost, i, j);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  std::vector<int> track_of(lanes.size(), -1);
  std::vector<bool> matched(tracks_.size(), false);
  for (const auto& [cost, i, j] : pairs) {
    if (matched[i] || track_of[j] >= 0) continue;
    matched[i] = true;
    track_of[j] = static_cast<int>(i);
  }

  // Type votes fade, so that a dashed line turning solid is followed.
  const double fade = std::exp(-dt / std::max(1e-3, options_.type_memory_s));
  for (Track& track : tracks_) {
    for (double& v : track.type_votes) v *= fade;
  }
  auto vote = [&](Track& track, size_t j) {
    if (j < types.size() && types[j] != MarkingType::kUnknown) {
      track.type_votes[static_cast<size_t>(types[j])] += 1;
    }
    if (j >= colors.size()) return;
    if (colors[j] == MarkingColor::kWhite) track.white_votes += 1;
    if (colors[j] == MarkingColor::kYellow) track.yellow_votes += 1;
  };
  // A track takes lane j of this frame.
  auto take = [&](Track& track, size_t j) {
    KalmanUpdate(lanes[j], options_, &track);
    track.curve.y_near = curves[j]->y_near;
    track.curve.y_far = curves[j]->y_far;
    ++track.hits;
    track.last_hit_frame = frame_;
    track.misses = 0;
    track.confirmed = track.confirmed || track.hits >= options_.confirm_frames;
    vote(track, j);
  };
  for (size_t j = 0; j < lanes.size(); ++j) {
    if (track_of[j] >= 0) take(tracks_[static_cast<size_t>(track_of[j])], j);
  }
  for (size_t i = 0; i < tracks_.size(); ++i) {
    if (!matched[i]) ++tracks_[i].misses;
  }
  // New tracks for the lanes no track took.
  for (size_t j = 0; j < lanes.size(); ++j) {
    if (track_of[j] >= 0 || !curves[j]) continue;
    Track track;
    track.id = next_id_++;
    track.born_frame = frame_;
    track.last_hit_frame = frame_;
    track.hits = 1;
    track.confirmed = options_.confirm_frames <= 1;
    // The prior: the lane's fitted offset and heading, loosely, and a
    // straight road; the first measurement then sets what it shows.
    track.curve = *curves[j];
    track.curve.coefficients(2) = 0.0;
    const Eigen::Vector3d prior(options_.prior_offset_sd, options_.prior_heading_sd,
                                options_.prior_curvature_sd);
    track.covariance = prior.cwiseProduct(prior).asDiagonal();
    KalmanUpdate(lanes[j], options_, &track);
    vote(track, j);
    tracks_.push_back(track);
    track_of[j] = static_cast<int>(tracks_.size()) - 1;
  }

  // Two tracks on one boundary (a detection that left the gate for a frame
  // started a second one, or it was missed): the one seen less often ends,
  // and a lane it holds this frame passes to the other, which has none.
  for (size_t a = 0; a < tracks_.size(); ++a) {
    for (size_t b = 0; b < tracks_.size(); ++b) {
      if (a == b || tracks_[a].misses >= options_.max_misses ||
          tracks_[b].misses >= options_.max_misses) {
        continue;
      }
      const bool b_weaker = tracks_[b].hits < tracks_[a].hits ||
                            (tracks_[b].hits == tracks_[a].hits && tracks_[b].id > tracks_[a].id);
      if (!b_weaker ||
          LateralDistance(tracks_[a].curve, tracks_[b].curve) >= options_.duplicate_m) {
        continue;
      }
      const auto ia = static_cast<int>(a), ib = static_cast<int>(b);
      const bool a_has_lane = std::find(track_of.begin(), track_of.end(), ia) != track_of.end();
      const bool b_has_lane = std::find(track_of.begin(), track_of.end(), ib) != track_of.end();
      // Both found in this frame: two boundaries close together (a lane
      // ending, a double line), not one boundary twice.
      if (a_has_lane && b_has_lane) continue;
      for (size_t j = 0; j < track_of.size(); ++j) {
        if (track_of[j] != ib) continue;
        track_of[j] = ia;
        take(tracks_[a], j);
      }
      tracks_[b].misses = options_.max_misses;  // ends below
    }
  }

  MarkParallel();

  std::vector<LaneIdentity> out(lanes.size());
  for (size_t j = 0; j < lanes.size(); ++j) {
    if (track_of[j] < 0) continue;
    const Track& track = tracks_[static_cast<size_t>(track_of[j])];
    out[j] = IdentityOf(track);
  }
  // Tracks missed max_misses frames in a row end.
  tracks_.erase(std::remove_if(tracks_.begin(), tracks_.end(),
                               [&](const Track& tr) { return tr.misses >= options_.max_misses; }),
                tracks_.end());
  return out;
}

// ---------------------------------------------------------------------------
// Ego lane

std::optional<EgoLane> ComputeEgoLane(const std::vector<Lane>& lanes, const CameraModel& camera,
                                      const EgoOptions& options) {
  std::vector<std::optional<GroundCurve>> curves;
  std::vector<int> ids;
  for (const Lane& lane : lanes) {
    curves.push_back(FitGroundCurve(lane));
    ids.push_back(lane.id);
  }
  return EgoLaneOfCurves(curves, ids, camera, options);
}

std::optional<EgoLane> EgoLaneOfCurves(const std::vector<std::optional<GroundCurve>>& given,
                                       const std::vector<int>& ids, const CameraModel& camera,
                                       const EgoOptions& options,
                                       const std::vector<Eigen::Matrix3d>* covariances) {
  std::vector<std::optional<GroundCurve>> curves = given;
  if (covariances != nullptr && covariances->size() == curves.size()) {
    // Shared heading and curvature: the information-weighted mean of the
    // lanes' (heading, curvature) ...
    Eigen::Matrix2d info = Eigen::Matrix2d::Zero();
    Eigen::Vector2d weighted = Eigen::Vector2d::Zero();
    for (size_t i = 0; i < curves.size(); ++i) {
      if (!curves[i]) continue;
      const Eigen::Matrix2d p = (*covariances)[i].bottomRightCorner<2, 2>();
      if (std::abs(p.determinant()) < 1e-30) continue;
      const Eigen::Matrix2d w = p.inverse();
      info += w;
      weighted += w * curves[i]->coefficients.tail<2>();
    }
    if (std::abs(info.determinant()) > 1e-30) {
      const Eigen::Vector2d shared = info.inverse() * weighted;
      // ... and each offset given them (Gaussian conditioning).
      for (size_t i = 0; i < curves.size(); ++i) {
        if (!curves[i]) continue;
        const Eigen::Matrix3d& p = (*covariances)[i];
        const Eigen::Matrix2d pss = p.bottomRightCorner<2, 2>();
        if (std::abs(pss.determinant()) < 1e-30) continue;
        const Eigen::Vector2d delta = shared - curves[i]->coefficients.tail<2>();
        curves[i]->coefficients(0) += (p.block<1, 2>(0, 1) * pss.inverse() * delta)(0);
        curves[i]->coefficients.tail<2>() = shared;
      }
    }
  }
  int left = -1, right = -1;
  double xl = -1e9, xr = 1e9;
  for (size_t i = 0; i < curves.size(); ++i) {
    if (!curves[i]) continue;
    const double x0 = curves[i]->X(0.0);
    if (x0 < 0 && x0 > xl) {
      xl = x0;
      left = static_cast<int>(i);
    }
    if (x0 >= 0 && x0 < xr) {
      xr = x0;
      right = static_cast<int>(i);
    }
  }
  if (left < 0 || right < 0) return std::nullopt;
  const double width = xr - xl;
  if (width < options.min_width_m || width > options.max_width_m) return std::nullopt;
  const GroundCurve& l = *curves[static_cast<size_t>(left)];
  const GroundCurve& r = *curves[static_cast<size_t>(right)];
  EgoLane ego;
  ego.width_m = width;
  ego.offset_m = -0.5 * (xl + xr);
  ego.heading_deg =
      std::atan(0.5 * (l.coefficients(1) + r.coefficients(1))) * kRadToDeg - camera.yaw_deg;
  ego.curvature_per_m = 0.5 * (l.coefficients(2) + r.coefficients(2));
  ego.left_index = left;
  ego.right_index = right;
  ego.left_id = static_cast<size_t>(left) < ids.size() ? ids[static_cast<size_t>(left)] : -1;
  ego.right_id = static_cast<size_t>(right) < ids.size() ? ids[static_cast<size_t>(right)] : -1;
  ego.left_distance_m = -xl;
  ego.right_distance_m = xr;
  return ego;
}

void EgoTracker::Reset() { history_.clear(); }

void EgoTracker::Update(std::optional<EgoLane>& ego, double time_s) {
  // A frame without the ego lane keeps the history: the window drops what
  // is too old.
  if (!ego) return;
  if (!history_.empty() && time_s <= history_.back().first) history_.clear();
  if (!history_.empty()) {
    // A lane change: the new lane's left boundary is the old one's right
    // (moving right), or its right the old left (moving left). The offset
    // jumps by the width; the history shifts with it, so that the rate
    // goes on. Other pairs of boundaries (or, without ids, a jump of half a
    // lane) start the rate again.
    const bool ids = ego->left_id >= 0 && ego->right_id >= 0;
    double shift = 0;
    bool keep = true;
    if (ids) {
      if (ego->left_id == right_id_ && ego->left_id != left_id_) {
        shift = -ego->width_m;
      } else if (ego->right_id == left_id_ && ego->right_id != right_id_) {
        shift = ego->width_m;
      } else {
        keep = ego->left_id == left_id_ && ego->right_id == right_id_;
      }
    } else {
      keep = std::abs(ego->offset_m - history_.back().second) < 0.5 * ego->width_m;
    }
    if (!keep) history_.clear();
    for (auto& entry : history_) entry.second += shift;
  }
  history_.emplace_back(time_s, ego->offset_m);
  while (history_.front().first < time_s - options_.rate_window_s) history_.pop_front();
  left_id_ = ego->left_id;
  right_id_ = ego->right_id;
  // Least-squares slope of the offset over the window.
  double rate = 0;
  const double span = history_.back().first - history_.front().first;
  if (history_.size() >= 4 && span >= 0.2) {
    double st = 0, so = 0, stt = 0, sto = 0;
    for (const auto& [t, o] : history_) {
      st += t;
      so += o;
      stt += t * t;
      sto += t * o;
    }
    const double n = static_cast<double>(history_.size());
    const double var = stt / n - (st / n) * (st / n);
    if (var > 0) rate = (sto / n - (st / n) * (so / n)) / var;
  }
  ego->offset_rate_mps = rate;
  const double min_rate = options_.departure_min_rate_mps;
  ego->departing = (rate > min_rate && ego->right_distance_m / rate < options_.departure_tlc_s) ||
                   (rate < -min_rate && ego->left_distance_m / -rate < options_.departure_tlc_s);
}

// ---------------------------------------------------------------------------
// Colour

namespace {

MarkingColor ColorWithMaps(const cv::Mat& bgr, const Lane& lane, const CameraModel& camera,
                           const PlaneMaps& maps, int top_row, int bottom_row) {
  if (bgr.type() != CV_8UC3) return MarkingColor::kUnknown;
  const int bottom = bottom_row < 0 ? bgr.rows : std::min(bottom_row, bgr.rows);
  Bezier image;
  for (int k = 0; k < 4; ++k) image.p[k] = lane.image[k];
  // Mean colour over columns c0..c1, at most 8 of them read.
  auto mean = [&](int row, int c0, int c1) {
    const int stride = std::max(1, (c1 - c0 + 1) / 8);
    cv::Vec3d sum(0, 0, 0);
    int n = 0;
    const cv::Vec3b* p = bgr.ptr<cv::Vec3b>(row);
    for (int c = c0; c <= c1; c += stride, ++n) sum += cv::Vec3d(p[c][0], p[c][1], p[c][2]);
    return sum / static_cast<double>(n);
  };
  // Yellow paint is bright in red *and* green over blue; a red car or tail
  // light is bright in red only.
  auto yellowness = [](const cv::Vec3d& bgr_mean) {
    return std::min(bgr_mean[2], bgr_mean[1]) - bgr_mean[0];
  };
  std::vector<double> ratios;
  for (const Eigen::Vector2d& p : image.Sample(24)) {
    const int row = static_cast<int>(std::lround(p.y()));
    if (row < top_row || row >= bottom || row <= camera.HorizonRow() + 5) continue;
    const std::optional<BarWindows> b = BarWindowsAt(maps, p, bgr.cols, 2.0);
    if (!b) continue;
    const int u = b->u, half = b->half, off = b->off, span = b->span;
    const cv::Vec3d paint = mean(row, u - half, u + half);
    const cv::Vec3d left = mean(row, u - off - span, u - off);
    const cv::Vec3d right = mean(row, u + off, u + off + span);
    const cv::Vec3d road = 0.5 * (left + right);
    auto grey = [](const cv::Vec3d& c) { return (c[0] + c[1] + c[2]) / 3.0; };
    // Paint is a bar: brighter than the road on both sides (not a car body,
    // a curb or a shadow border).
    const double contrast = grey(paint) - grey(road);
    if (std::min(grey(paint) - grey(left), grey(paint) - grey(right)) < 12.0) continue;
    ratios.push_back((yellowness(paint) - yellowness(road)) / contrast);
  }
  if (ratios.size() < 4) return MarkingColor::kUnknown;
  std::nth_element(ratios.begin(), ratios.begin() + static_cast<long>(ratios.size() / 2),
                   ratios.end());
  const double median = ratios[ratios.size() / 2];
  if (median > 0.35) return MarkingColor::kYellow;
  if (median < 0.15) return MarkingColor::kWhite;
  return MarkingColor::kUnknown;
}

}  // namespace

MarkingColor MarkingColorOf(const cv::Mat& bgr, const Lane& lane, const CameraModel& camera,
                            int top_row, int bottom_row) {
  if (bgr.type() != CV_8UC3) return MarkingColor::kUnknown;
  return ColorWithMaps(bgr, lane, camera, PlaneMaps(camera), top_row, bottom_row);
}

}  // namespace lane

namespace lane {

// ---------------------------------------------------------------------------
// Type

namespace {

// Grey level of a pixel of a BGR or single-channel frame.
double GreyAt(const cv::Mat& frame, int row, int col) {
  if (frame.type() == CV_8UC3) {
    const cv::Vec3b& p = frame.at<cv::Vec3b>(row, col);
    return (p[0] + p[1] + p[2]) / 3.0;
  }
  return frame.at<uint8_t>(row, col);
}

// Mean grey over columns c0..c1 of a row, at most 8 columns read (a wide
// window near the camera is sampled, not summed whole).
double GreyMean(const cv::Mat& frame, int row, int c0, int c1) {
  const int stride = std::max(1, (c1 - c0 + 1) / 8);
  double sum = 0;
  int n = 0;
  if (frame.type() == CV_8UC3) {
    const cv::Vec3b* p = frame.ptr<cv::Vec3b>(row);
    for (int c = c0; c <= c1; c += stride, ++n) sum += p[c][0] + p[c][1] + p[c][2];
    return sum / (3.0 * n);
  }
  const uint8_t* p = frame.ptr<uint8_t>(row);
  for (int c = c0; c <= c1; c += stride, ++n) sum += p[c];
  return sum / n;
}

bool ReadableForType(const cv::Mat& frame) {
  return !frame.empty() && (frame.type() == CV_8UC3 || frame.type() == CV_8UC1);
}

MarkingType TypeWithMaps(const cv::Mat& frame, const Lane& lane, const CameraModel& camera,
                         const PlaneMaps& maps, int top_row, int bottom_row) {
  if (!ReadableForType(frame)) return MarkingType::kUnknown;
  const int bottom = bottom_row < 0 ? frame.rows : std::min(bottom_row, frame.rows);
  Bezier image;
  for (int k = 0; k < 4; ++k) image.p[k] = lane.image[k];
  // Samples every kStep metres of road along the lane (fine enough for gaps
  // of 1.5 m and more) (from the image spline
  // mapped to the ground), near to far.
  constexpr double kStep = 0.4;
  const std::vector<Eigen::Vector2d> dense = image.Sample(120);
  std::vector<Eigen::Vector2d> samples;
  samples.reserve(dense.size());
  double run = kStep;
  Eigen::Vector2d previous = Eigen::Vector2d::Zero();
  bool have_previous = false;
  const double horizon = camera.HorizonRow();
  for (const Eigen::Vector2d& p : dense) {
    if (p.y() <= horizon + 5) continue;
    const Eigen::Vector2d g = maps.Ground(p);
    if (have_previous) run += (g - previous).norm();
    previous = g;
    have_previous = true;
    if (run >= kStep) {
      samples.push_back(p);
      run = 0;
    }
  }
  int n = 0, on = 0, steps = 0, resolvable = 0, doubles = 0;
  std::vector<bool> pattern;  // bar or not, near to far
  pattern.reserve(samples.size());
  std::vector<int> peaks;  // a twin check's peaks (reused)
  peaks.reserve(10);
  for (const Eigen::Vector2d& p : samples) {
    const int row = static_cast<int>(std::lround(p.y()));
    if (row < top_row || row >= bottom) continue;
    const std::optional<BarWindows> b = BarWindowsAt(maps, p, frame.cols, 1.5);
    if (!b) continue;
    const int u = b->u, half = b->half, off = b->off, span = b->span;
    const double w = b->width_px;
    ++n;
    // The paint against the road on both sides, at the spline's column or,
    // when that fails, up to half a marking width either side: the spline
    // is placed to a pixel or so, and far away a marking is 2-3 pixels wide
    // (a solid line read off its paint would show gaps).
    auto road_left = [&](int c) { return GreyMean(frame, row, c - off - span, c - off); };
    auto road_right = [&](int c) { return GreyMean(frame, row, c + off, c + off + span); };
    auto bar_at = [&](int c, double left_road, double right_road) {
      return GreyMean(frame, row, c - half, c + half) - std::max(left_road, right_road) >= 12.0;
    };
    const double left = road_left(u);
    const double right = road_right(u);
    bool bar = bar_at(u, left, right);
    const int reach = std::max(1, static_cast<int>(std::lround(0.5 * w)));
    for (int d = -reach; d <= reach && !bar; ++d) {
      const int c = u + d;
      if (d != 0 && c - off - span >= 0 && c + off + span < frame.cols) {
        bar = bar_at(c, road_left(c), road_right(c));
      }
    }
    // Two bars side by side: the profile across +-0.3 m has two peaks
    // 0.1..0.45 m apart with the road showing between them. A double
    // line's centre (where its lane runs) is that dip, not a bar, so the
    // check runs where there is no bar, and on every other bar sample (a
    // double line runs on: half of them tell as much for half the reads).
    bool twin = false;
    const bool check = w >= 4.0 && (!bar || (n % 2) == 0);
    if (check) {
      // Along the row, 3 cm on the road is 0.2 w pixels (w: 15 cm).
      std::array<double, 21> profile;
      for (int k = -10; k <= 10; ++k) {
        const int c = static_cast<int>(std::lround(p.x() + 0.2 * w * k));
        profile[static_cast<size_t>(k + 10)] =
            c >= 0 && c < frame.cols ? GreyAt(frame, row, c) : 0.0;
      }
      const double floor = std::min(profile.front(), profile.back());
      peaks.clear();
      for (int k = 1; k + 1 < static_cast<int>(profile.size()); ++k) {
        const double v = profile[static_cast<size_t>(k)];
        if (v >= floor + 12 && v >= profile[static_cast<size_t>(k - 1)] &&
            v > profile[static_cast<size_t>(k + 1)]) {
          peaks.push_back(k);
        }
      }
      for (size_t a = 0; a + 1 < peaks.size() && !twin; ++a) {
        const int k0 = peaks[a], k1 = peaks[a + 1];
        const double gap_m = 0.03 * (k1 - k0);
        if (gap_m < 0.1 || gap_m > 0.45) continue;
        // The dip goes at least half way down to the road's level (texture
        // on one line does not).
        double dip = 1e9;
        for (int k = k0 + 1; k < k1; ++k) dip = std::min(dip, profile[static_cast<size_t>(k)]);
        const double low_peak =
            std::min(profile[static_cast<size_t>(k0)], profile[static_cast<size_t>(k1)]);
        twin = low_peak >= floor + 20 && dip <= floor + 0.5 * (low_peak - floor);
      }
    }
    const bool painted = bar || twin;
    if (check && painted) {
      ++resolvable;
      doubles += twin;
    }
    if (!painted && std::abs(left - right) >= 15.0) ++steps;
    on += painted;
    pattern.push_back(painted);
  }
  if (n < 12) return MarkingType::kUnknown;
  const double on_share = static_cast<double>(on) / n;
  if (on_share < 0.15) {
    return steps >= 0.5 * n ? MarkingType::kRoadEdge : MarkingType::kUnknown;
  }
  if (resolvable >= 6 && doubles >= 0.4 * resolvable) return MarkingType::kDouble;
  // Painted runs and the gaps between them (not the ends: paint fades into
  // the distance, and the view ends).
  double longest_on = 0, longest_gap = 0, current = 0;
  bool seen_paint = false;
  for (size_t i = 0; i <= pattern.size(); ++i) {
    const bool end = i == pattern.size();
    if (!end && (i == 0 || pattern[i] == pattern[i - 1])) {
      current += kStep;
      continue;
    }
    // A run of pattern[i - 1] ends here.
    if (pattern[i - 1]) {
      longest_on = std::max(longest_on, current);
      seen_paint = true;
    } else if (seen_paint && !end) {
      longest_gap = std::max(longest_gap, current);
    }
    current = kStep;
  }
  // A long stretch of paint is a solid line (another stretch may be hidden
  // by a vehicle); short dashes with gaps between them are a dashed line
  // (dashes of 2-6 m: US 3 m, Chinese urban 2 and 6 m).
  if (longest_on > 6.5 || (on_share >= 0.85 && longest_gap < 1.0)) return MarkingType::kSolid;
  if (longest_gap >= 1.5 && longest_on >= 0.5) return MarkingType::kDashed;
  return MarkingType::kUnknown;
}

}  // namespace

MarkingType MarkingTypeOf(const cv::Mat& frame, const Lane& lane, const CameraModel& camera,
                          int top_row, int bottom_row) {
  if (!ReadableForType(frame)) return MarkingType::kUnknown;
  return TypeWithMaps(frame, lane, camera, PlaneMaps(camera), top_row, bottom_row);
}

void ReadMarkings(const cv::Mat& frame, const CameraModel& camera, std::vector<Lane>& lanes,
                  int top_row, int bottom_row) {
  if (lanes.empty()) return;
  const PlaneMaps maps(camera);  // one per frame, for every lane
  for (Lane& lane : lanes) {
    lane.color = ColorWithMaps(frame, lane, camera, maps, top_row, bottom_row);
    lane.type = TypeWithMaps(frame, lane, camera, maps, top_row, bottom_row);
  }
}

namespace {

// A lane drawn from a track's curve over its last extent: ground, image and
// top-view Beziers (none when it does not project into the image).
std::optional<Lane> LaneFromCurve(const GroundCurve& curve, const CameraModel& camera,
                                  const IpmMapping& ipm) {
  constexpr int kSamples = 12;
  std::vector<Eigen::Vector2d> ground, image, top;
  const double horizon = camera.HorizonRow();
  for (int i = 0; i < kSamples; ++i) {
    const double y = curve.y_near + (curve.y_far - curve.y_near) * i / (kSamples - 1);
    const Eigen::Vector2d g(curve.X(y), y);
    const Eigen::Vector2d p = camera.GroundToImage(g);
    if (!p.allFinite() || p.y() <= horizon) continue;
    ground.push_back(g);
    image.push_back(p);
    top.push_back(ipm.GroundToIpm(g));
  }
  if (ground.size() < 4) return std::nullopt;
  // Image order as the detector's: from the bottom of the frame up.
  const auto g = FitBezier(ground);
  const auto m = FitBezier(image);
  const auto t = FitBezier(top);
  if (!g || !m || !t) return std::nullopt;
  Lane lane;
  lane.ground = g->p;
  lane.image = m->p;
  lane.ipm = t->p;
  lane.predicted = true;
  return lane;
}

}  // namespace

std::optional<EgoLane> SequenceTracker::Track(std::vector<Lane>& lanes,
                                              std::optional<double> time_s, const IpmMapping* ipm) {
  std::vector<MarkingColor> colors;
  std::vector<MarkingType> types;
  for (const Lane& lane : lanes) {
    colors.push_back(lane.color);
    types.push_back(lane.type);
  }
  const std::vector<LaneIdentity> ids = lanes_.Update(lanes, time_s, colors, types);
  for (size_t i = 0; i < lanes.size(); ++i) {
    lanes[i].id = ids[i].id;
    lanes[i].confirmed = ids[i].confirmed;
    lanes[i].color = ids[i].color;
    lanes[i].type = ids[i].type;
  }
  std::vector<LaneIdentity> all = ids;
  if (ipm != nullptr) {
    // Confirmed lanes of this frame: their track's filtered curve.
    for (size_t i = 0; i < lanes.size() && lanes_.options().report_filtered; ++i) {
      if (!ids[i].confirmed) continue;
      const std::optional<Lane> filtered = LaneFromCurve(ids[i].curve, camera_, *ipm);
      if (!filtered) continue;
      lanes[i].image = filtered->image;
      lanes[i].ground = filtered->ground;
      lanes[i].ipm = filtered->ipm;
    }
    // Confirmed tracks missed for a few frames: their prediction.
    for (const lane::Track& track : lanes_.tracks()) {
      if (!track.Reported() || track.misses < 1 || track.misses > lanes_.options().coast_frames) {
        continue;
      }
      // Not when a lane of this frame lies near it: the boundary was found
      // (by another track); reporting both would draw it twice. A lane
      // farther than duplicate_m whose track was already there when this
      // one was last seen is another boundary (the asphalt's edge beside a
      // solid line) and does not stand in for it.
      bool found = false;
      for (size_t i = 0; i < lanes.size() && !found; ++i) {
        if (all[i].id < 0) continue;
        const double distance = LateralDistance(track.curve, all[i].curve);
        if (distance >= lanes_.options().coast_clearance_m) continue;
        const lane::Track* other = nullptr;
        for (const lane::Track& t : lanes_.tracks()) {
          if (t.id == all[i].id) other = &t;
        }
        const bool coexisted = other != nullptr && other->born_frame <= track.last_hit_frame;
        found = !(coexisted && distance >= lanes_.options().duplicate_m);
      }
      if (found) continue;
      std::optional<Lane> lane = LaneFromCurve(track.curve, camera_, *ipm);
      if (!lane) continue;
      const LaneIdentity identity = IdentityOf(track);
      lane->id = identity.id;
      lane->confirmed = true;
      lane->color = identity.color;
      lane->type = identity.type;
      lanes.push_back(*lane);
      all.push_back(identity);
    }
    // Left to right, as the detector sorts.
    std::vector<size_t> order(lanes.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    auto key = [&](size_t i) {
      return all[i].id >= 0 ? all[i].curve.X(0.5 * (all[i].curve.y_near + all[i].curve.y_far))
                            : 0.5 * (lanes[i].ground[0].x() + lanes[i].ground[3].x());
    };
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return key(a) < key(b); });
    std::vector<Lane> sorted_lanes;
    std::vector<LaneIdentity> sorted_ids;
    for (size_t i : order) {
      sorted_lanes.push_back(lanes[i]);
      sorted_ids.push_back(all[i]);
    }
    lanes = std::move(sorted_lanes);
    all = std::move(sorted_ids);
  }
  // The ego lane from the confirmed lanes' filtered curves only: a
  // one-frame streak on a car does not bound it, and the filter steadies
  // the offset whose rate warns of a departure.
  std::vector<std::optional<GroundCurve>> curves(lanes.size());
  std::vector<int> track_ids(lanes.size(), -1);
  std::vector<Eigen::Matrix3d> covariances(lanes.size(), Eigen::Matrix3d::Identity());
  for (size_t i = 0; i < lanes.size(); ++i) {
    if (!all[i].confirmed) continue;
    curves[i] = all[i].curve;
    track_ids[i] = all[i].id;
    covariances[i] = all[i].covariance;
  }
  std::optional<EgoLane> ego =
      EgoLaneOfCurves(curves, track_ids, camera_, ego_options_, &covariances);
  if (lanes_.resets() != resets_seen_) {
    ego_.Reset();
    resets_seen_ = lanes_.resets();
  }
  ego_.Update(ego, lanes_.time_s());
  return ego;
}

DetectionPrior SequenceTracker::Prior(const IpmMapping& ipm) const {
  DetectionPrior prior;
  const LaneTrackingOptions& o = lanes_.options();
  const double dt = 1.0 / std::max(1e-3, o.default_fps);
  for (const lane::Track& track : lanes_.tracks()) {
    if (!track.Reported()) continue;
    const double y0 = std::max(track.curve.y_near, ipm.y_min());
    const double y1 = std::min(track.curve.y_far, ipm.y_max());
    if (y1 - y0 < 1.0) continue;  // hardly in the view
    const Eigen::Vector2d a = ipm.GroundToIpm({track.curve.X(y0), y0});
    const Eigen::Vector2d b = ipm.GroundToIpm({track.curve.X(y1), y1});
    if (!a.allFinite() || !b.allFinite() || std::abs(a.y() - b.y()) < 1.0) continue;
    const std::optional<IpmLine> line = MakeIpmLine(a, b - a, ipm.height());
    if (!line) continue;
    DetectionPrior::Window w;
    w.line = *line;
    // The predicted lateral position's sd at mid extent, one frame on.
    const double ym = 0.5 * (y0 + y1);
    const Eigen::Vector3d j(1.0, ym, 0.5 * ym * ym);
    const double var =
        j.dot(track.covariance * j) + o.offset_noise * o.offset_noise * dt * (1 + track.misses);
    w.half_width_m = 0.3 + 2.5 * std::sqrt(std::max(0.0, var));
    prior.windows.push_back(w);
  }
  return prior;
}

void SequenceTracker::Reset() {
  lanes_.Reset();
  ego_.Reset();
}

}  // namespace lane
