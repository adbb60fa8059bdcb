// The self-check a camera estimate passes before it is written or adopted
// (lane/calibrate/self_check.h, CalibrationSelfCheck, OnlineCalibrator):
// exact chords first, then the detector on rendered frames with the true
// camera and with wrong ones, then an auto-calibrating session's refusal.
#include "lane/calibrate/self_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "lane/calibrate/calibration.h"
#include "lane/synthetic.h"
#include "test_cameras.h"

namespace lane {
namespace {

using testing::TestCamera;

// Lanes at lateral offsets `xs` (metres), turned by `heading_deg` and
// fanned out by `fan_deg_per_m` of lateral offset, from 8 to 18 m ahead.
std::vector<GroundChord> Chords(const std::vector<double>& xs, double heading_deg,
                                double fan_deg_per_m) {
  std::vector<GroundChord> out;
  for (double x : xs) {
    const double a = (heading_deg + fan_deg_per_m * x) * M_PI / 180.0;
    GroundChord c;
    c.near = {x, 8.0};
    c.far = {x + 10.0 * std::tan(a), 18.0};
    out.push_back(c);
  }
  return out;
}

TEST(SelfCheckTest, ParallelLanesALaneWidthApartPass) {
  LaneGeometryCheck check;
  for (int i = 0; i < 10; ++i) check.AddFrame(Chords({-5.3, -1.8, 1.7}, 0.2 * (i % 3 - 1), 0.0));
  const LaneGeometryReport r = check.Report();
  EXPECT_TRUE(r.verdict.ok()) << r.verdict;
  EXPECT_EQ(r.frames_with_pair, 10);
  EXPECT_NEAR(r.width_m, 3.5, 0.01);
  EXPECT_NEAR(r.heading_deg, 0.0, 0.01);
}

TEST(SelfCheckTest, TurnedFannedOrMissingLanesAreRefusedWithTheReason) {
  {
    LaneGeometryCheck turned;
    for (int i = 0; i < 10; ++i) turned.AddFrame(Chords({-1.8, 1.7}, 2.0, 0.0));
    const LaneGeometryReport r = turned.Report();
    EXPECT_FALSE(r.verdict.ok());
    EXPECT_NE(std::string(r.verdict.message()).find("yaw"), std::string::npos) << r.verdict;
    EXPECT_NEAR(r.heading_deg, 2.0, 0.01);
  }
  {
    LaneGeometryCheck fanned;  // 0.5 deg per metre: 1.75 deg between neighbours
    for (int i = 0; i < 10; ++i) fanned.AddFrame(Chords({-1.8, 1.7}, 0.0, 0.5));
    const LaneGeometryReport r = fanned.Report();
    EXPECT_FALSE(r.verdict.ok());
    EXPECT_NE(std::string(r.verdict.message()).find("pitch"), std::string::npos) << r.verdict;
    EXPECT_NEAR(r.divergence_deg, 1.75, 0.01);
  }
  {
    LaneGeometryCheck sparse;  // lanes 7 m apart, or one lane: no lane pair
    for (int i = 0; i < 5; ++i) sparse.AddFrame(Chords({-3.5, 3.5}, 0.0, 0.0));
    for (int i = 0; i < 5; ++i) sparse.AddFrame(Chords({1.7}, 0.0, 0.0));
    const LaneGeometryReport r = sparse.Report();
    EXPECT_FALSE(r.verdict.ok());
    EXPECT_EQ(r.frames_with_pair, 0);
    EXPECT_NE(std::string(r.verdict.message()).find("probably wrong"), std::string::npos);
  }
}

// The detector with the true camera passes on rendered straight roads; the
// same frames with the vanishing point moved refuse, naming the error.
TEST(SelfCheckTest, DetectorWithAWrongCameraIsRefused) {
  const CameraModel truth = TestCamera(6.0, 1.5, 1.6);
  SyntheticOptions so;
  so.straight_probability = 1.0;
  so.max_heading_rad = 0.005;
  so.lane_width_m = 3.6;
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 16; ++i) {
    absl::StatusOr<SyntheticFrame> f = RenderSyntheticFrame(truth, so, 700 + i);
    ASSERT_TRUE(f.ok()) << f.status();
    frames.push_back(f->bgr);
  }
  // The self-check's report, or the reason no detector could be built.
  auto check = [&](const Eigen::Vector2d& shift) -> absl::StatusOr<LaneGeometryReport> {
    CalibrationResult r;
    r.camera = CameraFromVanishingPoint(truth, truth.VanishingPoint() + shift);
    absl::StatusOr<GroundView> view = ChooseGroundView(r.camera, 3.6, RoadOutline{});
    if (!view.ok()) return view.status();
    r.view = *view;
    absl::StatusOr<CalibrationSelfCheck> c = CalibrationSelfCheck::Create(r, 3.6);
    if (!c.ok()) return c.status();
    for (const cv::Mat& f : frames) {
      if (absl::Status s = c->AddFrame(f); !s.ok()) return s;
    }
    return c->Report();
  };
  const absl::StatusOr<LaneGeometryReport> good = check({0, 0});
  ASSERT_TRUE(good.ok()) << good.status();
  EXPECT_TRUE(good->verdict.ok()) << good->verdict;
  EXPECT_GE(good->frames_with_pair, 12);
  EXPECT_NEAR(good->width_m, 3.6, 0.3);
  // 15 px across is 2.2 deg of yaw at this focal length; 12 px down is 1.8
  // deg of pitch; (250, -120) puts the top view across the verge (a ground
  // view that the camera cannot see whole is refused before any frame).
  const absl::StatusOr<LaneGeometryReport> yaw = check({15, 0});
  ASSERT_TRUE(yaw.ok()) << yaw.status();
  EXPECT_FALSE(yaw->verdict.ok());
  EXPECT_NE(std::string(yaw->verdict.message()).find("yaw"), std::string::npos) << yaw->verdict;
  const absl::StatusOr<LaneGeometryReport> pitch = check({0, 12});
  ASSERT_TRUE(pitch.ok()) << pitch.status();
  EXPECT_FALSE(pitch->verdict.ok()) << "divergence " << pitch->divergence_deg;
  const absl::StatusOr<LaneGeometryReport> gross = check({250, -120});
  EXPECT_FALSE(gross.ok() && gross->verdict.ok());
}

// A session's candidate camera is adopted only when its recent lanes, seen
// through it, are a lane width apart: the same straight image lanes 3.6 m
// apart are adopted, 8 m apart refused (and the detector keeps its camera).
TEST(SelfCheckTest, OnlineCalibratorRefusesACandidateThatFailsTheCheck) {
  const CameraModel truth = TestCamera(8.0, 0.0, 1.5);
  CameraModel start = truth;
  start.pitch_deg += 1.0;
  auto lanes = [&](double half_width) {
    std::vector<Lane> out;
    for (double x : {-half_width, half_width}) {
      Lane l;
      for (int k = 0; k < 4; ++k) l.image[k] = truth.GroundToImage({x, 4.0 + 4.0 * k});
      out.push_back(l);
    }
    return out;
  };
  OnlineCalibrator adopts(start);
  int adopted = 0;
  for (int i = 0; i < 200; ++i) adopted += adopts.Observe(lanes(1.8)) ? 1 : 0;
  EXPECT_GE(adopted, 3);
  EXPECT_EQ(adopts.refused(), 0);
  EXPECT_NEAR(adopts.camera().pitch_deg, truth.pitch_deg, 0.1);

  OnlineCalibrator refuses(start);
  int adopted_wide = 0;
  for (int i = 0; i < 200; ++i) adopted_wide += refuses.Observe(lanes(4.0)) ? 1 : 0;
  EXPECT_EQ(adopted_wide, 0);
  EXPECT_GT(refuses.refused(), 0);
  EXPECT_FALSE(refuses.last_refusal().ok());
}

}  // namespace
}  // namespace lane
