#include "lane/detector/road_model.h"

#include <algorithm>
#include <cmath>

#include "lane/base/median.h"

namespace lane {

absl::Status RoadModelOptions::Validate() const {
  if (!(min_lane_width_m > 0) || !(max_lane_width_m > min_lane_width_m)) {
    return absl::InvalidArgumentError("road_model: need 0 < min_lane_width_m < max_lane_width_m");
  }
  if (!(search_half_width_m > 0) || !(search_half_width_m < min_lane_width_m / 2)) {
    return absl::InvalidArgumentError(
        "road_model: need 0 < search_half_width_m < min_lane_width_m / 2");
  }
  if (!(search_quantile > 0 && search_quantile < 1) || !(search_min_fraction >= 0)) {
    return absl::InvalidArgumentError(
        "road_model: need 0 < search_quantile < 1 and search_min_fraction >= 0");
  }
  if (!(width_tolerance > 0) || !(max_gap_change_m > 0) || !(min_overlap_m > 0)) {
    return absl::InvalidArgumentError(
        "road_model: width_tolerance, max_gap_change_m and min_overlap_m must be positive");
  }
  return absl::OkStatus();
}

std::optional<LateralProfile> LateralProfile::FromGround(const Bezier& ground, int samples) {
  std::vector<Eigen::Vector2d> pts = ground.Sample(samples);
  if (pts.front().y() > pts.back().y()) std::reverse(pts.begin(), pts.end());
  LateralProfile p;
  for (const Eigen::Vector2d& q : pts) {
    if (!q.allFinite()) return std::nullopt;
    if (!p.y_.empty() && q.y() <= p.y_.back()) return std::nullopt;
    p.y_.push_back(q.y());
    p.x_.push_back(q.x());
  }
  return p;
}

std::optional<LateralProfile> LateralProfile::Clipped(double y_min, double y_max) const {
  const double lo = std::max(y_min, y_.front());
  const double hi = std::min(y_max, y_.back());
  if (!(hi > lo)) return std::nullopt;
  LateralProfile p;
  p.y_.push_back(lo);
  p.x_.push_back(XAt(lo));
  for (size_t i = 0; i < y_.size(); ++i) {
    if (y_[i] > lo && y_[i] < hi) {
      p.y_.push_back(y_[i]);
      p.x_.push_back(x_[i]);
    }
  }
  p.y_.push_back(hi);
  p.x_.push_back(XAt(hi));
  return p;
}

double LateralProfile::XAt(double y) const {
  if (y <= y_.front()) return x_.front();
  if (y >= y_.back()) return x_.back();
  const size_t i = static_cast<size_t>(std::upper_bound(y_.begin(), y_.end(), y) - y_.begin());
  const double f = (y - y_[i - 1]) / (y_[i] - y_[i - 1]);
  return x_[i - 1] + f * (x_[i] - x_[i - 1]);
}

namespace {

// Two neighbouring boundaries along their common extent.
struct Gap {
  double y_near = 0;
  double y_far = 0;
  double median_m = 0;  // median of right - left
  double change_m = 0;  // max - min of right - left
};

constexpr int kGapSamples = 9;

std::optional<Gap> MeasureGap(const LateralProfile& left, const LateralProfile& right,
                              double min_overlap_m) {
  Gap g;
  g.y_near = std::max(left.y_near(), right.y_near());
  g.y_far = std::min(left.y_far(), right.y_far());
  if (g.y_far - g.y_near < min_overlap_m) return std::nullopt;
  std::vector<double> gaps;
  for (int i = 0; i < kGapSamples; ++i) {
    const double y = g.y_near + (g.y_far - g.y_near) * i / (kGapSamples - 1);
    gaps.push_back(right.XAt(y) - left.XAt(y));
  }
  const auto [lo, hi] = std::minmax_element(gaps.begin(), gaps.end());
  g.change_m = *hi - *lo;
  g.median_m = Median(std::move(gaps));
  return g;
}

// The found boundaries' lateral profiles, the adjacent pairs that stay
// parallel (gap change within max_gap_change_m), and the frame's lane width:
// the median gap of those pairs one plausible lane apart (0 when none is).
struct RoadGaps {
  std::vector<std::optional<LateralProfile>> profiles;
  std::vector<std::pair<size_t, Gap>> gaps;
  double frame_width_m = 0;
};

RoadGaps MeasureRoad(const std::vector<Bezier>& ground, const RoadModelOptions& options) {
  RoadGaps road;
  road.profiles.reserve(ground.size());
  for (const Bezier& g : ground) road.profiles.push_back(LateralProfile::FromGround(g));
  std::vector<double> widths;
  for (size_t i = 0; i + 1 < ground.size(); ++i) {
    const auto& left = road.profiles[i];
    const auto& right = road.profiles[i + 1];
    if (!left || !right) continue;
    const std::optional<Gap> g = MeasureGap(*left, *right, options.min_overlap_m);
    if (!g || g->change_m > options.max_gap_change_m) continue;
    road.gaps.emplace_back(i, *g);
    if (g->median_m >= options.min_lane_width_m && g->median_m <= options.max_lane_width_m) {
      widths.push_back(g->median_m);
    }
  }
  road.frame_width_m = widths.empty() ? 0.0 : Median(widths);
  return road;
}

}  // namespace

std::vector<InferredBoundary> InferHiddenBoundaries(const std::vector<Bezier>& ground,
                                                    const RoadModelOptions& options) {
  std::vector<InferredBoundary> inferred;
  if (!options.infer_hidden || ground.size() < 2) return inferred;
  const RoadGaps road = MeasureRoad(ground, options);
  const auto& profiles = road.profiles;
  const double frame_width = road.frame_width_m;

  for (const auto& [i, g] : road.gaps) {
    const double half = 0.5 * g.median_m;
    if (half < options.min_lane_width_m || half > options.max_lane_width_m) continue;
    if (frame_width > 0 && std::abs(half - frame_width) > options.width_tolerance * frame_width) {
      continue;
    }
    // Half a gap from each neighbour, averaged where both run, over the
    // extent of either (a hidden boundary runs as far as the road shows its
    // neighbours: labels draw it so), far end first.
    const LateralProfile& left = *profiles[i];
    const LateralProfile& right = *profiles[i + 1];
    const double y_near = std::min(left.y_near(), right.y_near());
    const double y_far = std::max(left.y_far(), right.y_far());
    std::vector<Eigen::Vector2d> pts;
    constexpr int kSamples = 21;
    for (int k = 0; k < kSamples; ++k) {
      const double y = y_far - (y_far - y_near) * k / (kSamples - 1);
      double sum = 0;
      int n = 0;
      if (y >= left.y_near() && y <= left.y_far()) {
        sum += left.XAt(y) + half;
        ++n;
      }
      if (y >= right.y_near() && y <= right.y_far()) {
        sum += right.XAt(y) - half;
        ++n;
      }
      if (n > 0) pts.emplace_back(sum / n, y);
    }
    const std::optional<Bezier> fit = FitBezier(pts);
    if (!fit) continue;
    inferred.push_back({*fit, static_cast<int>(i), static_cast<int>(i + 1)});
  }
  return inferred;
}

std::vector<Bezier> OuterBoundaryGuesses(const std::vector<Bezier>& ground,
                                         const RoadModelOptions& options) {
  std::vector<Bezier> guesses;
  if (ground.empty()) return guesses;
  const RoadGaps road = MeasureRoad(ground, options);
  // Without a lane measured in this frame, the middle of the plausible range.
  const double width = road.frame_width_m > 0
                           ? road.frame_width_m
                           : 0.5 * (options.min_lane_width_m + options.max_lane_width_m);
  for (const auto& [index, side] :
       {std::pair<size_t, double>{0, -1.0}, std::pair<size_t, double>{ground.size() - 1, 1.0}}) {
    if (!road.profiles[index]) continue;
    std::array<Eigen::Vector2d, 4> p = ground[index].p;
    for (Eigen::Vector2d& q : p) q.x() += side * width;
    guesses.push_back(Bezier{p});
  }
  return guesses;
}

bool FitsRoadModel(const Bezier& lane, const std::vector<Bezier>& found, double y_min, double y_max,
                   const RoadModelOptions& options) {
  std::optional<LateralProfile> p = LateralProfile::FromGround(lane);
  if (!p) return false;
  p = p->Clipped(y_min, y_max);
  if (!p) return false;
  bool neighbour = false;
  for (const Bezier& f : found) {
    std::optional<LateralProfile> q = LateralProfile::FromGround(f);
    if (q) q = q->Clipped(y_min, y_max);
    if (!q) continue;
    const double y = 0.5 * (std::max(p->y_near(), q->y_near()) + std::min(p->y_far(), q->y_far()));
    const bool left_of = p->XAt(y) < q->XAt(y);
    const std::optional<Gap> g = left_of ? MeasureGap(*p, *q, options.min_overlap_m)
                                         : MeasureGap(*q, *p, options.min_overlap_m);
    if (!g) continue;
    if (g->median_m < (1 - options.width_tolerance) * options.min_lane_width_m) return false;
    if (g->median_m <= options.max_lane_width_m && g->change_m <= options.max_gap_change_m) {
      neighbour = true;
    }
  }
  return neighbour;
}

}  // namespace lane
