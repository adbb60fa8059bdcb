// The 2-lanes definition: the nearest labelled boundary on each side of the
// image centre at the bottom of the ROI, and 2-lanes scoring.
#include <gtest/gtest.h>

#include "lane/eval/ego.h"
#include "lane/eval/evaluate.h"

namespace lane::eval {
namespace {

// A straight boundary through (x_bottom, 480) and the vanishing point
// (320, 200) of a 640x480 frame, labelled from row 470 up to row 250.
Curve StraightBoundary(double x_bottom) {
  const auto at = [&](double y) {
    return Eigen::Vector2d(320 + (x_bottom - 320) * (y - 200) / 280, y);
  };
  return Curve::Polyline({at(470), at(250)});
}

TEST(EgoTest, NearestBoundaryOnEachSideOfTheCentre) {
  // Left to right: -330, 10, 290, 610, 900 at the bottom row; unordered.
  const std::vector<Curve> labels = {StraightBoundary(610), StraightBoundary(10),
                                     StraightBoundary(900), StraightBoundary(290),
                                     StraightBoundary(-330)};
  const EgoBoundaries ego = SelectEgoBoundaries(labels, 320, 350);
  EXPECT_EQ(ego.left, 3);   // 290 at the bottom
  EXPECT_EQ(ego.right, 0);  // 610
}

TEST(EgoTest, ChosenAtTheGivenRow) {
  // Two boundaries that cross between rows 300 and 460: at 460 the one
  // ending at x=300 is left of the centre; at 300 it is right of it.
  const std::vector<Curve> labels = {Curve::Polyline({{300, 460}, {400, 300}}),
                                     Curve::Polyline({{500, 460}, {200, 300}})};
  const EgoBoundaries low = SelectEgoBoundaries(labels, 320, 460);
  EXPECT_EQ(low.left, 0);
  EXPECT_EQ(low.right, 1);
  const EgoBoundaries high = SelectEgoBoundaries(labels, 320, 300);
  EXPECT_EQ(high.left, 1);
  EXPECT_EQ(high.right, 0);
}

TEST(EgoTest, LabelsStoppingShortOfTheRowAreExtended) {
  // The row (479) is below both labels' lower ends (470).
  const std::vector<Curve> labels = {StraightBoundary(200), StraightBoundary(450)};
  const EgoBoundaries ego = SelectEgoBoundaries(labels, 320, 479);
  EXPECT_EQ(ego.left, 0);
  EXPECT_EQ(ego.right, 1);
}

TEST(EgoTest, MissingSide) {
  const EgoBoundaries ego =
      SelectEgoBoundaries({StraightBoundary(100), StraightBoundary(250)}, 320, 400);
  EXPECT_EQ(ego.left, 1);
  EXPECT_EQ(ego.right, -1);
  const EgoBoundaries none = SelectEgoBoundaries({}, 320, 400);
  EXPECT_EQ(none.left, -1);
  EXPECT_EQ(none.right, -1);
}

TEST(EgoTest, TwoLanesModeScoresOnlyTheEgoBoundaries) {
  LabelledFrame frame;
  for (double x : {-330.0, 10.0, 290.0, 610.0, 900.0})
    frame.boundaries.push_back({StraightBoundary(x), ""});
  EvalOptions options;
  options.mode = Mode::kTwo;
  options.ego_row = 350;
  // Detections on the ego boundaries and on an outer one.
  const std::vector<Curve> detections = {StraightBoundary(290), StraightBoundary(610),
                                         StraightBoundary(10)};
  const FrameScore score = ScoreFrame(detections, frame, 640, 480, options);
  EXPECT_EQ(score.scored_labels, (std::vector<int>{2, 3}));
  EXPECT_EQ(score.paper.MatchedLabels(), 2);
  EXPECT_EQ(score.paper.FalsePositives(), 1);  // the outer boundary is not scored
  EXPECT_EQ(score.culane.MatchedDetections(), 2);

  options.mode = Mode::kAll;
  const FrameScore all = ScoreFrame(detections, frame, 640, 480, options);
  EXPECT_EQ(all.scored_labels.size(), 5u);
  EXPECT_EQ(all.paper.MatchedLabels(), 3);
  EXPECT_EQ(all.paper.FalsePositives(), 0);
}

}  // namespace
}  // namespace lane::eval
