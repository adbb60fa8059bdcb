#include "lane/track/marking_reader.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "lane/geometry/bezier.h"

namespace lane {
namespace {

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

// Points of the lane's image spline every kTypeStep metres of road (from the
// spline mapped to the ground), near to far, below the horizon: fine enough
// for gaps of 1.5 m and more.
constexpr double kTypeStep = 0.4;
std::vector<Eigen::Vector2d> SamplesAlongRoad(const Lane& lane, const CameraModel& camera,
                                              const PlaneMaps& maps) {
  Bezier image;
  for (int k = 0; k < 4; ++k) image.p[k] = lane.image[k];
  const std::vector<Eigen::Vector2d> dense = image.Sample(120);
  std::vector<Eigen::Vector2d> samples;
  samples.reserve(dense.size());
  double run = kTypeStep;
  Eigen::Vector2d previous = Eigen::Vector2d::Zero();
  bool have_previous = false;
  const double horizon = camera.HorizonRow();
  for (const Eigen::Vector2d& p : dense) {
    if (p.y() <= horizon + 5) continue;
    const Eigen::Vector2d g = maps.Ground(p);
    if (have_previous) run += (g - previous).norm();
    previous = g;
    have_previous = true;
    if (run >= kTypeStep) {
      samples.push_back(p);
      run = 0;
    }
  }
  return samples;
}

// Two bars side by side at point p of row `row` (w: a 15 cm marking's width
// in pixels): the profile across +-0.3 m has two peaks 0.1..0.45 m apart
// with the road showing between them. `peaks` is scratch space.
bool TwinBarsAt(const cv::Mat& frame, const Eigen::Vector2d& p, int row, double w,
                std::vector<int>& peaks) {
  // Along the row, 3 cm on the road is 0.2 w pixels (w: 15 cm).
  std::array<double, 21> profile;
  for (int k = -10; k <= 10; ++k) {
    const int c = static_cast<int>(std::lround(p.x() + 0.2 * w * k));
    profile[static_cast<size_t>(k + 10)] = c >= 0 && c < frame.cols ? GreyAt(frame, row, c) : 0.0;
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
  for (size_t a = 0; a + 1 < peaks.size(); ++a) {
    const int k0 = peaks[a], k1 = peaks[a + 1];
    const double gap_m = 0.03 * (k1 - k0);
    if (gap_m < 0.1 || gap_m > 0.45) continue;
    // The dip goes at least half way down to the road's level (texture on
    // one line does not).
    double dip = 1e9;
    for (int k = k0 + 1; k < k1; ++k) dip = std::min(dip, profile[static_cast<size_t>(k)]);
    const double low_peak =
        std::min(profile[static_cast<size_t>(k0)], profile[static_cast<size_t>(k1)]);
    if (low_peak >= floor + 20 && dip <= floor + 0.5 * (low_peak - floor)) return true;
  }
  return false;
}

// What the samples along a lane showed.
struct TypeEvidence {
  int n = 0;                  // samples read
  int on = 0;                 // painted (a bar or two)
  int steps = 0;              // unpainted with a brightness step across
  int resolvable = 0;         // painted samples checked for twin bars
  int doubles = 0;            // of those, twin bars
  std::vector<bool> pattern;  // painted or not, near to far
};

// Sample `index` (0-based among those read) at p: whether it is paint,
// counted into `evidence`.
void ReadTypeSample(const cv::Mat& frame, const Eigen::Vector2d& p, int row, const BarWindows& b,
                    TypeEvidence& evidence, std::vector<int>& peaks) {
  const int u = b.u, half = b.half, off = b.off, span = b.span;
  const double w = b.width_px;
  const int n = ++evidence.n;
  // The paint against the road on both sides, at the spline's column or,
  // when that fails, up to half a marking width either side: the spline is
  // placed to a pixel or so, and far away a marking is 2-3 pixels wide (a
  // solid line read off its paint would show gaps).
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
  // A double line's centre (where its lane runs) is the dip between its
  // bars, not a bar, so the twin check runs where there is no bar, and on
  // every other bar sample (a double line runs on: half of them tell as
  // much for half the reads).
  const bool check = w >= 4.0 && (!bar || (n % 2) == 0);
  const bool twin = check && TwinBarsAt(frame, p, row, w, peaks);
  const bool painted = bar || twin;
  if (check && painted) {
    ++evidence.resolvable;
    evidence.doubles += twin;
  }
  if (!painted && std::abs(left - right) >= 15.0) ++evidence.steps;
  evidence.on += painted;
  evidence.pattern.push_back(painted);
}

// The marking's type from what its samples showed.
MarkingType TypeOfEvidence(const TypeEvidence& e) {
  if (e.n < 12) return MarkingType::kUnknown;
  const double on_share = static_cast<double>(e.on) / e.n;
  if (on_share < 0.15) {
    return e.steps >= 0.5 * e.n ? MarkingType::kRoadEdge : MarkingType::kUnknown;
  }
  if (e.resolvable >= 6 && e.doubles >= 0.4 * e.resolvable) return MarkingType::kDouble;
  // Painted runs and the gaps between them (not the ends: paint fades into
  // the distance, and the view ends).
  const std::vector<bool>& pattern = e.pattern;
  double longest_on = 0, longest_gap = 0, current = 0;
  bool seen_paint = false;
  for (size_t i = 0; i <= pattern.size(); ++i) {
    const bool end = i == pattern.size();
    if (!end && (i == 0 || pattern[i] == pattern[i - 1])) {
      current += kTypeStep;
      continue;
    }
    // A run of pattern[i - 1] ends here.
    if (pattern[i - 1]) {
      longest_on = std::max(longest_on, current);
      seen_paint = true;
    } else if (seen_paint && !end) {
      longest_gap = std::max(longest_gap, current);
    }
    current = kTypeStep;
  }
  // A long stretch of paint is a solid line (another stretch may be hidden
  // by a vehicle); short dashes with gaps between them are a dashed line
  // (dashes of 2-6 m: US 3 m, Chinese urban 2 and 6 m).
  if (longest_on > 6.5 || (on_share >= 0.85 && longest_gap < 1.0)) return MarkingType::kSolid;
  if (longest_gap >= 1.5 && longest_on >= 0.5) return MarkingType::kDashed;
  return MarkingType::kUnknown;
}

MarkingType TypeWithMaps(const cv::Mat& frame, const Lane& lane, const CameraModel& camera,
                         const PlaneMaps& maps, int top_row, int bottom_row) {
  if (!ReadableForType(frame)) return MarkingType::kUnknown;
  const int bottom = bottom_row < 0 ? frame.rows : std::min(bottom_row, frame.rows);
  const std::vector<Eigen::Vector2d> samples = SamplesAlongRoad(lane, camera, maps);
  TypeEvidence evidence;
  evidence.pattern.reserve(samples.size());
  std::vector<int> peaks;  // a twin check's peaks (reused)
  peaks.reserve(10);
  for (const Eigen::Vector2d& p : samples) {
    const int row = static_cast<int>(std::lround(p.y()));
    if (row < top_row || row >= bottom) continue;
    const std::optional<BarWindows> b = BarWindowsAt(maps, p, frame.cols, 1.5);
    if (b) ReadTypeSample(frame, p, row, *b, evidence, peaks);
  }
  return TypeOfEvidence(evidence);
}

}  // namespace

MarkingColor MarkingColorOf(const cv::Mat& bgr, const Lane& lane, const CameraModel& camera,
                            int top_row, int bottom_row) {
  if (bgr.type() != CV_8UC3) return MarkingColor::kUnknown;
  return ColorWithMaps(bgr, lane, camera, PlaneMaps(camera), top_row, bottom_row);
}

MarkingType MarkingTypeOf(const cv::Mat& frame, const Lane& lane, const CameraModel& camera,
                          int top_row, int bottom_row) {
  if (!ReadableForType(frame)) return MarkingType::kUnknown;
  return TypeWithMaps(frame, lane, camera, PlaneMaps(camera), top_row, bottom_row);
}

std::vector<Marking> ReadMarkings(const cv::Mat& frame, const CameraModel& camera,
                                  const std::vector<Lane>& lanes, int top_row, int bottom_row) {
  std::vector<Marking> markings(lanes.size());
  if (lanes.empty()) return markings;
  const PlaneMaps maps(camera);  // one per frame, for every lane
  for (size_t i = 0; i < lanes.size(); ++i) {
    // An inferred boundary is hidden (by a vehicle): what lies there is not
    // its paint.
    if (lanes[i].inferred) continue;
    markings[i].color = ColorWithMaps(frame, lanes[i], camera, maps, top_row, bottom_row);
    markings[i].type = TypeWithMaps(frame, lanes[i], camera, maps, top_row, bottom_row);
  }
  return markings;
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

}  // namespace lane
