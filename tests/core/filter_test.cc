#include "lane/stages/filter.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <random>

#include "lane/stages/threshold.h"

namespace lane {
namespace {

TEST(FilterTest, KernelSigmasComeFromMetres) {
  FilterOptions o;
  o.min_sigma_x_px = 0.1;
  o.min_sigma_y_px = 0.1;
  // 0.05 m per pixel across, 0.1 m along: 3 inches = 1.524 px, 1 m = 10 px.
  const FilterKernels k = MakeFilterKernels(o, 0.05, 0.1);
  EXPECT_NEAR(k.sigma_x_px, 0.0762 / 0.05, 1e-9);
  EXPECT_NEAR(k.sigma_y_px, 10.0, 1e-9);
  // Halving the resolution halves the sigmas: the kernels follow the IPM.
  const FilterKernels k2 = MakeFilterKernels(o, 0.1, 0.2);
  EXPECT_NEAR(k2.sigma_x_px * 2, k.sigma_x_px, 1e-9);
  EXPECT_LT(k2.ky.rows, k.ky.rows);
}

TEST(FilterTest, KernelShapes) {
  const FilterKernels k = MakeFilterKernels(FilterOptions{}, 0.03, 0.1);
  ASSERT_EQ(k.kx.rows % 2, 1);
  ASSERT_EQ(k.ky.rows % 2, 1);
  const int cx = k.kx.rows / 2, cy = k.ky.rows / 2;
  // Across: positive centre lobe, negative side lobes, zero sum, symmetric.
  EXPECT_GT(k.kx.at<float>(cx), 0);
  float min_side = 0;
  double sum = 0, positive = 0;
  for (int i = 0; i < k.kx.rows; ++i) {
    const float v = k.kx.at<float>(i);
    sum += v;
    if (v > 0) positive += v;
    min_side = std::min(min_side, v);
    EXPECT_NEAR(v, k.kx.at<float>(k.kx.rows - 1 - i), 1e-7);
  }
  EXPECT_LT(min_side, 0);
  EXPECT_NEAR(sum, 0, 1e-5);
  EXPECT_NEAR(positive, 1, 1e-5);
  // Along: a Gaussian summing to one, peaked at the centre, symmetric.
  double gsum = 0;
  for (int i = 0; i < k.ky.rows; ++i) {
    gsum += k.ky.at<float>(i);
    EXPECT_LE(k.ky.at<float>(i), k.ky.at<float>(cy));
    EXPECT_NEAR(k.ky.at<float>(i), k.ky.at<float>(k.ky.rows - 1 - i), 1e-7);
  }
  EXPECT_NEAR(gsum, 1, 1e-5);
}

TEST(FilterTest, RespondsToBrightVerticalBarsOnly) {
  cv::Mat ipm(120, 160, CV_32F, cv::Scalar(0));
  ipm.colRange(80, 82).setTo(0.5);  // a bright vertical marking
  ipm.rowRange(30, 32).setTo(0.5);  // a bright horizontal stripe
  FilterOptions o;
  const FilterKernels k = MakeFilterKernels(o, 0.1, 0.1);
  const cv::Mat f = FilterTopView(ipm, k, o);
  EXPECT_GT(f.at<float>(60, 80), 0.1f);
  EXPECT_LT(std::abs(f.at<float>(31, 40)), 0.02f);  // the horizontal stripe is ignored
  EXPECT_LT(f.at<float>(60, 78), f.at<float>(60, 80));
  // Borders are zeroed.
  EXPECT_EQ(f.at<float>(60, 0), 0.f);
  EXPECT_EQ(f.at<float>(119, 80), 0.f);
}

// The filter runs only on the view's interior (the borders it zeroes are not
// computed), reading the pixels around the interior as they are: the result
// is the whole view filtered, then zeroed at the borders.
TEST(FilterTest, InteriorEqualsTheWholeViewFilteredThenZeroed) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  struct Case {
    int rows, cols, bx, by;
  };
  for (const Case c : {Case{120, 160, 10, 2}, Case{121, 163, 0, 0}, Case{60, 97, 3, 7},
                       Case{40, 30, 20, 50}, Case{40, 30, 15, 0}, Case{50, 64, 31, 1}}) {
    cv::Mat ipm(c.rows, c.cols, CV_32F);
    for (int r = 0; r < c.rows; ++r) {
      for (int x = 0; x < c.cols; ++x) ipm.at<float>(r, x) = u(rng);
    }
    FilterOptions o;
    o.zero_border_x_px = c.bx;
    o.zero_border_bottom_px = c.by;
    const FilterKernels k = MakeFilterKernels(o, 0.05, 0.1);
    cv::Mat want;
    cv::sepFilter2D(ipm, want, CV_32F, k.kx, k.ky, cv::Point(-1, -1), 0.0, cv::BORDER_REPLICATE);
    const int bx = std::min(c.bx, c.cols / 2), by = std::min(c.by, c.rows);
    want.colRange(0, bx).setTo(0);
    want.colRange(c.cols - bx, c.cols).setTo(0);
    want.rowRange(c.rows - by, c.rows).setTo(0);
    const cv::Mat got = FilterTopView(ipm, k, o);
    ASSERT_EQ(got.size(), want.size());
    ASSERT_EQ(got.type(), CV_32F);
    // Equal up to the rounding of OpenCV's vector and scalar paths (which
    // columns take which depends on the width filtered); a border read
    // wrongly would be off by the kernel's response, orders above this.
    EXPECT_LE(cv::norm(got, want, cv::NORM_INF), 1e-5)
        << c.rows << "x" << c.cols << " borders " << c.bx << ", " << c.by;
  }
}

TEST(ThresholdTest, QuantileInterpolates) {
  std::vector<float> v(101);
  std::iota(v.begin(), v.end(), 0.f);
  std::shuffle(v.begin(), v.end(), std::mt19937(3));
  EXPECT_FLOAT_EQ(Quantile(v, 0.975), 97.5f);
  std::vector<float> w = {4, 1, 3, 2};
  EXPECT_FLOAT_EQ(Quantile(w, 0.5), 2.5f);  // between 2 and 3
  std::vector<float> one = {7};
  EXPECT_FLOAT_EQ(Quantile(one, 0.9), 7.f);
}

TEST(ThresholdTest, KeepsTheTopValuesUnbinarised) {
  std::mt19937 rng(5);
  std::normal_distribution<float> n(0.f, 1.f);
  cv::Mat img(100, 100, CV_32F);
  for (int r = 0; r < 100; ++r)
    for (int c = 0; c < 100; ++c) img.at<float>(r, c) = n(rng);
  std::vector<float> all(img.begin<float>(), img.end<float>());
  for (float& x : all) x = std::max(x, 0.f);
  const float expected = Quantile(all, 0.975);
  cv::Mat copy = img.clone();
  const float thr = ApplyQuantileThreshold(copy, 0.975);
  EXPECT_NEAR(thr, expected, 1e-6);
  const int kept = cv::countNonZero(copy);
  EXPECT_NEAR(kept, 250, 2);  // 2.5 % of 10000
  for (int r = 0; r < 100; ++r) {
    for (int c = 0; c < 100; ++c) {
      const float v = copy.at<float>(r, c);
      ASSERT_TRUE(v == 0.f || (v >= thr && v == img.at<float>(r, c)));
    }
  }
}

TEST(ThresholdTest, IntoASecondImageEqualsInPlaceAndLeavesTheInput) {
  std::mt19937 rng(11);
  std::normal_distribution<float> n(0.f, 1.f);
  cv::Mat img(37, 53, CV_32F);  // odd sizes: the row loops' tails
  for (int r = 0; r < img.rows; ++r)
    for (int c = 0; c < img.cols; ++c) img.at<float>(r, c) = n(rng);
  const cv::Mat before = img.clone();
  cv::Mat in_place = img.clone(), out;
  const float thr_in_place = ApplyQuantileThreshold(in_place, 0.9);
  const float thr = ApplyQuantileThreshold(img, out, 0.9);
  EXPECT_EQ(thr, thr_in_place);
  EXPECT_EQ(cv::norm(img, before, cv::NORM_INF), 0.0);
  ASSERT_EQ(out.size(), img.size());
  EXPECT_EQ(cv::norm(out, in_place, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::countNonZero(out), 0);
}

TEST(ThresholdTest, MostlyZeroImagesKeepOnlyPositives) {
  cv::Mat img(10, 10, CV_32F, cv::Scalar(-1));
  img.at<float>(3, 3) = 2.f;
  const float thr = ApplyQuantileThreshold(img, 0.975);
  EXPECT_GE(thr, 0.f);
  EXPECT_EQ(cv::countNonZero(img), 1);
  EXPECT_EQ(img.at<float>(3, 3), 2.f);
  EXPECT_FALSE(ThresholdOptions{1.5}.Validate().ok());
}

}  // namespace
}  // namespace lane
