// Stage "refit" (3b): on a tracked frame whose prior allows refits, each
// confirmed lane seen in the last frame is refitted to this frame's response
// near its predicted curve (a shift and a turn, by weighted least squares
// over each row's localised peak); the search then leaves its window alone.
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include "pipeline.h"

namespace lane::pipeline {

namespace {

// The refit's limits. What a refit must show before it replaces the
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

// The lane of a refit window, or none.
std::optional<Lane> RefitWindow(const StageEnv& env, const cv::Mat& thresholded,
                                const DetectionPrior::Window& w) {
  if (!w.curve) return std::nullopt;
  const GroundCurve& curve = *w.curve;
  const IpmMapping& ipm = env.ipm;
  const double mpp_x = ipm.metres_per_px_x();
  const double mpp_y = ipm.metres_per_px_y();
  const double max_rms_px = kRefitMaxRmsMarkings * env.options.filter.marking_width_m / mpp_x;
  auto row_of = [&](double y) { return ipm.GroundToIpm({0.0, y}).y(); };
  const double y0 = std::max(curve.y_near, ipm.y_min());
  const double y1 = std::min(curve.y_far, ipm.y_max());
  const int r0 = std::max(0, static_cast<int>(std::ceil(row_of(y1))));
  const int r1 = std::min(thresholded.rows - 1, static_cast<int>(std::floor(row_of(y0))));
  const int rows = r1 - r0 + 1;
  if (rows <= 0) return std::nullopt;
  const double half_px = env.WindowHalfWidthM(w) / mpp_x;
  const std::vector<RefitPoint> points = PeaksAlong(thresholded, ipm, curve, half_px, r0, r1);
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
  std::optional<Lane> lane = LaneAlongCurve(refit, ipm, /*near_first=*/false);
  if (!lane) return std::nullopt;
  lane->refit = true;
  for (size_t i = 0; i < points.size(); ++i) {
    if (keep[i]) lane->score += points[i].weight;
  }
  return lane;
}

}  // namespace

bool HasRefitPrior(const FrameContext& f) { return f.prior != nullptr && f.prior->refit; }

void Refit(const StageEnv& env, FrameContext& f) {
  const cv::Mat& thresholded = f.thresholded;
  const DetectorOptions& opt = env.options;
  const double mpp_x = env.ipm.metres_per_px_x();
  Refitted out;
  for (const DetectionPrior::Window& w : f.prior->windows) {
    std::optional<Lane> lane = w.refit ? RefitWindow(env, thresholded, w) : std::nullopt;
    if (!lane) {
      out.failed += w.refit && w.curve.has_value();
      out.rest.windows.push_back(w);
      continue;
    }
    const double half_m = env.WindowHalfWidthM(w);
    out.lanes.push_back(*lane);
    out.half_widths_m.push_back(half_m);
    // The column a column sum puts the lane at: its mean over the rows.
    double sum = 0;
    for (int r = 0; r < thresholded.rows; ++r) {
      const double y = env.ipm.IpmToGround({0.0, static_cast<double>(r)}).y();
      sum += env.ipm.GroundToIpm({w.curve->X(y), y}).x();
    }
    out.columns.push_back({sum / thresholded.rows, (half_m + opt.filter.marking_width_m) / mpp_x});
  }
  f.refitted = std::move(out);
  // The search below leaves the refitted lanes' windows alone.
  f.prior = &f.refitted.rest;
  f.detection.refit_lanes = static_cast<int>(f.refitted.lanes.size());
  f.detection.refit_failed = f.refitted.failed;
}

void JoinRefitted(const Refitted& refitted, std::vector<Lane>& lanes) {
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

}  // namespace lane::pipeline
