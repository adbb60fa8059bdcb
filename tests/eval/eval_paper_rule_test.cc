// The paper's scoring rule on hand-made curves: identical and shifted
// curves, Bezier against polyline, one-to-one assignment, width scaling.
#include <gtest/gtest.h>

#include <cmath>

#include "lane/eval/curve.h"
#include "lane/eval/curve_distances.h"
#include "lane/eval/paper_rule.h"

namespace lane::eval {
namespace {

// A gently curved boundary in a 640x480 frame, bottom to top.
Curve CurvedBoundary(double dx = 0) {
  return Curve::FromBezier(std::array<Eigen::Vector2d, 4>{
      Eigen::Vector2d(200 + dx, 470), Eigen::Vector2d(240 + dx, 400),
      Eigen::Vector2d(270 + dx, 330), Eigen::Vector2d(290 + dx, 250)});
}

// The same curve as a CULane-style polyline: vertices every ~10 rows.
Curve AsPolyline(const Curve& c, int vertices) { return Curve::Polyline(c.Sample(vertices)); }

TEST(CurveTest, BezierSamplesAreThePapersT) {
  const Curve c = CurvedBoundary();
  const std::vector<Eigen::Vector2d> s = c.Sample();
  ASSERT_EQ(s.size(), 101u);
  EXPECT_TRUE(s.front().isApprox(c.points[0]));
  EXPECT_TRUE(s.back().isApprox(c.points[3]));
  const Bezier b{{c.points[0], c.points[1], c.points[2], c.points[3]}};
  EXPECT_TRUE(s[37].isApprox(b.Eval(0.37)));
}

TEST(CurveTest, PolylineIsDensifiedEvenlyAlongItsLength) {
  // An L: 100 px right, then 100 px down; 5 samples every 50 px.
  const Curve c = Curve::Polyline({{0, 0}, {100, 0}, {100, 100}});
  const std::vector<Eigen::Vector2d> s = c.Sample(5);
  ASSERT_EQ(s.size(), 5u);
  const Eigen::Vector2d expected[] = {{0, 0}, {50, 0}, {100, 0}, {100, 50}, {100, 100}};
  for (int i = 0; i < 5; ++i) {
    EXPECT_NEAR((s[i] - expected[i]).norm(), 0, 1e-9) << "sample " << i;
  }
}

TEST(CurveTest, DegeneratePolylines) {
  EXPECT_TRUE(Curve::Polyline({}).Sample().empty());
  const std::vector<Eigen::Vector2d> s = Curve::Polyline({{3, 4}, {3, 4}}).Sample(7);
  ASSERT_EQ(s.size(), 7u);
  EXPECT_TRUE(s[6].isApprox(Eigen::Vector2d(3, 4)));
}

TEST(CurveTest, XAtRowCrossesAndExtends) {
  const Curve line = Curve::Polyline({{100, 500}, {200, 400}});
  EXPECT_NEAR(*XAtRow(line.Sample(), 450), 150, 1e-9);
  // Below the curve's lower end: extended along it.
  EXPECT_NEAR(*XAtRow(line.Sample(), 550), 50, 1e-9);
  // Above its upper end.
  EXPECT_NEAR(*XAtRow(line.Sample(), 300), 300, 1e-9);
  // Order of the points does not matter.
  EXPECT_NEAR(*XAtRow(Curve::Polyline({{200, 400}, {100, 500}}).Sample(), 550), 50, 1e-9);
  // A horizontal curve never reaches another row.
  EXPECT_FALSE(XAtRow(Curve::Polyline({{0, 10}, {100, 10}}).Sample(), 20).has_value());
}

TEST(PaperRuleTest, IdenticalCurvesMatch) {
  const Matching m = MatchPaperRule({CurvedBoundary()}, {CurvedBoundary()}, 640);
  EXPECT_EQ(m.detection_label, std::vector<int>{0});
  EXPECT_EQ(m.label_detection, std::vector<int>{0});
  EXPECT_EQ(m.MatchedLabels(), 1);
  EXPECT_EQ(m.FalsePositives(), 0);
}

TEST(PaperRuleTest, ThirtyPixelShiftAt640DoesNotMatch) {
  const Matching m = MatchPaperRule({CurvedBoundary(30)}, {CurvedBoundary()}, 640);
  EXPECT_EQ(m.MatchedLabels(), 0);
  EXPECT_EQ(m.FalsePositives(), 1);
  EXPECT_EQ(m.Misses(), 1);
  // Under both the AND and the OR rule: every distance exceeds both bounds.
  PaperRuleOptions loose;
  loose.rule = PaperRuleOptions::Rule::kOr;
  EXPECT_EQ(MatchPaperRule({CurvedBoundary(30)}, {CurvedBoundary()}, 640, loose).MatchedLabels(),
            0);
  // A 10 px shift matches.
  EXPECT_EQ(MatchPaperRule({CurvedBoundary(10)}, {CurvedBoundary()}, 640).MatchedLabels(), 1);
}

TEST(PaperRuleTest, BezierMatchesDensifiedPolylineOfTheSameCurve) {
  const Curve polyline = AsPolyline(CurvedBoundary(), 23);  // like a CULane label
  ASSERT_EQ(polyline.kind, Curve::Kind::kPolyline);
  const MatchDistances d = CurveMatchDistances(CurvedBoundary().Sample(), polyline.Sample());
  // Bezier t is not arc length, so the samples differ, but lie on one curve.
  EXPECT_LT(d.median, 1.0);
  EXPECT_LT(d.mean, 1.0);
  EXPECT_EQ(MatchPaperRule({CurvedBoundary()}, {polyline}, 640).MatchedLabels(), 1);
  // And a detection covering only the lower half of a label still matches:
  // the rule takes the smaller of the two directed distances.
  const Curve lower_half = Curve::Polyline(
      std::vector<Eigen::Vector2d>(polyline.points.begin(), polyline.points.begin() + 12));
  EXPECT_EQ(MatchPaperRule({lower_half}, {CurvedBoundary()}, 640).MatchedLabels(), 1);
}

TEST(PaperRuleTest, OneToOneAssignmentBestPairsFirst) {
  // Two detections on one label: the nearer is correct, the other a false
  // positive. A second label far away is missed.
  const std::vector<Curve> detections = {CurvedBoundary(8), CurvedBoundary(2)};
  const std::vector<Curve> labels = {CurvedBoundary(), CurvedBoundary(200)};
  const Matching m = MatchPaperRule(detections, labels, 640);
  EXPECT_EQ(m.detection_label, (std::vector<int>{-1, 0}));
  EXPECT_EQ(m.label_detection, (std::vector<int>{1, -1}));
  EXPECT_EQ(m.MatchedLabels(), 1);
  EXPECT_EQ(m.MatchedDetections(), 1);
  EXPECT_EQ(m.FalsePositives(), 1);
  EXPECT_EQ(m.Misses(), 1);

  // The released code's many-to-one counting: both detections are correct.
  PaperRuleOptions many;
  many.assignment = PaperRuleOptions::Assignment::kManyToOne;
  const Matching mm = MatchPaperRule(detections, labels, 640, many);
  EXPECT_EQ(mm.detection_label, (std::vector<int>{0, 0}));
  EXPECT_EQ(mm.label_detection, (std::vector<int>{1, -1}));  // the best one
  EXPECT_EQ(mm.MatchedLabels(), 1);
  EXPECT_EQ(mm.MatchedDetections(), 2);
  EXPECT_EQ(mm.FalsePositives(), 0);
}

TEST(PaperRuleTest, OneToOneGivesEachDetectionItsOwnLabel) {
  // Two labels 12 px apart, two detections between them: each label gets
  // one detection even though both detections are within bounds of both.
  const std::vector<Curve> labels = {CurvedBoundary(0), CurvedBoundary(12)};
  const std::vector<Curve> detections = {CurvedBoundary(10), CurvedBoundary(3)};
  const Matching m = MatchPaperRule(detections, labels, 640);
  EXPECT_EQ(m.detection_label, (std::vector<int>{1, 0}));
  EXPECT_EQ(m.MatchedLabels(), 2);
  EXPECT_EQ(m.FalsePositives(), 0);
}

TEST(PaperRuleTest, ThresholdsScaleWithWidth) {
  // Bounds are 20/15 px at 640 px, 40/30 px at 1280 px.
  EXPECT_FALSE(PassesPaperRule(18, 16, 640, {}));  // mean too large
  EXPECT_TRUE(PassesPaperRule(18, 14, 640, {}));
  EXPECT_TRUE(PassesPaperRule(36, 28, 1280, {}));
  EXPECT_FALSE(PassesPaperRule(36, 31, 1280, {}));
  EXPECT_TRUE(PassesPaperRule(10, 7.5, 320, {}));
  EXPECT_FALSE(PassesPaperRule(10.5, 7, 320, {}));
  // The OR rule passes when either bound holds.
  PaperRuleOptions loose;
  loose.rule = PaperRuleOptions::Rule::kOr;
  EXPECT_TRUE(PassesPaperRule(18, 16, 640, loose));
  EXPECT_FALSE(PassesPaperRule(21, 16, 640, loose));

  // The same picture at twice the size: a 30 px shift at 1280 px is a 15 px
  // shift at 640 px, and matches.
  const auto scaled = [](double dx) {
    Curve c = CurvedBoundary(dx / 2);
    for (Eigen::Vector2d& p : c.points) p *= 2;
    return c;
  };
  EXPECT_EQ(MatchPaperRule({scaled(30)}, {scaled(0)}, 1280).MatchedLabels(), 1);
  EXPECT_EQ(MatchPaperRule({scaled(30)}, {scaled(0)}, 640).MatchedLabels(), 0);
  EXPECT_EQ(MatchPaperRule({scaled(60)}, {scaled(0)}, 1280).MatchedLabels(), 0);
}

TEST(PaperRuleTest, EmptySides) {
  const Matching none = MatchPaperRule({}, {CurvedBoundary()}, 640);
  EXPECT_EQ(none.Misses(), 1);
  const Matching fp = MatchPaperRule({CurvedBoundary()}, {}, 640);
  EXPECT_EQ(fp.FalsePositives(), 1);
}

TEST(PaperRuleTest, OptionsValidate) {
  EXPECT_TRUE(PaperRuleOptions().Validate().ok());
  PaperRuleOptions bad;
  bad.median_px = 0;
  EXPECT_FALSE(bad.Validate().ok());
  bad = PaperRuleOptions();
  bad.samples = 1;
  EXPECT_FALSE(bad.Validate().ok());
}

}  // namespace
}  // namespace lane::eval
