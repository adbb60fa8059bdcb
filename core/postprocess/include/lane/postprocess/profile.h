// Intensity profiles across a curve: sampling, Gaussian smoothing on a
// quantised sigma grid, and the strongest peak. The tools of stage 7's
// localisation and extension (postprocess.h, image_extension.h) and of the
// marking checks.
#ifndef LANE_POSTPROCESS_PROFILE_H_
#define LANE_POSTPROCESS_PROFILE_H_

#include <Eigen/Core>
#include <cmath>
#include <optional>
#include <vector>

#include "lane/geometry/channel_view.h"

namespace lane {

// A curve's normal: its tangent turned by +90 degrees.
inline Eigen::Vector2d Normal(const Eigen::Vector2d& tangent) {
  return Eigen::Vector2d(-tangent.y(), tangent.x());
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

}  // namespace lane

#endif  // LANE_POSTPROCESS_PROFILE_H_
