#include "lane/geometry/camera.h"

#include <gtest/gtest.h>

#include <cmath>

#include "test_cameras.h"

namespace lane {
namespace {

using ::lane::testing::CulaneCamera;

TEST(CameraTest, RoundTripImageGroundImage) {
  for (const CameraModel& cam : {CameraModel{}, CulaneCamera()}) {
    const double horizon = cam.HorizonRow();
    for (double v = std::ceil(horizon + 5); v < cam.image_height; v += 17) {
      for (double u = 0; u < cam.image_width; u += 23) {
        const Eigen::Vector2d img(u, v);
        const Eigen::Vector2d back = cam.GroundToImage(cam.ImageToGround(img));
        ASSERT_NEAR(back.x(), u, 1e-6 * std::max(1.0, std::abs(u))) << "at " << u << "," << v;
        ASSERT_NEAR(back.y(), v, 1e-6 * std::max(1.0, std::abs(v))) << "at " << u << "," << v;
      }
    }
  }
}

TEST(CameraTest, RoundTripGroundImageGround) {
  const CameraModel cam = CulaneCamera();
  for (double y = 3; y < 100; y += 7) {
    for (double x = -10; x <= 10; x += 1.5) {
      const Eigen::Vector2d g(x, y);
      const Eigen::Vector2d back = cam.ImageToGround(cam.GroundToImage(g));
      ASSERT_NEAR(back.x(), x, 1e-6 * std::max(1.0, std::abs(x)));
      ASSERT_NEAR(back.y(), y, 1e-6 * y);
    }
  }
}

TEST(CameraTest, FarPointsConvergeOnTheVanishingPoint) {
  const CameraModel cam = CulaneCamera();
  const Eigen::Vector2d far = cam.GroundToImage({0.0, 1e7});
  const Eigen::Vector2d vp = cam.VanishingPoint();
  EXPECT_NEAR(far.x(), vp.x(), 1e-2);
  EXPECT_NEAR(far.y(), vp.y(), 1e-2);
  // The data README's estimate: the lanes of culane-driver161-a meet at
  // (755, 380).
  EXPECT_NEAR(vp.x(), 755, 1.0);
  EXPECT_NEAR(vp.y(), 380, 1.5);
}

TEST(CameraTest, GroundAxesPointRightAndAhead) {
  const CameraModel cam;
  const Eigen::Vector2d centre = cam.GroundToImage({0, 10});
  EXPECT_GT(cam.GroundToImage({1, 10}).x(), centre.x());  // right is right
  EXPECT_GT(cam.GroundToImage({0, 5}).y(), centre.y());   // nearer is lower
  EXPECT_GT(centre.y(), cam.HorizonRow());
}

TEST(CameraTest, RejectsNonsense) {
  auto bad = [](auto mutate) {
    CameraModel c;
    mutate(c);
    return c.Validate();
  };
  EXPECT_TRUE(CameraModel{}.Validate().ok());
  EXPECT_FALSE(bad([](CameraModel& c) { c.fu = 0; }).ok());
  EXPECT_FALSE(bad([](CameraModel& c) { c.fv = -3; }).ok());
  EXPECT_FALSE(bad([](CameraModel& c) { c.pitch_deg = 90; }).ok());
  EXPECT_FALSE(bad([](CameraModel& c) { c.pitch_deg = -95; }).ok());
  EXPECT_FALSE(bad([](CameraModel& c) { c.height_m = 0; }).ok());
  EXPECT_FALSE(bad([](CameraModel& c) { c.cu = std::nan(""); }).ok());
  EXPECT_FALSE(bad([](CameraModel& c) { c.yaw_deg = INFINITY; }).ok());
  EXPECT_FALSE(bad([](CameraModel& c) { c.image_width = 0; }).ok());
  const absl::Status s = bad([](CameraModel& c) { c.pitch_deg = 90; });
  EXPECT_NE(s.message().find("pitch"), std::string::npos) << s;
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace lane
