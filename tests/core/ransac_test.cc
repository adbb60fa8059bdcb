// The RANSAC template on synthetic truth (in the manner of COLMAP's
// ransac_test): a known line among outliers comes back with exactly its
// inliers in the report's mask.
#include "lane/ransac.h"

#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <random>
#include <vector>

namespace lane {
namespace {

// y = slope * x + intercept, fitted through two samples; inliers within tol.
struct Line {
  double slope = 0;
  double intercept = 0;
};

class LineThroughTwo {
 public:
  using Model = Line;
  static constexpr int kSampleSize = 2;

  LineThroughTwo(const std::vector<Eigen::Vector2d>& points, double tol)
      : points_(points), tol_(tol) {}

  std::optional<Line> Estimate(const std::vector<Eigen::Vector2d>& sample) const {
    const Eigen::Vector2d d = sample[1] - sample[0];
    if (std::abs(d.x()) < 1e-12) return std::nullopt;
    const double slope = d.y() / d.x();
    return Line{slope, sample[0].y() - slope * sample[0].x()};
  }
  double Score(const Line& line) const {
    double score = 0;
    for (size_t i = 0; i < points_.size(); ++i) score += IsInlier(line, i);
    return score;
  }
  bool IsInlier(const Line& line, size_t i) const {
    const Eigen::Vector2d& p = points_[i];
    return std::abs(line.slope * p.x() + line.intercept - p.y()) <= tol_;
  }

 private:
  const std::vector<Eigen::Vector2d>& points_;
  double tol_;
};

// The same without IsInlier: the report has no mask.
class ScoreOnly {
 public:
  using Model = Line;
  static constexpr int kSampleSize = 2;
  explicit ScoreOnly(const LineThroughTwo& inner) : inner_(inner) {}
  std::optional<Line> Estimate(const std::vector<Eigen::Vector2d>& s) const {
    return inner_.Estimate(s);
  }
  double Score(const Line& line) const { return inner_.Score(line); }

 private:
  const LineThroughTwo& inner_;
};

struct Scene {
  std::vector<Eigen::Vector2d> points;
  std::vector<double> weights;
  std::vector<char> truth;  // 1 for the line's points
};

// 60 points on y = 0.5 x + 3 (noise below the tolerance), 40 outliers at
// least 2 away from it.
Scene MakeScene(uint64_t seed) {
  Scene scene;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> x(0, 100), noise(-0.05, 0.05), off(2, 30);
  std::bernoulli_distribution sign(0.5);
  for (int i = 0; i < 100; ++i) {
    const double px = x(rng);
    const bool inlier = i % 5 < 3;
    const double y = 0.5 * px + 3 + (inlier ? noise(rng) : (sign(rng) ? 1 : -1) * off(rng));
    scene.points.emplace_back(px, y);
    scene.weights.push_back(1.0);
    scene.truth.push_back(inlier ? 1 : 0);
  }
  return scene;
}

TEST(RansacTest, RecoversTheModelAndExactlyItsInliers) {
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    const Scene scene = MakeScene(seed);
    const LineThroughTwo estimator(scene.points, 0.2);
    std::mt19937_64 rng(seed);
    const RansacReport<Line> report =
        Ransac(estimator, scene.points, scene.weights, RansacOptions{200}, rng);
    ASSERT_TRUE(report.model.has_value()) << "seed " << seed;
    EXPECT_NEAR(report.model->slope, 0.5, 0.01) << "seed " << seed;
    EXPECT_NEAR(report.model->intercept, 3, 0.5) << "seed " << seed;
    ASSERT_EQ(report.inlier_mask, scene.truth) << "seed " << seed;
    EXPECT_EQ(report.num_inliers, 60u);
    EXPECT_EQ(report.score, 60.0);
    EXPECT_EQ(report.trials, 200);
  }
}

TEST(RansacTest, DeterministicForAnEngineStateAndWeightedBySampling) {
  const Scene scene = MakeScene(7);
  const LineThroughTwo estimator(scene.points, 0.2);
  std::mt19937_64 a(3), b(3);
  const RansacReport<Line> ra = Ransac(estimator, scene.points, scene.weights, RansacOptions{5}, a);
  const RansacReport<Line> rb = Ransac(estimator, scene.points, scene.weights, RansacOptions{5}, b);
  ASSERT_TRUE(ra.model && rb.model);
  EXPECT_EQ(ra.model->slope, rb.model->slope);
  EXPECT_EQ(ra.inlier_mask, rb.inlier_mask);
  // Zero weight on every outlier: even 3 trials only ever draw the line's
  // points, so the fit is exact.
  std::vector<double> weights(scene.points.size());
  for (size_t i = 0; i < weights.size(); ++i) weights[i] = scene.truth[i];
  for (uint64_t seed = 1; seed <= 10; ++seed) {
    std::mt19937_64 rng(seed);
    const RansacReport<Line> r = Ransac(estimator, scene.points, weights, RansacOptions{3}, rng);
    ASSERT_TRUE(r.model.has_value());
    EXPECT_EQ(r.inlier_mask, scene.truth) << "seed " << seed;
  }
}

TEST(RansacTest, InitialModelSurvivesAndTooFewPointsGiveNoTrials) {
  const Scene scene = MakeScene(2);
  const LineThroughTwo estimator(scene.points, 0.2);
  std::mt19937_64 rng(1);
  // A perfect initial guess and a single trial: the guess is kept unless
  // that one sample ties or beats it.
  const RansacReport<Line> kept = Ransac(estimator, scene.points, scene.weights, RansacOptions{1},
                                         rng, std::optional<Line>(Line{0.5, 3}));
  ASSERT_TRUE(kept.model.has_value());
  EXPECT_EQ(kept.num_inliers, 60u);

  const std::vector<Eigen::Vector2d> one = {scene.points[0]};
  const LineThroughTwo lonely(one, 0.2);
  const RansacReport<Line> none = Ransac(lonely, one, {1.0}, RansacOptions{10}, rng);
  EXPECT_FALSE(none.model.has_value());
  EXPECT_EQ(none.trials, 0);
  EXPECT_TRUE(none.inlier_mask.empty());

  // Without IsInlier there is no mask, but the same model.
  const ScoreOnly score_only(estimator);
  std::mt19937_64 r1(9), r2(9);
  const RansacReport<Line> with =
      Ransac(estimator, scene.points, scene.weights, RansacOptions{50}, r1);
  const RansacReport<Line> without =
      Ransac(score_only, scene.points, scene.weights, RansacOptions{50}, r2);
  ASSERT_TRUE(with.model && without.model);
  EXPECT_EQ(with.model->slope, without.model->slope);
  EXPECT_TRUE(without.inlier_mask.empty());
  EXPECT_FALSE(with.inlier_mask.empty());
}

TEST(RansacTest, OptionsAreValidated) {
  EXPECT_TRUE(RansacOptions{}.Validate().ok());
  EXPECT_FALSE(RansacOptions{0}.Validate().ok());
}

}  // namespace
}  // namespace lane
