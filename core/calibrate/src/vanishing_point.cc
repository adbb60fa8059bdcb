#include "lane/calibrate/vanishing_point.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <random>

#include "lane/base/median.h"
#include "lane/geometry/camera.h"

namespace lane {
namespace {

// The quantile of the non-negative values of `values` in a histogram of
// quarter grey levels (responses are differences of 8-bit means).
float ResponseQuantile(const cv::Mat& response, double q) {
  constexpr int kBins = 1024;
  std::vector<int> hist(kBins, 0);
  long long n = 0;
  for (int r = 0; r < response.rows; ++r) {
    const float* p = response.ptr<float>(r);
    for (int c = 0; c < response.cols; ++c) {
      const int bin = std::clamp(static_cast<int>(p[c] * 4.0f), 0, kBins - 1);
      ++hist[bin];
      ++n;
    }
  }
  const long long target = static_cast<long long>(q * static_cast<double>(n));
  long long seen = 0;
  for (int b = 0; b < kBins; ++b) {
    seen += hist[b];
    if (seen > target) return static_cast<float>(b) / 4.0f;
  }
  return static_cast<float>(kBins) / 4.0f;
}

// Bright-bar response of one row: min(centre - left, centre - right) for a
// bar `width` pixels wide, or 0 where the window leaves the image.
void BarResponse(const uint8_t* row, int cols, double width, std::vector<int>& prefix, float* out) {
  prefix.assign(static_cast<size_t>(cols) + 1, 0);
  for (int c = 0; c < cols; ++c) prefix[c + 1] = prefix[c] + row[c];
  const int hc = std::max(0, static_cast<int>(std::lround(width / 4.0)));
  const int d = std::max(2, static_cast<int>(std::lround(0.75 * width)));
  const int s = std::max(2, static_cast<int>(std::lround(0.75 * width)));
  const float centre_n = static_cast<float>(2 * hc + 1);
  const float side_n = static_cast<float>(s);
  for (int u = d + s; u + d + s < cols; ++u) {
    const float centre = static_cast<float>(prefix[u + hc + 1] - prefix[u - hc]) / centre_n;
    const float left = static_cast<float>(prefix[u - d] - prefix[u - d - s]) / side_n;
    const float right = static_cast<float>(prefix[u + d + s + 1] - prefix[u + d + 1]) / side_n;
    out[u] = std::max(out[u], std::min(centre - left, centre - right));
  }
}

double AngleBetween(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  // Undirected angle between two lines, radians in [0, pi/2].
  const double c = std::abs(a.dot(b)) / std::max(1e-12, a.norm() * b.norm());
  return std::acos(std::min(1.0, c));
}

// Angle between segment k and the direction from its centre to p (radians),
// or a large value when p is not above the segment.
double SupportAngle(const ImageSegment& s, const Eigen::Vector2d& p) {
  if (!(p.y() < s.top_row)) return M_PI;
  return AngleBetween(s.direction, p - s.centre);
}

struct Consensus {
  Eigen::Vector2d point = Eigen::Vector2d::Zero();
  std::vector<int> support;
  double weight = 0;
};

// The segments of `use` that point at p, and their score: the lesser of
// the lengths supporting p from its left and from its right (a vanishing
// point has markings on both sides; many nearly parallel segments on one
// side support a whole strip of far points equally).
std::vector<int> SupportOf(const std::vector<ImageSegment>& segs, const std::vector<int>& use,
                           const Eigen::Vector2d& p, double tol, double* score) {
  std::vector<int> support;
  double left = 0, right = 0;
  for (int k : use) {
    if (SupportAngle(segs[k], p) < tol) {
      support.push_back(k);
      (segs[k].centre.x() < p.x() ? left : right) += segs[k].length;
    }
  }
  if (score) *score = std::min(left, right);
  return support;
}

std::optional<Eigen::Vector2d> Refit(const std::vector<ImageSegment>& segs,
                                     const std::vector<int>& support, const Eigen::Vector2d& p0) {
  std::vector<Eigen::Vector2d> points, dirs;
  std::vector<double> weights;
  for (int k : support) {
    points.push_back(segs[k].centre);
    dirs.push_back(segs[k].direction);
    // Residuals in angle: distance to the line over the distance to the point.
    const double r = std::max(1.0, (p0 - segs[k].centre).norm());
    weights.push_back(segs[k].length / (r * r));
  }
  return IntersectLines(points, dirs, weights);
}

// The best-supported point of the segments `use` (indices into segs), refined.
// Candidates are the intersections of pairs among `pairs` (indices into
// segs; all of `use` when empty), within gate_px of `prior` when given.
std::optional<Consensus> BestPoint(const std::vector<ImageSegment>& segs,
                                   const std::vector<int>& use, double tol, int min_inliers,
                                   double min_spread, const std::optional<Eigen::Vector2d>& prior,
                                   double gate_px, const std::optional<cv::Rect2d>& bounds,
                                   const std::vector<std::vector<int>>& pair_groups = {}) {
  Consensus best;
  const std::vector<std::vector<int>> groups =
      pair_groups.empty() ? std::vector<std::vector<int>>{use} : pair_groups;
  for (const std::vector<int>& group : groups) {
    for (size_t a = 0; a < group.size(); ++a) {
      for (size_t b = a + 1; b < group.size(); ++b) {
        const ImageSegment& s = segs[group[a]];
        const ImageSegment& t = segs[group[b]];
        if (AngleBetween(s.direction, t.direction) < 2.0 * kDegToRad) continue;
        const std::optional<Eigen::Vector2d> p =
            IntersectLines({s.centre, t.centre}, {s.direction, t.direction}, {1.0, 1.0});
        if (!p) continue;
        if (prior && (*p - *prior).norm() > gate_px) continue;
        if (bounds && !bounds->contains(cv::Point2d(p->x(), p->y()))) continue;
        double w = 0;
        std::vector<int> support = SupportOf(segs, use, *p, tol, &w);
        if (w > best.weight) best = {*p, std::move(support), w};
      }
    }
  }
  if (best.weight <= 0 || static_cast<int>(best.support.size()) < std::max(2, min_inliers)) {
    return std::nullopt;
  }
  for (int iter = 0; iter < 3; ++iter) {
    const std::optional<Eigen::Vector2d> p = Refit(segs, best.support, best.point);
    if (!p) break;
    double w = 0;
    std::vector<int> support = SupportOf(segs, use, *p, tol, &w);
    if (w <= 0 || static_cast<int>(support.size()) < std::max(2, min_inliers)) break;
    best = {*p, std::move(support), w};
  }
  // The supporting directions must span enough angle to locate a point.
  double lo = M_PI, hi = -M_PI;
  for (int k : best.support) {
    const double angle = std::atan2(segs[k].direction.x(), -segs[k].direction.y());
    lo = std::min(lo, angle);
    hi = std::max(hi, angle);
  }
  if (hi - lo < min_spread) return std::nullopt;
  return best;
}

}  // namespace

cv::Mat PaintChannel(const cv::Mat& frame) {
  if (frame.type() == CV_8UC1) return frame;
  CV_Assert(frame.type() == CV_8UC3);
  cv::Mat paint(frame.rows, frame.cols, CV_8UC1);
  for (int r = 0; r < frame.rows; ++r) {
    const cv::Vec3b* in = frame.ptr<cv::Vec3b>(r);
    uint8_t* out = paint.ptr<uint8_t>(r);
    for (int c = 0; c < frame.cols; ++c) out[c] = std::min(in[c][1], in[c][2]);
  }
  return paint;
}

namespace {

// The bar responses of rows [top, bottom) of the paint channel, smoothed
// over 3 rows first (noise, JPEG blocks): a marking's width at each row
// from the horizon and the camera's height, or the fixed widths.
cv::Mat BandResponse(const cv::Mat& paint, int top, int bottom, const MarkingSegmentOptions& o) {
  cv::Mat smooth;
  cv::GaussianBlur(paint.rowRange(top, bottom), smooth, cv::Size(3, 3), 0.0);
  cv::Mat response(bottom - top, paint.cols, CV_32F, cv::Scalar(0));
  std::vector<int> prefix;
  for (int r = 0; r < response.rows; ++r) {
    const int v = top + r;
    float* out = response.ptr<float>(r);
    if (o.horizon_row) {
      const double w = o.marking_width_m * (v - *o.horizon_row) / std::max(0.1, o.height_m);
      if (w < 1.5) continue;
      BarResponse(smooth.ptr<uint8_t>(r), paint.cols, w, prefix, out);
    } else {
      for (double w : o.fixed_widths_px)
        BarResponse(smooth.ptr<uint8_t>(r), paint.cols, w, prefix, out);
    }
  }
  return response;
}

// The pieces of a thresholded band (connected components) with the centre
// of each of their rows: the sum and count of the columns of row j of
// piece i at index offset[i] + j.
struct BandPieces {
  cv::Mat labels, stats, centroids;
  int count = 0;
  std::vector<int> offset;
  std::vector<double> row_sum;
  std::vector<int> row_count;
};

BandPieces PiecesOf(const cv::Mat& mask) {
  BandPieces p;
  p.count = cv::connectedComponentsWithStats(mask, p.labels, p.stats, p.centroids, 8, CV_32S);
  const int n = p.count;
  p.offset.assign(static_cast<size_t>(n) + 1, 0);
  for (int i = 1; i < n; ++i)
    p.offset[i + 1] = p.offset[i] + p.stats.at<int>(i, cv::CC_STAT_HEIGHT);
  p.row_sum.assign(static_cast<size_t>(p.offset[n]), 0.0);
  p.row_count.assign(static_cast<size_t>(p.offset[n]), 0);
  for (int r = 0; r < p.labels.rows; ++r) {
    const int* l = p.labels.ptr<int>(r);
    for (int c = 0; c < p.labels.cols; ++c) {
      if (l[c] == 0) continue;
      const size_t k =
          static_cast<size_t>(p.offset[l[c]] + r - p.stats.at<int>(l[c], cv::CC_STAT_TOP));
      p.row_sum[k] += c;
      ++p.row_count[k];
    }
  }
  return p;
}

// Piece i as a segment: its axis from the centres of its rows (u regressed
// on v: the pieces are cut along rows, and a principal axis of a slanted bar
// with horizontal ends leans towards the rows); none when it is too short,
// not elongated or too flat.
std::optional<ImageSegment> SegmentOfPiece(const BandPieces& p, int i, int top, double min_length,
                                           double min_sin, const MarkingSegmentOptions& o) {
  const int rows = p.stats.at<int>(i, cv::CC_STAT_HEIGHT);
  if (rows < 3 || p.stats.at<int>(i, cv::CC_STAT_AREA) < 6) return std::nullopt;
  // Least squares u = a v + b over the rows' centres.
  double sv = 0, su = 0, svv = 0, suv = 0, runs = 0;
  int m = 0;
  for (int j = 0; j < rows; ++j) {
    const size_t k = static_cast<size_t>(p.offset[i] + j);
    if (p.row_count[k] == 0) continue;
    const double v = top + p.stats.at<int>(i, cv::CC_STAT_TOP) + j;
    const double u = p.row_sum[k] / p.row_count[k];
    sv += v;
    su += u;
    svv += v * v;
    suv += u * v;
    runs += p.row_count[k];
    ++m;
  }
  if (m < 3) return std::nullopt;
  const double mv = sv / m, mu = su / m;
  const double var_v = svv / m - mv * mv;
  if (var_v <= 0) return std::nullopt;
  const double slope = (suv / m - mu * mv) / var_v;  // du/dv
  const double stretch = std::sqrt(1.0 + slope * slope);
  const double length = rows * stretch;
  const double width = (runs / m) / stretch;
  if (length < min_length || length < o.min_elongation * width) return std::nullopt;
  // Pointing up the image.
  const Eigen::Vector2d dir = Eigen::Vector2d(-slope, -1.0) / stretch;
  if (-dir.y() < min_sin) return std::nullopt;
  ImageSegment seg;
  seg.centre = {mu, mv};
  seg.direction = dir;
  seg.length = length;
  seg.top_row = top + p.stats.at<int>(i, cv::CC_STAT_TOP);
  seg.bottom_row = seg.top_row + rows - 1;
  return seg;
}

}  // namespace

cv::Mat MarkingResponse(const cv::Mat& paint, const MarkingSegmentOptions& o) {
  CV_Assert(paint.type() == CV_8UC1);
  const int top = std::clamp(o.top_row, 0, paint.rows);
  const int bottom = std::clamp(o.bottom_row > 0 ? o.bottom_row : paint.rows, top, paint.rows);
  if (bottom - top < 3) return cv::Mat::zeros(bottom - top, paint.cols, CV_32F);
  return BandResponse(paint, top, bottom, o);
}

std::vector<double> FixedBarWidths(int image_width) {
  std::vector<double> widths;
  for (double f : {320.0, 160.0, 80.0, 40.0}) widths.push_back(std::max(2.0, image_width / f));
  return widths;
}

std::vector<ImageSegment> FindMarkingSegments(const cv::Mat& frame,
                                              const MarkingSegmentOptions& o) {
  std::vector<ImageSegment> segments;
  if (frame.empty()) return segments;
  const cv::Mat paint = PaintChannel(frame);
  const int top = std::clamp(o.top_row, 0, paint.rows);
  const int bottom = std::clamp(o.bottom_row > 0 ? o.bottom_row : paint.rows, top, paint.rows);
  if (bottom - top < 3) return segments;
  const cv::Mat response = MarkingResponse(paint, o);
  const float threshold =
      std::max(static_cast<float>(o.min_contrast), ResponseQuantile(response, o.quantile));
  cv::Mat mask = response >= threshold;
  const int slice = o.slice_rows > 0 ? o.slice_rows : std::max(8, paint.rows / 12);
  for (int r = slice - (top % slice); r < mask.rows; r += slice) {
    mask.row(r).setTo(cv::Scalar(0));
  }
  const BandPieces pieces = PiecesOf(mask);
  const double min_length = o.min_length_px > 0 ? o.min_length_px : paint.rows / 40.0;
  const double min_sin = std::sin(o.min_angle_deg * kDegToRad);
  for (int i = 1; i < pieces.count; ++i) {
    if (auto seg = SegmentOfPiece(pieces, i, top, min_length, min_sin, o)) segments.push_back(*seg);
  }
  return segments;
}

const char* VpFrameResultName(VpFrameResult result) {
  switch (result) {
    case VpFrameResult::kOk:
      return "ok";
    case VpFrameResult::kNoMarkings:
      return "no_markings";
    case VpFrameResult::kCurved:
      return "curved";
    case VpFrameResult::kStationary:
      return "stationary";
    case VpFrameResult::kElsewhere:
      return "elsewhere";
  }
  return "?";
}

std::optional<Eigen::Vector2d> IntersectLines(const std::vector<Eigen::Vector2d>& points,
                                              const std::vector<Eigen::Vector2d>& directions,
                                              const std::vector<double>& weights) {
  // Minimises sum w_k (n_k . p - n_k . m_k)^2 with n_k the unit normal.
  Eigen::Matrix2d a = Eigen::Matrix2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  for (size_t k = 0; k < points.size(); ++k) {
    const Eigen::Vector2d d = directions[k].normalized();
    const Eigen::Vector2d normal(-d.y(), d.x());
    a += weights[k] * normal * normal.transpose();
    b += weights[k] * normal * normal.dot(points[k]);
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(a);
  if (eig.eigenvalues()(0) <= 1e-9 * std::max(1e-300, eig.eigenvalues()(1))) return std::nullopt;
  const Eigen::Vector2d p = a.ldlt().solve(b);
  if (!p.allFinite()) return std::nullopt;
  return p;
}

FrameVanishingPoint EstimateFrameVanishingPoint(const std::vector<ImageSegment>& segments,
                                                const VanishingPointOptions& o) {
  FrameVanishingPoint out;
  std::vector<int> use(segments.size());
  std::iota(use.begin(), use.end(), 0);
  std::stable_sort(use.begin(), use.end(),
                   [&](int a, int b) { return segments[a].length > segments[b].length; });
  if (static_cast<int>(use.size()) > o.max_segments)
    use.resize(static_cast<size_t>(o.max_segments));
  out.segments = static_cast<int>(use.size());
  const double tol = o.inlier_angle_deg * kDegToRad;
  const double spread = o.min_spread_deg * kDegToRad;
  const double gate_px = o.focal_px * std::tan(o.prior_gate_deg * kDegToRad);
  const std::optional<Consensus> all =
      BestPoint(segments, use, tol, o.min_inliers, spread, o.prior, gate_px, o.bounds);
  if (!all) {
    // Markings that meet away from the prior disagree with it: told apart
    // from a frame without markings.
    if (o.prior) {
      const std::optional<Consensus> free =
          BestPoint(segments, use, tol, o.min_inliers, spread, std::nullopt, gate_px, o.bounds);
      if (free) {
        out.result = VpFrameResult::kElsewhere;
        out.point = free->point;
      }
    }
    return out;
  }
  out.point = all->point;
  out.support = all->support;
  out.inliers = static_cast<int>(all->support.size());
  double sq = 0;
  for (int k : all->support) {
    const double e = SupportAngle(segments[k], all->point) / kDegToRad;
    sq += e * e;
  }
  out.rms_deg = std::sqrt(sq / std::max(1, out.inliers));

  // Curve check: the near and the far segments, split at the supporting
  // segments' median row, must agree.
  std::vector<double> rows;
  for (int k : all->support) rows.push_back(segments[k].centre.y());
  std::nth_element(rows.begin(), rows.begin() + static_cast<long>(rows.size() / 2), rows.end());
  const double split = rows[rows.size() / 2];
  std::vector<int> near, far;
  for (int k : use) (segments[k].centre.y() > split ? near : far).push_back(k);
  const std::optional<Consensus> n =
      BestPoint(segments, near, tol, 2, spread, o.prior, gate_px, o.bounds);
  const std::optional<Consensus> f =
      BestPoint(segments, far, tol, 2, spread, o.prior, gate_px, o.bounds);
  if (o.curve_tolerance_deg > 0 && n && f) {
    const double tolerance_px = o.focal_px * std::tan(o.curve_tolerance_deg * kDegToRad);
    if ((n->point - f->point).norm() > tolerance_px) {
      out.result = VpFrameResult::kCurved;
      return out;
    }
  }
  out.result = VpFrameResult::kOk;
  return out;
}

std::optional<PooledVanishingPoint> EstimatePooledVanishingPoint(
    const std::vector<std::vector<ImageSegment>>& frames, const VanishingPointOptions& o,
    int pairs_per_frame) {
  std::vector<ImageSegment> all;
  std::vector<std::pair<int, int>> origin;  // (frame, index) of each of `all`
  std::vector<std::vector<int>> groups;
  for (const std::vector<ImageSegment>& frame : frames) {
    for (size_t k = 0; k < frame.size(); ++k) {
      origin.emplace_back(static_cast<int>(groups.size()), static_cast<int>(k));
    }
    std::vector<int> idx(frame.size());
    std::iota(idx.begin(), idx.end(), 0);
    std::stable_sort(idx.begin(), idx.end(),
                     [&](int a, int b) { return frame[a].length > frame[b].length; });
    if (static_cast<int>(idx.size()) > pairs_per_frame)
      idx.resize(static_cast<size_t>(pairs_per_frame));
    std::vector<int> group;
    for (int i : idx) group.push_back(static_cast<int>(all.size()) + i);
    groups.push_back(std::move(group));
    all.insert(all.end(), frame.begin(), frame.end());
  }
  std::vector<int> use(all.size());
  std::iota(use.begin(), use.end(), 0);
  const std::optional<Consensus> c =
      BestPoint(all, use, o.inlier_angle_deg * kDegToRad, o.min_inliers,
                o.min_spread_deg * kDegToRad, std::nullopt, 0.0, o.bounds, groups);
  if (!c) return std::nullopt;
  PooledVanishingPoint p{
      c->point, static_cast<int>(c->support.size()), static_cast<int>(all.size()), {}};
  for (int k : c->support) p.supporting.push_back(origin[static_cast<size_t>(k)]);
  return p;
}

std::optional<CombinedVanishingPoint> CombineVanishingPoints(
    const std::vector<Eigen::Vector2d>& points, double min_spread_px) {
  if (points.empty()) return std::nullopt;
  Eigen::Vector2d med, sigma;
  for (int axis = 0; axis < 2; ++axis) {
    std::vector<double> v;
    for (const Eigen::Vector2d& p : points) v.push_back(p(axis));
    med(axis) = Median(v);
    for (double& x : v) x = std::abs(x - med(axis));
    sigma(axis) = std::max(min_spread_px, 1.4826 * Median(v));
  }
  CombinedVanishingPoint c;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero(), sum_sq = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& p : points) {
    if (std::abs(p.x() - med.x()) > 3 * sigma.x() || std::abs(p.y() - med.y()) > 3 * sigma.y()) {
      ++c.frames_rejected;
      continue;
    }
    ++c.frames_used;
    c.used.push_back(static_cast<int>(&p - points.data()));
    sum += p;
    sum_sq += p.cwiseProduct(p);
  }
  const double n = c.frames_used;
  c.point = sum / n;
  const Eigen::Vector2d var = (sum_sq / n - c.point.cwiseProduct(c.point)).cwiseMax(0.0);
  c.spread = (var * (n / std::max(1.0, n - 1))).cwiseSqrt();
  c.standard_error = c.spread / std::sqrt(n);
  return c;
}

namespace {

// Two-sided 97.5 % quantile of Student's t with `df` degrees of freedom
// (tabled to 10, then 1.96 + 2.4 / df, within 0.01 of the exact value).
double StudentT975(int df) {
  static constexpr double kTable[] = {12.71, 4.30, 3.18, 2.78, 2.57, 2.45, 2.36, 2.31, 2.26, 2.23};
  if (df < 1) return kTable[0];
  if (df <= 10) return kTable[df - 1];
  return 1.96 + 2.4 / df;
}

}  // namespace

Eigen::Vector2d BootstrapInterval(const std::vector<Eigen::Vector2d>& points, double min_spread_px,
                                  int resamples) {
  const std::optional<CombinedVanishingPoint> whole = CombineVanishingPoints(points, min_spread_px);
  if (!whole || points.size() < 2) {
    return Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  }
  std::mt19937_64 rng(20261205);
  std::uniform_int_distribution<size_t> pick(0, points.size() - 1);
  std::vector<double> us, vs;
  std::vector<Eigen::Vector2d> sample(points.size());
  for (int b = 0; b < resamples; ++b) {
    for (Eigen::Vector2d& s : sample) s = points[pick(rng)];
    const std::optional<CombinedVanishingPoint> c = CombineVanishingPoints(sample, min_spread_px);
    us.push_back(c->point.x());
    vs.push_back(c->point.y());
  }
  auto half = [&](std::vector<double>& v, double estimate) {
    std::sort(v.begin(), v.end());
    const double lo = v[static_cast<size_t>(0.025 * static_cast<double>(v.size() - 1))];
    const double hi = v[static_cast<size_t>(0.975 * static_cast<double>(v.size() - 1))];
    return std::max(hi - estimate, estimate - lo);
  };
  const double widen = StudentT975(whole->frames_used - 1) / 1.96;
  return Eigen::Vector2d(half(us, whole->point.x()), half(vs, whole->point.y())) * widen;
}

}  // namespace lane
