// Stage 7: post-processing (paper section II-E): localisation along normals,
// extension along the tangent, geometric checks with fallback to the RANSAC
// line. Done in the top view and again in the image.
#ifndef LANE_POSTPROCESS_H_
#define LANE_POSTPROCESS_H_

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <optional>

#include "absl/status/status.h"
#include "lane/bezier.h"
#include "lane/ipm.h"
#include "lane/line_fit.h"

namespace lane {

struct PostprocessOptions {
  // --- checks in the top view ---
  // Splines whose mean direction is further than this from vertical are
  // dropped (reference: closer than 70 deg to horizontal), degrees.
  double ipm_max_angle_from_vertical_deg = 20.0;
  // Splines whose control polygon is less straight than this (mean cosine of
  // its angles, 1 = straight) fall back to the RANSAC line.
  double min_straightness = 0.85;
  // Splines shorter than this fraction of the top view's height fall back to
  // the RANSAC line.
  double min_length_fraction = 0.25;
  // Marking check (not in the paper): a painted marking is a bright bar, darker
  // on BOTH sides, whereas a curb or the edge of the asphalt is a step that
  // is dark on one side only, yet excites the second-derivative filter too.
  // Along the top-view spline, the IPM intensity must exceed the intensity
  // `side_offset_m` to the left and to the right by at least
  // `min_side_contrast` (IPM intensity units, 1 = full scale) along at least
  // `min_bar_fraction` of its length (so dashed markings pass).
  // 0 disables the check. The paper lists curbs as its main source of false
  // positives (section IV).
  double side_offset_m = 0.3;
  double min_side_contrast = 0.027;
  // A dashed line is paint along a quarter of its length on US roads (3 m
  // dashes, 9 m gaps; 2 m / 4 m, a third, on Chinese urban roads), and a
  // top view about one dash cycle deep shows a dash cut by its edge as less.
  // A quarter, the old fixed value, lost dashed lines on about half their
  // frames; a fifth keeps them. The contrast above went up with it, from
  // 0.015, to keep the false-positive rate (cordova1, docs/accuracy-log.md
  // entry 35).
  double min_bar_fraction = 0.2;
  // Vertical objects (lane/vehicle_check.h): a top-view spline closer in
  // direction to the ray from the camera's foot point through it than to the
  // road's direction is dropped, where the two directions differ by at
  // least this many degrees (twice the ~3 deg by which yaw and curvature
  // tilt markings from the road's axis). 0 disables the test.
  // The road's direction is the frame's median candidate direction; a
  // candidate that bends by more than max_ray_bend_m from its straight line
  // is a marking on a curve, not a (straight) ray.
  double min_ray_angle_deg = 6.0;
  // Bright neighbours (lane/vehicle_check.h): a top-view spline with a side,
  // side_offset_m across, brighter than the road by more than half its own
  // contrast along more than this fraction of its length is dropped: a
  // marking has road on both sides. >= 1 disables it (the default: on the
  // dev clips it cost more markings, beside double lines and bright curbs,
  // than it removed false positives; docs/accuracy-log.md).
  double max_bright_side_fraction = 1.0;
  double max_ray_bend_m = 0.15;
  // Extension in the top view: tangent step and normal half-search, IPM px.
  double ipm_extend_step_px = 5.0;
  double ipm_normal_search_px = 10.0;

  // --- in the image (values for a 640 px wide image; scaled by width/640) ---
  // Samples of the top-view spline mapped back to refit it in the image.
  int backproject_samples = 11;
  // Localisation: points sampled on the spline and half length of the normal
  // segment searched for the brightest (Gaussian-smoothed) profile peak.
  int localize_points = 21;
  double localize_search_px = 20.0;
  double profile_sigma_px = 2.0;
  // A localised point is rejected when the direction to it from the previous
  // point turns by more than acos(localize_min_cos) from the spline's.
  double localize_min_cos = 0.9;
  // Extension: tangent step and normal half-search, pixels.
  double extend_step_px = 10.0;
  double extend_search_px = 20.0;
  // Stop when the profile contrast falls below this fraction of the mean
  // contrast of the localised points.
  double continuation_threshold = 0.35;
  // Stop when the direction turns by more than acos(cos) from the spline's
  // direction: looser going up (far, curves look sharper) than down.
  double extend_min_cos_up = 0.86;
  double extend_min_cos_down = 0.95;
  // Extension stays between these image rows. Negative = derived from the
  // camera: top = horizon + 0.15 * (ROI bottom - horizon), bottom = ROI bottom
  // + 0.2 * (ROI bottom - horizon) (reference: rows 200..380 of the Caltech
  // camera, whose horizon is at row 171 and ROI bottom at 350).
  double extend_min_row = -1;
  double extend_max_row = -1;
  // Extension in the image along the road's geometry (lane/image_extension.h)
  // instead of the reference's walk (stop at the first step without a
  // profile peak): each step looks for a bright bar as wide as a marking
  // across a normal `extend_search_m` metres long on the road (so the window
  // follows the perspective: the reference's fixed 20 px are +-1.4 m at the
  // Caltech camera's far rows and +-0.2 m at its near rows), walks through
  // up to `extend_gap_m` metres without one (the gap between two dashes: 6
  // to 9 m on US and Chinese roads; beyond that the lane is not followed),
  // and, with `extend_to_max_row`, extrapolates the final straight segment
  // down to `extend_max_row` (the road continues straight under the last
  // evidence; lane labels such as CULane's run to the image bottom).
  bool extend_geometric = true;
  // Localisation in the image along the road's geometry (LocalizeInImage)
  // instead of with the fixed pixel values above: the normal is searched
  // +-localize_search_m on the road and the profile smoothed with
  // localize_sigma_m on the road (at least profile_sigma_px), so the two
  // lines of a double line merge into one peak at their centre (0.1 m: a
  // marking's width; the lines of a double line are 10-15 cm apart).
  bool localize_geometric = true;
  double localize_search_m = 0.4;
  double localize_sigma_m = 0.1;
  double extend_search_m = 0.4;
  double extend_gap_m = 6.0;
  bool extend_to_max_row = false;
  // The final image spline is cut to the part inside the image and on image
  // content (not black: outside a lens's image circle). A top-view spline
  // spans the whole top view, which extends beyond the image's sides where
  // the ground rectangle does; a lane stops where the image does.
  bool clip_to_image = true;
  // The final image spline, mapped to the ground, must run within
  // ipm_max_angle_from_vertical_deg of the road's direction, as the top-view
  // spline had to (paper II-E.3: geometric checks after each step).
  bool check_ground_angle = true;
  // Colour (lane/marking_check.h): an image spline whose median redness
  // (R - G) / R exceeds this is dropped. Yellow paint reads ~0.15, faded
  // orange ~0.3, red curbs, red cars and tail lights 0.5-0.7; 0.4 lies
  // between. >= 1 disables it. Grey frames are not checked.
  double max_redness = 0.4;
  // A final image spline shorter than this (pixels at 640 width) is replaced
  // by the line.
  double min_image_length_px = 40.0;
  // Turn extension/localisation in the image on or off.
  bool localize_in_image = true;
  bool extend_in_image = true;
  bool extend_in_ipm = true;

  absl::Status Validate() const;
};

// One channel of an image without copying it out: a CV_8UC1 or CV_32FC1
// image (channel 0), or channel `channel` of a CV_8UC3 image, or with
// `channel2` >= 0 the per-pixel minimum of two channels of a CV_8UC3 image,
// or with `channel2` == kGrayOfBgr the grey (BT.601, as cv::COLOR_BGR2GRAY)
// of a CV_8UC3 BGR image.
inline constexpr int kGrayOfBgr = -2;
inline int GrayOfBgr(const uint8_t* p) {
  return (p[0] * 1868 + p[1] * 9617 + p[2] * 4899 + 8192) >> 14;
}
//
// Only rows [top(), bottom()) are read (row_begin/row_end; the whole image
// by default): the detector sets them to the rows it needs of a frame
// (Detector::Needs), so that a frame decoded only there reads exactly as a
// whole one. Points in other rows count as outside the image.
struct ChannelView {
  ChannelView(const cv::Mat& m, int c = 0, int c2 = -1)  // NOLINT: implicit
      : image(m), channel(c), channel2(c2) {}
  cv::Mat image;
  int channel = 0;
  int channel2 = -1;
  int row_begin = 0;
  int row_end = -1;  // -1: the image's height
  int cols() const { return image.cols; }
  int rows() const { return image.rows; }
  int top() const { return row_begin; }
  int bottom() const { return row_end < 0 ? image.rows : row_end; }
  // Whether (x, y) lies inside the image and the rows read.
  bool Inside(double x, double y) const {
    return x >= 0 && y >= top() && x <= image.cols - 1 && y <= bottom() - 1;
  }
  float At(int x, int y) const {
    if (image.depth() == CV_32F) return image.ptr<float>(y)[x];
    const uint8_t* p = image.ptr<uint8_t>(y) + x * image.channels();
    if (channel2 == kGrayOfBgr) return static_cast<float>(GrayOfBgr(p));
    return channel2 >= 0 ? std::min(p[channel], p[channel2]) : p[channel];
  }
  // Bilinear sample; 0 outside the image. Inline: profile sampling calls it
  // tens of thousands of times per frame.
  float Bilinear(double x, double y) const;
  // Bilinear(x, y) at each point c + i * d, i = -h..h, into out[0 .. 2h],
  // with the channel's case decided once for the run. Returns whether every
  // point lies inside.
  bool SampleAlong(const Eigen::Vector2d& c, const Eigen::Vector2d& d, int h, float* out) const;
};

namespace internal {
// Bilinear sample of channel `channel` of `m` at (x, y) (inside the image and
// rows top..bottom - 1), reading only those rows.
template <typename T>
inline float BilinearT(const cv::Mat& m, int cn, int channel, double x, double y, int top,
                       int bottom) {
  const int x0 = std::min(static_cast<int>(x), std::max(0, m.cols - 2));
  const int y0 = std::min(static_cast<int>(y), std::max(top, bottom - 2));
  const int dx = m.cols > 1 ? cn : 0;
  const size_t dy = bottom - top > 1 ? m.step[0] : 0;
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const uint8_t* p = m.data + y0 * m.step[0] + (x0 * cn + channel) * sizeof(T);
  const T* p00 = reinterpret_cast<const T*>(p);
  const T* p01 = reinterpret_cast<const T*>(p + dx * sizeof(T));
  const T* p10 = reinterpret_cast<const T*>(p + dy);
  const T* p11 = reinterpret_cast<const T*>(p + dy + dx * sizeof(T));
  return (1 - fy) * ((1 - fx) * *p00 + fx * *p01) + fy * ((1 - fx) * *p10 + fx * *p11);
}

}  // namespace internal

inline float ChannelView::Bilinear(double x, double y) const {
  if (!Inside(x, y)) return 0.f;
  if (channel2 != -1) {
    const int x0 = std::min(static_cast<int>(x), std::max(0, image.cols - 2));
    const int y0 = std::min(static_cast<int>(y), std::max(top(), bottom() - 2));
    const int x1 = std::min(x0 + 1, image.cols - 1), y1 = std::min(y0 + 1, bottom() - 1);
    const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
    return (1 - fy) * ((1 - fx) * At(x0, y0) + fx * At(x1, y0)) +
           fy * ((1 - fx) * At(x0, y1) + fx * At(x1, y1));
  }
  if (image.depth() == CV_32F)
    return internal::BilinearT<float>(image, image.channels(), channel, x, y, top(), bottom());
  return internal::BilinearT<uint8_t>(image, image.channels(), channel, x, y, top(), bottom());
}

inline bool ChannelView::SampleAlong(const Eigen::Vector2d& c, const Eigen::Vector2d& d, int h,
                                     float* out) const {
  bool all_inside = true;
  // c + i * d rounds monotonically in i, so when both ends lie inside the
  // (convex) image every point between them does: no test per point then.
  const Eigen::Vector2d first = c + (-h) * d, last = c + h * d;
  const bool ends_inside = Inside(first.x(), first.y()) && Inside(last.x(), last.y());
  const auto run = [&](const auto& sample) {
    if (ends_inside) {
      for (int i = -h; i <= h; ++i) {
        const Eigen::Vector2d p = c + i * d;
        out[i + h] = sample(p.x(), p.y());
      }
      return;
    }
    for (int i = -h; i <= h; ++i) {
      const Eigen::Vector2d p = c + i * d;
      const bool inside = Inside(p.x(), p.y());
      all_inside = all_inside && inside;
      out[i + h] = inside ? sample(p.x(), p.y()) : 0.f;
    }
  };
  if (channel2 != -1) {
    run([this](double x, double y) { return Bilinear(x, y); });
  } else {
    const int cn = image.channels(), t = top(), b = bottom();
    if (image.depth() == CV_32F) {
      run([&](double x, double y) {
        return internal::BilinearT<float>(image, cn, channel, x, y, t, b);
      });
    } else {
      run([&](double x, double y) {
        return internal::BilinearT<uint8_t>(image, cn, channel, x, y, t, b);
      });
    }
  }
  return all_inside;
}

// Samples of one channel along the segment center +- half * normal, one per
// pixel step, bilinear, into `out` (resized: no allocation once it has
// grown); positions outside the image read as 0.
void SampleProfile(const ChannelView& image, const Eigen::Vector2d& center,
                   const Eigen::Vector2d& normal, double half, std::vector<float>& out);

// A smoothing sigma that follows the image's scale (pixels per metre at a
// row) rounded to the nearest 1/kSigmaSteps px: 1/16 px is far below what
// changes a profile's peak, and profiles of nearby rows then share one
// kernel instead of computing theirs (exps) each time.
inline constexpr int kSigmaSteps = 16;
inline double QuantizedSigma(double sigma) { return std::round(sigma * kSigmaSteps) / kSigmaSteps; }

// `in` smoothed with a Gaussian of `sigma` samples (truncated at 2.5 sigma,
// renormalised where it passes the ends) into `out`. T: float or double.
// The taps are computed once per sigma and thread; sigmas on the grid of
// QuantizedSigma below 8 keep theirs for good.
template <typename T>
void SmoothProfile(const std::vector<T>& in, double sigma, std::vector<double>& out);

namespace internal {
// std::max_element(s, s + n) - s for n >= 1 values that are not NaN: the
// first index of the largest.
int FirstMaxIndex(const double* s, int n);
}  // namespace internal

// Offset (along the normal, pixels) of the strongest peak of the smoothed
// profile and its contrast over the profile's mean. nullopt if flat.
struct ProfilePeak {
  double offset = 0;
  double contrast = 0;
};
std::optional<ProfilePeak> FindProfilePeak(const std::vector<float>& profile, double sigma_px);

// Localisation: moves `n` samples of the spline to the profile peak along
// their normals, rejects points that turn too sharply, and refits. nullopt if
// fewer than 4 points survive. `mean_contrast` receives the points' mean
// contrast when not null.
std::optional<Bezier> LocalizeSpline(const Bezier& spline, const ChannelView& image, int n,
                                     double search_px, double sigma_px, double min_cos,
                                     double* mean_contrast);

// The (1 - bar_fraction) quantile over samples of `spline` of min(I(p) -
// I(p - d n), I(p) - I(p + d n)) where n is the normal, d = side_offset_px
// and I(p) is the brightest value within 1 px of p along n: how much
// brighter the curve is than both of its sides along bar_fraction of its
// length (a high quantile lets dashed markings pass).
double BarContrast(const Bezier& spline, const ChannelView& image, double side_offset_px,
                   double bar_fraction, int samples = 20);

struct ExtendOptions {
  double step_px = 10;
  double search_px = 20;
  double sigma_px = 2;
  double min_contrast = 0;      // absolute contrast to continue
  double min_cos_start = 0.95;  // going towards t=0
  double min_cos_end = 0.86;    // going towards t=1
  double min_row = 0;           // stay within these rows
  double max_row = 1e9;
  int max_steps = 60;
};
// Extension at both ends along the tangent, then a refit through the old
// samples and the new points. Returns the input when nothing was added.
Bezier ExtendSpline(const Bezier& spline, const ChannelView& image, const ExtendOptions& options);

// ---- Stage 7 as a whole ------------------------------------------------------

// A lane candidate through stages 6 to 8.
struct SplineCandidate {
  IpmLine line;  // the RANSAC line it was fitted around: the shape checks' fallback
  Bezier ipm;    // top view, P0 the farther end
  Bezier image;  // image, set by post-processing, P0 the upper end
  double score = 0;
};

// One frame's images that post-processing reads.
struct PostprocessFrame {
  const IpmMapping& ipm;
  const cv::Mat& top_view;     // CV_32F, mean removed
  const cv::Mat& filtered;     // the filter's response
  const ChannelView& channel;  // the detector's channel of the frame
  const cv::Mat& frame;        // the frame itself (colour checks)
};

// Stage 7: for each candidate, in order, in the top view: localise, check
// the shape (else fall back to its line), extend, check the direction and the
// top-view marking checks (candidate_checks.h); back-project into the image;
// there localise, extend and finish (clip, colour, ground angle); finally drop
// an image spline that lies along one kept before it. `marking_width_m` is
// the filter's marking width; `merge_distance_px` the spline RANSAC's
// duplicate distance (scaled to the image here). Returns the survivors with
// their image splines.
std::vector<SplineCandidate> PostprocessCandidates(const std::vector<SplineCandidate>& candidates,
                                                   const PostprocessFrame& frame,
                                                   const PostprocessOptions& options,
                                                   double marking_width_m,
                                                   double merge_distance_px);

}  // namespace lane

#endif  // LANE_POSTPROCESS_H_
