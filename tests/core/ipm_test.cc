#include "lane/ipm.h"

#include <gtest/gtest.h>

namespace lane {
namespace {

TEST(IpmTest, RoundTripsBetweenIpmImageAndGround) {
  auto m = IpmMapping::Create(CameraModel{}, IpmOptions{});
  ASSERT_TRUE(m.ok()) << m.status();
  for (double r = 0; r < m->height(); r += 7) {
    for (double c = 0; c < m->width(); c += 9) {
      const Eigen::Vector2d ipm(c, r);
      const Eigen::Vector2d back = m->ImageToIpm(m->IpmToImage(ipm));
      ASSERT_NEAR(back.x(), c, 1e-6 * std::max(1.0, c));
      ASSERT_NEAR(back.y(), r, 1e-6 * std::max(1.0, r));
      const Eigen::Vector2d g = m->IpmToGround(ipm);
      ASSERT_NEAR((m->GroundToIpm(g) - ipm).norm(), 0, 1e-9);
    }
  }
}

TEST(IpmTest, ScaleAndOrientationOfTheCaltechCamera) {
  auto m = IpmMapping::Create(CameraModel{}, IpmOptions{});
  ASSERT_TRUE(m.ok()) << m.status();
  // The data README quotes ~8.9 px/m across and ~10.5 px/m along the road.
  EXPECT_NEAR(1.0 / m->metres_per_px_x(), 8.9, 0.5);
  EXPECT_NEAR(1.0 / m->metres_per_px_y(), 10.5, 0.6);
  // Row 0 is the farthest row; columns grow to the right.
  EXPECT_GT(m->IpmToGround({80, 0}).y(), m->IpmToGround({80, 119}).y());
  EXPECT_GT(m->IpmToGround({150, 60}).x(), m->IpmToGround({10, 60}).x());
  // A ground line parallel to the road is a vertical line in the top view.
  const Eigen::Vector2d a = m->GroundToIpm({1.0, m->y_min() + 1});
  const Eigen::Vector2d b = m->GroundToIpm({1.0, m->y_max() - 1});
  EXPECT_NEAR(a.x(), b.x(), 1e-9);
}

TEST(IpmTest, ApplySamplesTheImageAndFillsOutsideTheRoiWithTheMean) {
  CameraModel cam;
  auto m = IpmMapping::Create(cam, IpmOptions{});
  ASSERT_TRUE(m.ok());
  // Left half dark, right half bright: the top view's left columns read dark.
  cv::Mat img(cam.image_height, cam.image_width, CV_8UC1, cv::Scalar(50));
  img.colRange(cam.image_width / 2, cam.image_width).setTo(200);
  const cv::Mat top = m->Apply(img);
  ASSERT_EQ(top.type(), CV_32FC1);
  ASSERT_EQ(top.cols, 160);
  ASSERT_EQ(top.rows, 120);
  ASSERT_TRUE(m->valid_mask().at<uint8_t>(100, 60) && m->valid_mask().at<uint8_t>(100, 100));
  EXPECT_NEAR(top.at<float>(100, 60), 50 / 255.0, 1e-3);
  EXPECT_NEAR(top.at<float>(100, 100), 200 / 255.0, 1e-3);
  const double mean_valid = cv::mean(top, m->valid_mask())[0];
  const cv::Mat invalid = m->valid_mask() == 0;
  ASSERT_GT(cv::countNonZero(invalid), 0);
  EXPECT_NEAR(cv::mean(top, invalid)[0], mean_valid, 1e-5);
  // The channel argument picks one channel of a colour frame.
  cv::Mat bgr(cam.image_height, cam.image_width, CV_8UC3, cv::Scalar(10, 20, 30));
  EXPECT_NEAR(m->Apply(bgr, 2).at<float>(100, 80), 30 / 255.0, 1e-3);
}

TEST(IpmTest, RoiIsClippedBelowTheHorizon) {
  CameraModel cam;
  IpmOptions o;
  o.roi.top = 0;  // far above the horizon (row ~171)
  auto m = IpmMapping::Create(cam, o);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_GE(m->roi().top, cam.HorizonRow() + o.horizon_margin_px - 1e-9);
}

TEST(IpmTest, RejectsRoisWithNothingToMap) {
  CameraModel cam;
  IpmOptions above;
  above.roi = {100, 500, 10, 150};  // entirely above the horizon
  auto a = IpmMapping::Create(cam, above);
  EXPECT_EQ(a.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(a.status().message().find("horizon"), std::string::npos) << a.status();
  IpmOptions outside;
  outside.roi = {700, 900, 300, 400};  // right of a 640-wide image
  EXPECT_EQ(IpmMapping::Create(cam, outside).status().code(), absl::StatusCode::kInvalidArgument);
  IpmOptions inverted;
  inverted.roi = {400, 100, 300, 400};
  EXPECT_EQ(IpmMapping::Create(cam, inverted).status().code(), absl::StatusCode::kInvalidArgument);
  IpmOptions tiny;
  tiny.width = 0;
  EXPECT_EQ(IpmMapping::Create(cam, tiny).status().code(), absl::StatusCode::kInvalidArgument);
  CameraModel bad;
  bad.fu = -1;
  EXPECT_EQ(IpmMapping::Create(bad, IpmOptions{}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace lane
