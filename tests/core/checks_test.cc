// The candidate checks and the geometric image steps added for issue 13, on
// hand-made inputs with a known answer.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "lane/postprocess/image_extension.h"
#include "lane/postprocess/marking_check.h"
#include "lane/postprocess/postprocess.h"
#include "lane/postprocess/vehicle_check.h"
#include "lane/stages/threshold.h"

namespace lane {
namespace {

std::vector<Eigen::Vector2d> Line(double x0, double y0, double x1, double y1, int n = 11) {
  std::vector<Eigen::Vector2d> out;
  for (int i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / (n - 1);
    out.emplace_back(x0 + t * (x1 - x0), y0 + t * (y1 - y0));
  }
  return out;
}

TEST(RayTestTest, MarkingAlongTheRoadIsNotARay) {
  const RayTest t = TestRay(Line(2.0, 8, 2.0, 18));
  ASSERT_TRUE(t.valid);
  EXPECT_NEAR(t.line_deg, 0, 1e-9);
  EXPECT_NEAR(t.ray_deg, std::atan(2.0 / 13) * 180 / M_PI, 1e-9);
  EXPECT_FALSE(t.RayLike(6));
}

TEST(RayTestTest, StreakAlongARayThroughTheFootPointIs) {
  // x / y = 0.25 everywhere: the ray through (2, 8).
  const RayTest t = TestRay(Line(2.0, 8, 4.5, 18));
  ASSERT_TRUE(t.valid);
  EXPECT_NEAR(t.line_deg, t.ray_deg, 1e-9);
  EXPECT_TRUE(t.RayLike(6));
  // Near the camera's axis the two directions are too close to tell.
  EXPECT_FALSE(TestRay(Line(0.3, 8, 0.675, 18)).RayLike(6));
  // Measured against the frame's road direction: when the whole road turns
  // by the ray's angle, the streak is parallel to it.
  EXPECT_FALSE(t.RayLike(6, t.ray_deg));
}

TEST(RayTestTest, CurvedCandidatesAreMarkings) {
  std::vector<Eigen::Vector2d> pts = Line(2.0, 8, 4.5, 18);
  for (size_t i = 0; i < pts.size(); ++i) {
    const double t = static_cast<double>(i) / (pts.size() - 1);
    pts[i].x() += 1.2 * t * (1 - t);  // bows 0.3 m out
  }
  const RayTest r = TestRay(pts);
  EXPECT_GT(r.bend_m, 0.15);
  EXPECT_FALSE(r.RayLike(6));
}

TEST(TransverseRowsTest, RowsFilledAcrossAreZeroed) {
  cv::Mat kept = cv::Mat::zeros(40, 100, CV_32F);
  const cv::Mat valid(40, 100, CV_8U, cv::Scalar(255));
  kept.col(20).setTo(1.f);  // two markings along the road
  kept.col(70).setTo(1.f);
  kept.row(10).colRange(5, 95).setTo(1.f);  // a stop line across
  EXPECT_EQ(SuppressTransverseRows(kept, valid, 0.1, 2), 1);
  for (int r = 8; r <= 12; ++r) EXPECT_EQ(cv::countNonZero(kept.row(r)), 0) << r;
  EXPECT_EQ(cv::countNonZero(kept.row(13)), 2);
  EXPECT_EQ(cv::countNonZero(kept.col(20)), 35);
  // The fraction is of the valid width: a row of a narrow band.
  cv::Mat band = cv::Mat::zeros(40, 100, CV_8U);
  band.colRange(15, 25).setTo(255);
  cv::Mat one = cv::Mat::zeros(40, 100, CV_32F);
  one.col(20).setTo(1.f);
  EXPECT_EQ(SuppressTransverseRows(one, band, 0.15, 0), 0);
  EXPECT_EQ(SuppressTransverseRows(one, band, 0.05, 0), 40);
}

// A synthetic 640x480 frame of the Caltech camera: grey road, one white
// marking at x = 1.8 m and a red one at x = -1.8 m, from 4 to 30 m.
cv::Mat RoadFrame(const CameraModel& cam, double gap_from_m = 1e9, double gap_to_m = 1e9) {
  cv::Mat frame(cam.image_height, cam.image_width, CV_8UC3, cv::Scalar(90, 90, 90));
  for (double y = 4; y < 30; y += 0.05) {
    if (y > gap_from_m && y < gap_to_m) continue;
    for (const auto& [x, colour] :
         {std::pair<double, cv::Scalar>{1.8, {230, 230, 230}}, {-1.8, {40, 40, 220}}}) {
      const Eigen::Vector2d a = cam.GroundToImage({x - 0.06, y});
      const Eigen::Vector2d b = cam.GroundToImage({x + 0.06, y});
      cv::line(frame, cv::Point2d(a.x(), a.y()), cv::Point2d(b.x(), b.y()), colour, 2);
    }
  }
  return frame;
}

Bezier ImageSpline(const CameraModel& cam, double x, double y_far, double y_near) {
  return Bezier::Line(cam.GroundToImage({x, y_far}), cam.GroundToImage({x, y_near}));
}

TEST(ImageExtensionTest, FollowsTheMarkingThroughAGapAndStopsAtTheEnd) {
  const CameraModel cam;
  const cv::Mat frame = RoadFrame(cam, 9.0, 13.0);  // a 4 m gap
  const ChannelView red(frame, 2);
  ImageExtendOptions o;
  o.min_row = 0;
  o.max_row = 479;
  o.marking_width_m = 0.12;
  const Bezier start = ImageSpline(cam, 1.8, 18, 15);  // beyond the gap
  const Bezier out = ExtendInImage(start, red, cam, o);
  const Eigen::Vector2d near = cam.ImageToGround(out.p[3]);
  EXPECT_LT(near.y(), 5.0) << "the walk should cross the gap down to the marking's near end";
  EXPECT_NEAR(near.x(), 1.8, 0.1);
  // With a gap allowance shorter than the gap it stops before it.
  o.max_gap_m = 2;
  const Eigen::Vector2d stopped = cam.ImageToGround(ExtendInImage(start, red, cam, o).p[3]);
  EXPECT_GT(stopped.y(), 12.0);
}

// Without walks (max_steps 0: post-processing's last fallback, when the
// walks strayed), extend_to_max_row carries the spline straight on down to
// the bottom row along its own ground line, and nothing is added upwards.
TEST(ImageExtensionTest, CarriesTheLineStraightDownWithoutWalking) {
  const CameraModel cam;
  const cv::Mat frame = RoadFrame(cam);
  const ChannelView red(frame, 2);
  ImageExtendOptions o;
  o.min_row = 0;
  o.max_row = 470;
  o.marking_width_m = 0.12;
  o.max_steps = 0;
  o.extrapolate_down = true;
  const Bezier start = ImageSpline(cam, 1.8, 18, 12);
  const Bezier out = ExtendInImage(start, red, cam, o);
  EXPECT_NEAR(std::max(out.p[0].y(), out.p[3].y()), 470.0, 1.0);
  EXPECT_NEAR(std::min(out.p[0].y(), out.p[3].y()), std::min(start.p[0].y(), start.p[3].y()), 1.0);
  for (double t : {0.0, 0.5, 1.0}) {
    EXPECT_NEAR(cam.ImageToGround(out.Eval(t)).x(), 1.8, 0.05) << t;
  }
  // Without extend_to_max_row nothing changes.
  o.extrapolate_down = false;
  const Bezier same = ExtendInImage(start, red, cam, o);
  EXPECT_NEAR((same.p[3] - start.p[3]).norm() + (same.p[0] - start.p[0]).norm(), 0.0, 1e-6);
}

// No bar under the spline (it runs along a step: a shadow's border, dark
// to its right): there is nothing to follow, but extend_to_max_row, a
// labelling convention, needs no evidence and still carries it down to the
// bottom row (it returned the spline unextended).
TEST(ImageExtensionTest, WithoutABarUnderItOnlyTheConventionExtends) {
  const CameraModel cam;
  cv::Mat frame(cam.image_height, cam.image_width, CV_8UC3, cv::Scalar(90, 90, 90));
  std::vector<cv::Point> dark;
  for (const auto& [x, y] : {std::pair{1.8, 3.0}, {9.0, 3.0}, {9.0, 40.0}, {1.8, 40.0}}) {
    const Eigen::Vector2d p = cam.GroundToImage({x, y});
    dark.emplace_back(static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y())));
  }
  cv::fillConvexPoly(frame, dark, cv::Scalar(40, 40, 40), cv::LINE_AA);
  const ChannelView red(frame, 2);
  ImageExtendOptions o;
  o.min_row = 0;
  o.max_row = 470;
  o.marking_width_m = 0.12;
  o.extrapolate_down = true;
  const Bezier start = ImageSpline(cam, 1.8, 18, 12);
  ASSERT_EQ(ImageBarContrast(start, red, cam, o), 0.0);
  const Bezier out = ExtendInImage(start, red, cam, o);
  EXPECT_NEAR(out.p[3].y(), 470.0, 1.0);
  EXPECT_NEAR(out.p[0].y(), start.p[0].y(), 1.0) << "nothing to follow upwards";
  EXPECT_NEAR(cam.ImageToGround(out.p[3]).x(), 1.8, 0.05);
}

// A double line (two 0.1 m lines 0.12 m apart, centred at x = 1.8 m, from
// 3 to 30 m): far away its lines blur into one, near the camera they
// resolve. Walking down from the far part, profiles smoothed as
// localisation's (down_sigma_m 0.1) keep the walk on the pair's centre,
// where such a boundary is labelled, down to the near end; with the narrow
// smoothing alone the walk moves onto one of the lines, half the pair's
// width aside (on cordova1's double yellow line the step aside was too
// sharp for the direction checks, and the walk stopped there).
TEST(ImageExtensionTest, WalksDownADoubleLineOnItsCentre) {
  const CameraModel cam;
  cv::Mat frame(cam.image_height, cam.image_width, CV_8UC3, cv::Scalar(90, 90, 90));
  for (double y = 3; y < 30; y += 0.05) {
    for (const double x : {1.69, 1.91}) {
      const Eigen::Vector2d a = cam.GroundToImage({x - 0.05, y});
      const Eigen::Vector2d b = cam.GroundToImage({x + 0.05, y});
      cv::line(frame, cv::Point2d(a.x(), a.y()), cv::Point2d(b.x(), b.y()),
               cv::Scalar(230, 230, 230), 2);
    }
  }
  const ChannelView red(frame, 2);
  ImageExtendOptions o;
  o.min_row = 0;
  o.max_row = 479;
  o.marking_width_m = 0.1;
  const Bezier start = ImageSpline(cam, 1.8, 20, 14);
  o.down_sigma_m = 0.1;
  const Bezier merged = ExtendInImage(start, red, cam, o);
  const Eigen::Vector2d near = cam.ImageToGround(merged.p[3]);
  EXPECT_LT(near.y(), 4.0) << "the walk should reach the pair's near end";
  EXPECT_NEAR(near.x(), 1.8, 0.06);
  o.down_sigma_m = 0;
  const Eigen::Vector2d narrow = cam.ImageToGround(ExtendInImage(start, red, cam, o).p[3]);
  EXPECT_GT(std::abs(narrow.x() - 1.8), 0.08) << "narrow smoothing: y " << narrow.y();
}

TEST(ImageExtensionTest, LocalisationMovesASplineOntoTheMarking) {
  const CameraModel cam;
  const cv::Mat frame = RoadFrame(cam);
  const ChannelView red(frame, 2);
  const Bezier off = ImageSpline(cam, 1.6, 14, 8);  // 0.2 m beside the marking
  LocalizeOptions lo;
  lo.min_sigma_px = 1.0;
  const auto loc = LocalizeInImage(off, red, cam, lo);
  ASSERT_TRUE(loc.has_value());
  for (double t : {0.1, 0.5, 0.9}) {
    EXPECT_NEAR(cam.ImageToGround(loc->Eval(t)).x(), 1.8, 0.05) << t;
  }
}

TEST(ImageExtensionTest, ClipsToTheImageAndItsContent) {
  cv::Mat frame(480, 640, CV_8UC1, cv::Scalar(100));
  frame.colRange(0, 100).setTo(0);  // black, as outside a lens circle
  const Bezier s = Bezier::Line({50, 300}, {400, 300});
  const auto clipped = ClipToImageContent(s, ChannelView(frame));
  ASSERT_TRUE(clipped.has_value());
  EXPECT_GT(std::min(clipped->p[0].x(), clipped->p[3].x()), 90);
  EXPECT_NEAR(std::max(clipped->p[0].x(), clipped->p[3].x()), 400, 1e-6);
  EXPECT_FALSE(ClipToImageContent(Bezier::Line({5, 300}, {60, 300}), ChannelView(frame)));
}

TEST(MarkingCheckTest, RednessTellsRedFromWhite) {
  const CameraModel cam;
  const cv::Mat frame = RoadFrame(cam);
  const ChannelView red(frame, 2);
  EXPECT_LT(MedianRedness(ImageSpline(cam, 1.8, 6, 14), frame, red, 3), 0.1);
  EXPECT_GT(MedianRedness(ImageSpline(cam, -1.8, 6, 14), frame, red, 3), 0.6);
  cv::Mat grey;
  cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
  EXPECT_TRUE(std::isnan(MedianRedness(ImageSpline(cam, 1.8, 6, 14), grey, ChannelView(grey), 3)));
}

TEST(MarkingCheckTest, GroundAngleOfTheRoadsDirection) {
  const CameraModel cam;
  EXPECT_NEAR(GroundAngleFromRoadDeg(ImageSpline(cam, 1.8, 6, 14), cam), 0, 1e-6);
  const Bezier slanted =
      Bezier::Line(cam.GroundToImage({1.0, 14}), cam.GroundToImage({1.0 + 8 * std::tan(0.5), 6}));
  EXPECT_NEAR(GroundAngleFromRoadDeg(slanted, cam), 0.5 * 180 / M_PI, 1e-6);
}

// Post-processing on a fine top view (CULane's 0.0625 m/px, where the image
// localisation is skipped): a candidate along a marking is kept and
// extended; one along a step (a vehicle's lower edge or its shadow's
// border: bright on one side, dark on the other) has no bar under it in
// the image, nor near it, and is dropped (driver161-a's raw top-view
// splines; docs/accuracy-log.md, entry 61). The top view's own marking and
// ray checks are off here, so that the image's check is the one tested.
TEST(PostprocessTest, DropsACandidateWithNoBarInTheImage) {
  CameraModel cam;
  cam.fu = cam.fv = 1000;
  cam.cu = 820;
  cam.cv = 295;
  cam.pitch_deg = -4.858;
  cam.yaw_deg = 0;
  cam.height_m = 1.3;
  cam.image_width = 1640;
  cam.image_height = 590;
  IpmOptions io;
  io.view = IpmView::kGround;
  auto ipm = IpmMapping::Create(cam, io);
  ASSERT_TRUE(ipm.ok()) << ipm.status();
  cv::Mat frame(cam.image_height, cam.image_width, CV_8UC3, cv::Scalar(90, 90, 90));
  const auto quad = [&](double x0, double x1, const cv::Scalar& colour) {
    std::vector<cv::Point> pts;
    for (const auto& [x, y] : {std::pair{x0, 5.0}, {x1, 5.0}, {x1, 80.0}, {x0, 80.0}}) {
      const Eigen::Vector2d p = cam.GroundToImage({x, y});
      pts.emplace_back(static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y())));
    }
    cv::fillConvexPoly(frame, pts, colour, cv::LINE_AA);
  };
  quad(-1.875, -1.725, cv::Scalar(220, 220, 220));  // a 15 cm marking at x = -1.8 m
  quad(2.0, 9.0, cv::Scalar(35, 35, 35));           // a step at x = 2 m
  const ChannelView red(frame, 2);
  const cv::Mat zeros = cv::Mat::zeros(ipm->height(), ipm->width(), CV_32F);
  const PostprocessFrame images{*ipm, zeros, zeros, red, frame};
  std::vector<SplineCandidate> candidates;
  for (const double x : {-1.8, 2.0}) {
    SplineCandidate c;
    c.line.top = ipm->GroundToIpm({x, 17.9});
    c.line.bottom = ipm->GroundToIpm({x, 8.1});
    c.ipm = Bezier::Line(c.line.top, c.line.bottom);
    candidates.push_back(c);
  }
  PostprocessOptions pp;
  pp.min_side_contrast = 0;
  pp.min_ray_angle_deg = 0;
  const std::vector<SplineCandidate> kept = PostprocessCandidates(candidates, images, pp, 0.15, 2);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_NEAR(cam.ImageToGround(kept[0].image.Eval(0.5)).x(), -1.8, 0.05);
  EXPECT_LT(kept[0].image.p[0].y(), ipm->roi().top - 5) << "the marking is extended upwards";
}

}  // namespace
}  // namespace lane
