// The profile primitives of post-processing (lane/postprocess/profile.h): the
// smoothing and the sampling along a normal are written for speed (blocked
// sums, no bounds test per point when a segment's ends lie inside); here they
// are held to the plain definitions they must equal exactly.
#include "lane/postprocess/profile.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "lane/postprocess/spline_walk.h"

namespace lane {
namespace {

// The definition: taps -h..h, h = max(1, ceil(2.5 sigma)), w_j =
// exp(-j^2 / (2 sigma^2)); each output sums its in-range taps in order,
// lowest first, and divides by their weight (added in the same order).
std::vector<double> PlainSmooth(const std::vector<float>& in, double sigma) {
  const int n = static_cast<int>(in.size());
  const int h = std::max(1, static_cast<int>(std::ceil(2.5 * sigma)));
  std::vector<double> w(2 * h + 1);
  for (int j = -h; j <= h; ++j) w[j + h] = std::exp(-0.5 * j * j / (sigma * sigma));
  std::vector<double> out(n);
  for (int i = 0; i < n; ++i) {
    double s = 0, ws = 0;
    for (int j = std::max(-h, -i); j <= std::min(h, n - 1 - i); ++j) {
      s += w[j + h] * in[i + j];
      ws += w[j + h];
    }
    out[i] = s / ws;
  }
  return out;
}

TEST(ProfileTest, SmoothingEqualsThePlainSumExactly) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> value(0.f, 255.f);
  std::vector<double> smooth;
  // Lengths around the block of eight and below the kernel's width; sigmas
  // whose kernels are cached and ones seen once, on the grid of
  // QuantizedSigma (kept in slots of their own; its first and last below
  // 8 px) and off it.
  for (const double sigma : {0.7, 1.0, 2.5, 4.0, 4.0, 3.37, 9.0, QuantizedSigma(1.23),
                             QuantizedSigma(1.23), 0.0625, 7.9375, 8.0, 0.7}) {
    for (const int n : {1, 2, 3, 7, 8, 9, 16, 17, 23, 41, 64, 101}) {
      std::vector<float> in(n);
      for (float& v : in) v = value(rng);
      SmoothProfile(in, sigma, smooth);
      const std::vector<double> want = PlainSmooth(in, sigma);
      ASSERT_EQ(smooth.size(), want.size());
      for (int i = 0; i < n; ++i) {
        ASSERT_EQ(smooth[i], want[i]) << "sigma " << sigma << " n " << n << " i " << i;
      }
    }
  }
}

// The first index of the largest value, as std::max_element gives it: ties
// (values drawn from a few levels, -0 and +0 among them) at every length
// around the block of four.
TEST(ProfileTest, FirstMaxIndexEqualsTheLibrarysMaxElement) {
  std::mt19937 rng(9);
  const double levels[] = {-3.0, -0.0, 0.0, 1.5, 2.0};
  std::uniform_int_distribution<int> pick(0, 4);
  for (int n = 1; n <= 23; ++n) {
    for (int trial = 0; trial < 50; ++trial) {
      std::vector<double> v(n);
      for (double& x : v) x = levels[pick(rng)];
      const int want = static_cast<int>(std::max_element(v.begin(), v.end()) - v.begin());
      ASSERT_EQ(internal::FirstMaxIndex(v.data(), n), want) << "n " << n << " trial " << trial;
    }
  }
}

TEST(ProfileTest, QuantizedSigmaRoundsToTheNearestSixteenth) {
  EXPECT_EQ(QuantizedSigma(1.23), 1.25);    // 19.68 sixteenths
  EXPECT_EQ(QuantizedSigma(0.7), 0.6875);   // 11.2
  EXPECT_EQ(QuantizedSigma(2.0), 2.0);      // on the grid already
  EXPECT_EQ(QuantizedSigma(3.97), 4.0);     // 63.52
  EXPECT_EQ(QuantizedSigma(3.95), 3.9375);  // 63.2
}

TEST(ProfileTest, SamplingAlongANormalEqualsPointByPointBilinear) {
  cv::Mat bgr(60, 80, CV_8UC3);
  cv::randu(bgr, 0, 256);
  cv::Mat grey(60, 80, CV_8UC1);
  cv::randu(grey, 0, 256);
  std::vector<ChannelView> views = {ChannelView(bgr, 2), ChannelView(grey), ChannelView(bgr, 2, 1)};
  ChannelView rows(bgr, 1);
  rows.row_begin = 10;
  rows.row_end = 50;
  views.push_back(rows);
  const Eigen::Vector2d normal = Eigen::Vector2d(0.8, -0.6) * 1.25;
  for (const ChannelView& view : views) {
    // Inside, touching the last column and row, and leaving the image.
    for (const Eigen::Vector2d& c :
         {Eigen::Vector2d(40.3, 30.7), Eigen::Vector2d(69.0, 40.25), Eigen::Vector2d(5.5, 12.5),
          Eigen::Vector2d(72.0, 30.0), Eigen::Vector2d(76.0, 55.0)}) {
      const int h = 8;
      std::vector<float> out(2 * h + 1, -1.f);
      const bool all_inside = view.SampleAlong(c, normal, h, out.data());
      bool inside = true;
      for (int i = -h; i <= h; ++i) {
        const Eigen::Vector2d p = c + i * normal;
        inside = inside && view.Inside(p.x(), p.y());
        ASSERT_EQ(out[i + h], view.Bilinear(p.x(), p.y())) << "point " << i;
      }
      EXPECT_EQ(all_inside, inside);
    }
  }
}

}  // namespace
}  // namespace lane
