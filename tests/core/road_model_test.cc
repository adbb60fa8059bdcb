// The road model (lane/detector/road_model.h): a boundary hidden between two found
// ones that run parallel two lane widths apart is inferred half-way; nothing
// else is.
#include "lane/detector/road_model.h"

#include <gtest/gtest.h>

#include <cmath>

namespace lane {
namespace {

// A boundary x(y) = x0 + heading * y + curvature * y^2 / 2 from y = 3 m to
// y_far, as a ground Bezier with its far end first (as the detector gives).
Bezier Boundary(double x0, double heading = 0, double curvature = 0, double y_near = 3,
                double y_far = 40) {
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i <= 20; ++i) {
    const double y = y_far - (y_far - y_near) * i / 20.0;
    pts.emplace_back(x0 + heading * y + 0.5 * curvature * y * y, y);
  }
  return *FitBezier(pts);
}

// Inference is off by default (docs/config.md): the tests switch it on.
RoadModelOptions On() {
  RoadModelOptions o;
  o.infer_hidden = true;
  return o;
}

TEST(LateralProfileTest, InterpolatesAlongTheRoadAndClampsBeyondItsEnds) {
  const auto p = LateralProfile::FromGround(Boundary(1.0, 0.05));
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR(p->y_near(), 3.0, 1e-6);
  EXPECT_NEAR(p->y_far(), 40.0, 1e-6);
  EXPECT_NEAR(p->XAt(20.0), 2.0, 1e-3);
  EXPECT_NEAR(p->XAt(0.0), p->XAt(3.0), 1e-9);
  // A curve across the road (y not advancing) has no profile.
  Bezier across = Bezier::Line({-5, 10}, {5, 10});
  EXPECT_FALSE(LateralProfile::FromGround(across).has_value());
}

TEST(RoadModelTest, InfersTheBoundaryHiddenBetweenTwoLaneWidths) {
  // Found: -5.25, -1.75, +5.25 on a gentle right curve; hidden: +1.75.
  const double k = 1.0 / 400;
  const std::vector<Bezier> found = {Boundary(-5.25, 0.01, k), Boundary(-1.75, 0.01, k),
                                     Boundary(5.25, 0.01, k)};
  const std::vector<InferredBoundary> hidden = InferHiddenBoundaries(found, On());
  ASSERT_EQ(hidden.size(), 1u);
  EXPECT_EQ(hidden[0].left, 1);
  EXPECT_EQ(hidden[0].right, 2);
  const auto p = LateralProfile::FromGround(hidden[0].ground);
  ASSERT_TRUE(p.has_value());
  for (double y : {5.0, 15.0, 30.0}) {
    EXPECT_NEAR(p->XAt(y), 1.75 + 0.01 * y + 0.5 * k * y * y, 0.02) << "at y = " << y;
  }
  EXPECT_GT(hidden[0].ground.p[0].y(), hidden[0].ground.p[3].y()) << "far end first";
}

TEST(RoadModelTest, AnInferredBoundaryRunsAsFarAsEitherNeighbour) {
  // The left neighbour is seen from 3 to 40 m, the right one from 6 to 25 m:
  // the hidden boundary runs from 3 to 40 m, half a gap from whichever
  // neighbour is there.
  const std::vector<Bezier> found = {Boundary(-1.8, 0.02, 0, 3, 40), Boundary(5.2, 0.02, 0, 6, 25)};
  const std::vector<InferredBoundary> hidden = InferHiddenBoundaries(found, On());
  ASSERT_EQ(hidden.size(), 1u);
  const auto p = LateralProfile::FromGround(hidden[0].ground);
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR(p->y_near(), 3.0, 0.05);
  EXPECT_NEAR(p->y_far(), 40.0, 0.05);
  for (double y : {4.0, 15.0, 35.0}) EXPECT_NEAR(p->XAt(y), 1.7 + 0.02 * y, 0.02) << y;
}

TEST(RoadModelTest, InfersNothingWhereTheGapIsNotTwoLanes) {
  const RoadModelOptions options = On();
  // One lane width apart: nothing hidden.
  EXPECT_TRUE(InferHiddenBoundaries({Boundary(-1.75), Boundary(1.75)}, options).empty());
  // 5.0 m (half is 2.5, narrower than a lane) and 10 m (half is 5 m, wider).
  EXPECT_TRUE(InferHiddenBoundaries({Boundary(-1.75), Boundary(3.25)}, options).empty());
  EXPECT_TRUE(InferHiddenBoundaries({Boundary(-1.75), Boundary(8.25)}, options).empty());
  // Two lane widths at the near end but converging (not parallel).
  EXPECT_TRUE(InferHiddenBoundaries({Boundary(-1.75), Boundary(5.25, -0.05)}, options).empty());
  // Overlapping over less than min_overlap_m.
  EXPECT_TRUE(
      InferHiddenBoundaries({Boundary(-1.75, 0, 0, 3, 9), Boundary(5.25, 0, 0, 6, 40)}, options)
          .empty());
  // Switched off (the default).
  const RoadModelOptions off;
  EXPECT_TRUE(InferHiddenBoundaries({Boundary(-1.75), Boundary(5.25)}, off).empty());
}

TEST(RoadModelTest, AGapMustMatchTheLaneWidthTheFrameShows) {
  // The frame shows 3.0 m lanes (-4.5 | -1.5 | 1.5); a 7.6 m gap would be two
  // 3.8 m lanes, 27 % wider: a shoulder or a turn bay, not a hidden line.
  const std::vector<Bezier> wide = {Boundary(-4.5), Boundary(-1.5), Boundary(1.5), Boundary(9.1)};
  EXPECT_TRUE(InferHiddenBoundaries(wide, On()).empty());
  // A 6.2 m gap (two 3.1 m lanes) is.
  const std::vector<Bezier> two = {Boundary(-4.5), Boundary(-1.5), Boundary(1.5), Boundary(7.7)};
  const std::vector<InferredBoundary> hidden = InferHiddenBoundaries(two, On());
  ASSERT_EQ(hidden.size(), 1u);
  EXPECT_EQ(hidden[0].left, 2);
  EXPECT_NEAR(LateralProfile::FromGround(hidden[0].ground)->XAt(10), 4.6, 0.02);
}

TEST(RoadModelTest, GuessesTheOuterBoundariesOneLaneWidthOutside) {
  // Found: -1.5, 1.5, 4.5 (3.0 m lanes, parallel, heading 0.02): the
  // guesses run at -4.5 and 7.5, parallel to the outermost ones.
  const std::vector<Bezier> found = {Boundary(-1.5, 0.02), Boundary(1.5, 0.02),
                                     Boundary(4.5, 0.02)};
  const std::vector<Bezier> guesses = OuterBoundaryGuesses(found, RoadModelOptions{});
  ASSERT_EQ(guesses.size(), 2u);
  for (double y : {5.0, 30.0}) {
    EXPECT_NEAR(LateralProfile::FromGround(guesses[0])->XAt(y), -4.5 + 0.02 * y, 0.02);
    EXPECT_NEAR(LateralProfile::FromGround(guesses[1])->XAt(y), 7.5 + 0.02 * y, 0.02);
  }
  // One boundary alone: the middle of the plausible widths (2.6..4.3 m).
  const std::vector<Bezier> one = OuterBoundaryGuesses({Boundary(1.0)}, RoadModelOptions{});
  ASSERT_EQ(one.size(), 2u);
  EXPECT_NEAR(LateralProfile::FromGround(one[0])->XAt(10), 1.0 - 3.45, 0.02);
  EXPECT_NEAR(LateralProfile::FromGround(one[1])->XAt(10), 1.0 + 3.45, 0.02);
  EXPECT_TRUE(OuterBoundaryGuesses({}, RoadModelOptions{}).empty());
}

TEST(RoadModelTest, ALineFoundInASearchWindowMustFitTheRoad) {
  const RoadModelOptions o;
  const std::vector<Bezier> found = {Boundary(-1.75), Boundary(5.25)};
  // Parallel, a lane width from a found boundary: fits.
  EXPECT_TRUE(FitsRoadModel(Boundary(1.75), found, 0, 50, o));
  // Closer than (1 - width_tolerance) lane widths to a found one: a second
  // edge of the same marking or a vehicle's edge.
  EXPECT_FALSE(FitsRoadModel(Boundary(-0.2), found, 0, 50, o));
  // Not parallel to any found boundary (converging by 0.1 m per metre).
  EXPECT_FALSE(FitsRoadModel(Boundary(1.75, 0.1), found, 0, 50, o));
  // Wider than a lane from both: nothing supports it.
  EXPECT_FALSE(FitsRoadModel(Boundary(12.0), found, 0, 50, o));
  // Judged inside the top view's rows only: a line that bends away (0.4 m
  // off by 15 m, 3.2 m by 40 m) fits a view that ends at 15 m.
  const Bezier bends = Boundary(1.75, 0, 1.0 / 250, 3, 40);
  EXPECT_FALSE(FitsRoadModel(bends, found, 0, 50, o));
  EXPECT_TRUE(FitsRoadModel(bends, found, 0, 15, o));
}

TEST(RoadModelTest, OptionsAreValidated) {
  RoadModelOptions o;
  EXPECT_TRUE(o.Validate().ok());
  o.max_lane_width_m = o.min_lane_width_m;
  EXPECT_FALSE(o.Validate().ok());
  o = RoadModelOptions{};
  o.max_gap_change_m = 0;
  EXPECT_FALSE(o.Validate().ok());
  o = RoadModelOptions{};
  o.search_half_width_m = 0;
  EXPECT_FALSE(o.Validate().ok());
  o.search_half_width_m = o.min_lane_width_m;  // windows of neighbours would overlap
  EXPECT_FALSE(o.Validate().ok());
  o = RoadModelOptions{};
  o.search_quantile = 1.0;
  EXPECT_FALSE(o.Validate().ok());
  o = RoadModelOptions{};
  o.search_min_fraction = -0.1;
  EXPECT_FALSE(o.Validate().ok());
}

}  // namespace
}  // namespace lane
