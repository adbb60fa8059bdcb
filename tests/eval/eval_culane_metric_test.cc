// The CULane metric: mask IoU against hand-computed values, lane drawing at
// 1640x590 and scaled sizes, one-to-one matching.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "lane/eval/culane_metric.h"

namespace lane::eval {
namespace {

cv::Mat Rect(cv::Size canvas, cv::Rect r) {
  cv::Mat m = cv::Mat::zeros(canvas, CV_8U);
  m(r).setTo(255);
  return m;
}

// A vertical lane at column x over the whole frame height (its round ends
// fall outside the frame, so every row holds the same run of pixels).
Curve Vertical(double x, int height) { return Curve::Polyline({{x, height + 40.0}, {x, -40.0}}); }

// Width in pixels of the run drawn in row `row`.
int RunWidth(const cv::Mat& mask, int row) { return cv::countNonZero(mask.row(row)); }

TEST(CulaneMetricTest, MaskIoUOfRectangles) {
  const cv::Size canvas(40, 30);
  // 10x10 squares overlapping by 5 columns: 50 / 150.
  EXPECT_DOUBLE_EQ(MaskIoU(Rect(canvas, {0, 0, 10, 10}), Rect(canvas, {5, 0, 10, 10})), 1.0 / 3);
  // Nested: 4x4 inside 8x8: 16 / 64.
  EXPECT_DOUBLE_EQ(MaskIoU(Rect(canvas, {0, 0, 8, 8}), Rect(canvas, {2, 2, 4, 4})), 0.25);
  // Disjoint, identical, empty.
  EXPECT_DOUBLE_EQ(MaskIoU(Rect(canvas, {0, 0, 5, 5}), Rect(canvas, {20, 20, 5, 5})), 0.0);
  EXPECT_DOUBLE_EQ(MaskIoU(Rect(canvas, {3, 3, 7, 9}), Rect(canvas, {3, 3, 7, 9})), 1.0);
  const cv::Mat empty = cv::Mat::zeros(canvas, CV_8U);
  EXPECT_DOUBLE_EQ(MaskIoU(empty, empty), 0.0);
}

TEST(CulaneMetricTest, LanesAreThirtyPixelsWideAt1640) {
  const cv::Mat mask = DrawLaneMask(Vertical(800, 590), 1640, 590);
  ASSERT_EQ(mask.size(), cv::Size(1640, 590));
  const int w = RunWidth(mask, 300);
  EXPECT_GE(w, 30);
  EXPECT_LE(w, 31);
  for (int row : {0, 100, 589}) EXPECT_EQ(RunWidth(mask, row), w) << "row " << row;
  EXPECT_EQ(cv::countNonZero(mask), 590 * w);
}

TEST(CulaneMetricTest, ParallelLanesIoUIsHandComputed) {
  // Two bands of width w shifted by d overlap in w - d columns out of w + d:
  // IoU = (w - d) / (w + d), e.g. 20/40 = 0.5 for d = 10 and w = 30.
  const cv::Mat a = DrawLaneMask(Vertical(800, 590), 1640, 590);
  const double w = RunWidth(a, 300);
  for (int d : {0, 5, 10, 20, 29, 40}) {
    const cv::Mat b = DrawLaneMask(Vertical(800 + d, 590), 1640, 590);
    const double expected = d < w ? (w - d) / (w + d) : 0.0;
    EXPECT_NEAR(MaskIoU(a, b), expected, 1e-12) << "shift " << d;
    const auto iou = LaneIoUs({Vertical(800 + d, 590)}, {Vertical(800, 590)}, 1640, 590);
    EXPECT_NEAR(iou[0][0], expected, 1e-12) << "shift " << d;
  }
}

TEST(CulaneMetricTest, OtherSizesAreScaledToTheReferenceWidth) {
  // 820x295 is drawn on a 1640x590 canvas: a 5 px shift there is a 10 px
  // shift at 1640.
  EXPECT_EQ(CulaneCanvasSize(820, 295), cv::Size(1640, 590));
  EXPECT_EQ(CulaneCanvasSize(640, 480), cv::Size(1640, 1230));
  const auto full = LaneIoUs({Vertical(810, 590)}, {Vertical(800, 590)}, 1640, 590);
  const auto half = LaneIoUs({Vertical(405, 295)}, {Vertical(400, 295)}, 820, 295);
  EXPECT_NEAR(half[0][0], full[0][0], 1e-12);
  EXPECT_NEAR(half[0][0], 0.5, 0.03);
}

TEST(CulaneMetricTest, MatchingIsOneToOneAtIoUHalf) {
  const Curve label0 = Vertical(400, 590), label1 = Vertical(900, 590);
  // Two detections on label0 (one exact, one 5 px off), one 20 px off label1
  // (IoU 10/50 = 0.2), one nowhere.
  const std::vector<Curve> detections = {Vertical(405, 590), Vertical(400, 590), Vertical(920, 590),
                                         Vertical(1300, 590)};
  const Matching m = MatchCulane(detections, {label0, label1}, 1640, 590);
  EXPECT_EQ(m.detection_label, (std::vector<int>{-1, 0, -1, -1}));
  EXPECT_EQ(m.label_detection, (std::vector<int>{1, -1}));
  EXPECT_EQ(m.MatchedDetections(), 1);
  EXPECT_EQ(m.FalsePositives(), 3);
  EXPECT_EQ(m.Misses(), 1);
}

TEST(CulaneMetricTest, ShortDetectionOfALongLabel) {
  // A detection covering the lower half of a label: IoU about 1/2, so
  // covering a bit more than half is needed to match.
  const Curve label = Curve::Polyline({{800, 590}, {800, 390}});
  const auto half = LaneIoUs({Curve::Polyline({{800, 590}, {800, 490}})}, {label}, 1640, 590);
  EXPECT_NEAR(half[0][0], 0.5, 0.05);
  const Matching longer =
      MatchCulane({Curve::Polyline({{800, 590}, {800, 450}})}, {label}, 1640, 590);
  EXPECT_EQ(longer.MatchedDetections(), 1);
  const Matching shorter =
      MatchCulane({Curve::Polyline({{800, 590}, {800, 520}})}, {label}, 1640, 590);
  EXPECT_EQ(shorter.MatchedDetections(), 0);
}

TEST(CulaneMetricTest, BezierDetectionOfAPolylineLabel) {
  const Curve label = Curve::Polyline({{500, 590}, {600, 490}, {700, 390}});
  const Curve detection = Curve::FromBezier(
      std::array<Eigen::Vector2d, 4>{Eigen::Vector2d(500, 590), Eigen::Vector2d(566.7, 523.3),
                                     Eigen::Vector2d(633.3, 456.7), Eigen::Vector2d(700, 390)});
  EXPECT_GT(LaneIoUs({detection}, {label}, 1640, 590)[0][0], 0.95);
}

TEST(CulaneMetricTest, OptionsValidate) {
  EXPECT_TRUE(CulaneOptions().Validate().ok());
  CulaneOptions bad;
  bad.iou_threshold = 0;
  EXPECT_FALSE(bad.Validate().ok());
}

}  // namespace
}  // namespace lane::eval
