#include "lane/geometry/ipm.h"

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

// The CULane camera of configs/culane-driver161.json.
CameraModel CulaneCamera() {
  CameraModel cam;
  cam.fu = cam.fv = 1000;
  cam.cu = 820;
  cam.cv = 295;
  cam.pitch_deg = -4.858;
  cam.yaw_deg = 3.706;
  cam.height_m = 1.3;
  cam.image_width = 1640;
  cam.image_height = 590;
  return cam;
}

TEST(IpmTest, GroundViewHasTheRequestedExtentAndResolution) {
  IpmOptions o;
  o.view = IpmView::kGround;
  o.ground = {-7.5, 7.5, 8.0, 18.0, 0.0625, 0.125};
  const auto m = IpmMapping::Create(CulaneCamera(), o);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_EQ(m->width(), 240);
  EXPECT_EQ(m->height(), 80);
  EXPECT_NEAR(m->metres_per_px_x(), 0.0625, 1e-12);
  EXPECT_NEAR(m->metres_per_px_y(), 0.125, 1e-12);
  EXPECT_NEAR(m->x_min(), -7.5, 1e-12);
  EXPECT_NEAR(m->y_max(), 18.0, 1e-12);
  // The outer edges of the corner pixels are the rectangle's corners.
  EXPECT_NEAR((m->IpmToGround({-0.5, -0.5}) - Eigen::Vector2d(-7.5, 18)).norm(), 0, 1e-9);
  EXPECT_NEAR((m->IpmToGround({239.5, 79.5}) - Eigen::Vector2d(7.5, 8)).norm(), 0, 1e-9);
  // The derived ROI: the bounding box of the corners' images (the yaw tilts
  // the rows of constant distance a little), clipped to the image's columns
  // (at 8 m, +-7.5 m lies outside a 1640 px wide frame).
  const CameraModel cam = CulaneCamera();
  EXPECT_NEAR(m->roi().top,
              std::min(cam.GroundToImage({-7.5, 18}).y(), cam.GroundToImage({7.5, 18}).y()), 1e-9);
  EXPECT_NEAR(m->roi().bottom,
              std::max(cam.GroundToImage({-7.5, 8}).y(), cam.GroundToImage({7.5, 8}).y()), 1e-9);
  EXPECT_EQ(m->roi().left, 0);
  EXPECT_EQ(m->roi().right, 1639);
  // Pixels whose ground point lies outside the image are invalid.
  EXPECT_EQ(m->valid_mask().at<uint8_t>(79, 0), 0);
  EXPECT_EQ(m->valid_mask().at<uint8_t>(79, 120), 255);
}

TEST(IpmTest, GroundViewBeyondTheHorizonIsAnError) {
  IpmOptions o;
  o.view = IpmView::kGround;
  o.ground.y_max_m = 1e4;  // projects onto the horizon
  const auto m = IpmMapping::Create(CulaneCamera(), o);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status().code(), absl::StatusCode::kInvalidArgument);
  IpmOptions behind;
  behind.view = IpmView::kGround;
  behind.ground.y_min_m = 0.5;  // below the image
  behind.ground.y_max_m = 1.0;
  EXPECT_FALSE(IpmMapping::Create(CulaneCamera(), behind).ok());
}

// Fine vertical stripes, 1 px white / 1 px black: far finer than a top-view
// pixel near the camera (8 image columns), so a point sample reads either
// 0 or 1 while the true average is 0.5.
TEST(IpmTest, AreaSamplingAveragesTheFootprint) {
  const CameraModel cam = CulaneCamera();
  cv::Mat stripes(cam.image_height, cam.image_width, CV_8UC1);
  for (int x = 0; x < stripes.cols; ++x) stripes.col(x).setTo(x % 2 ? 255 : 0);
  IpmOptions o;
  o.view = IpmView::kGround;
  o.ground = {-5, 5, 8, 18, 0.0625, 0.125};
  o.interpolation = Interpolation::kArea;
  const auto area = IpmMapping::Create(cam, o);
  o.interpolation = Interpolation::kNearest;
  const auto nearest = IpmMapping::Create(cam, o);
  ASSERT_TRUE(area.ok() && nearest.ok());
  const cv::Mat a = area->Apply(stripes);
  const cv::Mat n = nearest->Apply(stripes);
  // Near rows (footprints several columns wide): the area average is close
  // to 0.5 everywhere; nearest reads 0 or 1.
  double worst_area = 0, worst_nearest = 0;
  for (int c = 10; c < a.cols - 10; ++c) {
    worst_area = std::max(worst_area, std::abs(a.at<float>(a.rows - 2, c) - 0.5));
    worst_nearest = std::max(worst_nearest, std::abs(n.at<float>(n.rows - 2, c) - 0.5));
  }
  EXPECT_LT(worst_area, 0.1);
  EXPECT_GT(worst_nearest, 0.45);
  EXPECT_GT(area->mean_taps(), 1.0);

  // A uniform image reads the same everywhere, whatever the footprint.
  const cv::Mat grey(cam.image_height, cam.image_width, CV_8UC1, cv::Scalar(100));
  const cv::Mat g = area->Apply(grey);
  double lo = 0, hi = 0;
  cv::minMaxLoc(g, &lo, &hi, nullptr, nullptr, area->valid_mask());
  EXPECT_NEAR(lo, 100 / 255.0, 1e-4);
  EXPECT_NEAR(hi, 100 / 255.0, 1e-4);
}

// Where a top-view pixel is smaller than an image pixel (far rows), area
// sampling is bilinear interpolation.
TEST(IpmTest, AreaSamplingIsBilinearWhereTheViewIsFinerThanTheImage) {
  CameraModel cam;  // Caltech, 640x480
  cv::Mat ramp(cam.image_height, cam.image_width, CV_8UC1);
  for (int x = 0; x < ramp.cols; ++x) ramp.col(x).setTo(x * 255 / (ramp.cols - 1));
  IpmOptions o;
  o.view = IpmView::kGround;
  o.ground = {-3, 3, 20, 30, 0.2, 0.5};  // far: ~3 image px per top-view px across
  o.interpolation = Interpolation::kArea;
  const auto area = IpmMapping::Create(cam, o);
  o.interpolation = Interpolation::kBilinear;
  const auto bilinear = IpmMapping::Create(cam, o);
  ASSERT_TRUE(area.ok() && bilinear.ok());
  // On a linear ramp every symmetric average equals the centre value.
  const cv::Mat a = area->Apply(ramp), b = bilinear->Apply(ramp);
  for (int r = 0; r < a.rows; r += 5) {
    for (int c = 0; c < a.cols; c += 3) {
      ASSERT_NEAR(a.at<float>(r, c), b.at<float>(r, c), 2e-3) << r << "," << c;
    }
  }
}

// Area sampling reads a BGR frame's channel (or the minimum of two) straight
// from its pixels: the same top view as from the channel extracted first,
// including the row ends that the 16-pixel vector steps leave to the scalar
// tail (640 = 40 x 16, so the band's width of 639 columns has a tail).
TEST(IpmTest, AreaSamplingReadsTheChannelOfABgrFrame) {
  CameraModel cam;  // Caltech, 640x480
  cv::Mat bgr(cam.image_height, cam.image_width, CV_8UC3);
  cv::RNG rng(7);
  rng.fill(bgr, cv::RNG::UNIFORM, 0, 256);
  IpmOptions o;
  o.view = IpmView::kGround;
  o.ground = {-4, 4, 5, 25, 0.1, 0.25};
  o.interpolation = Interpolation::kArea;
  const auto area = IpmMapping::Create(cam, o);
  ASSERT_TRUE(area.ok());
  cv::Mat red, green, min_rg;
  cv::extractChannel(bgr, red, 2);
  cv::extractChannel(bgr, green, 1);
  cv::min(red, green, min_rg);
  const cv::Mat from_bgr = area->Apply(bgr, 2), from_red = area->Apply(red);
  const cv::Mat from_bgr_min = area->Apply(bgr, 2, 1), from_min = area->Apply(min_rg);
  EXPECT_EQ(cv::norm(from_bgr, from_red, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(from_bgr_min, from_min, cv::NORM_INF), 0.0);
  // And the channel matters (the test would pass on any one channel otherwise).
  EXPECT_GT(cv::norm(area->Apply(bgr, 1), from_red, cv::NORM_INF), 0.01);
}

}  // namespace
}  // namespace lane
