// The RANSAC template on synthetic truth (in the manner of COLMAP's
// ransac_test): a known line among outliers comes back with exactly its
// inliers in the report's mask.
#include "lane/stages/ransac.h"

#include <gtest/gtest.h>

#include <algorithm>
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

// The same with the adaptive stop's SupportFraction: the inliers' share.
class WithSupport {
 public:
  using Model = Line;
  static constexpr int kSampleSize = 2;
  explicit WithSupport(const LineThroughTwo& inner, size_t n) : inner_(inner), n_(n) {}
  std::optional<Line> Estimate(const std::vector<Eigen::Vector2d>& s) const {
    return inner_.Estimate(s);
  }
  double Score(const Line& line) const { return inner_.Score(line); }
  double SupportFraction(const Line& line) const { return Score(line) / n_; }

 private:
  const LineThroughTwo& inner_;
  size_t n_;
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

TEST(RansacTest, AdaptiveTrialsFollowTheStandardFormula) {
  // 60 % support, pairs: 0.36 per sample; log(0.01) / log(0.64) = 10.3.
  EXPECT_EQ(AdaptiveTrials(0.99, 0.6, 2, 200), 11);
  EXPECT_EQ(AdaptiveTrials(0.999, 0.6, 2, 200), 16);
  // Four points at 90 %: 0.656 per sample, log(0.001) / log(0.344) = 6.5.
  EXPECT_EQ(AdaptiveTrials(0.999, 0.9, 4, 40), 7);
  EXPECT_EQ(AdaptiveTrials(0.999, 0.5, 4, 40), 40);  // 108 trials: capped
  EXPECT_EQ(AdaptiveTrials(0.999, 1.0, 4, 40), 1);
  EXPECT_EQ(AdaptiveTrials(0.999, 0.0, 4, 40), 40);
  EXPECT_EQ(AdaptiveTrials(0.0, 0.9, 4, 40), 40);  // off
}

TEST(RansacTest, AdaptiveStopEndsOnceTheBestModelIsLikelyFound) {
  int total_trials = 0;
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    const Scene scene = MakeScene(seed);
    const LineThroughTwo inner(scene.points, 0.2);
    const WithSupport estimator(inner, scene.points.size());
    std::mt19937_64 rng(seed);
    RansacOptions options{200};
    options.confidence = 0.99;
    const RansacReport<Line> report = Ransac(estimator, scene.points, scene.weights, options, rng);
    ASSERT_TRUE(report.model.has_value()) << "seed " << seed;
    EXPECT_NEAR(report.model->slope, 0.5, 0.01) << "seed " << seed;
    EXPECT_EQ(report.score, 60.0) << "seed " << seed;
    // Once the line is found (60 % support) 11 trials suffice; an earlier
    // partial model may ask for more, but never the 200 allowed.
    EXPECT_GE(report.trials, 11) << "seed " << seed;
    EXPECT_LT(report.trials, 200) << "seed " << seed;
    total_trials += report.trials;
  }
  EXPECT_LT(total_trials, 20 * 30);

  // min_iterations holds the loop open; without SupportFraction, or with
  // confidence 0, it runs every trial.
  const Scene scene = MakeScene(4);
  const LineThroughTwo inner(scene.points, 0.2);
  const WithSupport estimator(inner, scene.points.size());
  RansacOptions options{200};
  options.confidence = 0.99;
  options.min_iterations = 50;
  std::mt19937_64 r1(1), r2(1), r3(1);
  EXPECT_EQ(Ransac(estimator, scene.points, scene.weights, options, r1).trials, 50);
  options.min_iterations = 1;
  EXPECT_EQ(Ransac(inner, scene.points, scene.weights, options, r2).trials, 200);
  options.confidence = 0;
  EXPECT_EQ(Ransac(estimator, scene.points, scene.weights, options, r3).trials, 200);
}

// The branch-free search gives std::upper_bound's index on every sorted
// array, at and between its values, past both ends and through runs of equal
// values (a zero weight repeats a cumulative value).
TEST(RansacTest, UpperBoundIndexEqualsTheLibrarySearch) {
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<int> step(0, 3);
  for (int n = 0; n <= 40; ++n) {
    std::vector<double> a(n);
    double v = 0;
    for (double& x : a) x = v += step(rng);  // steps of 0 repeat a value
    std::vector<double> queries = {-1.0, v + 1, 0.0};
    for (const double x : a) {
      queries.push_back(x);
      queries.push_back(x - 0.5);
      queries.push_back(std::nextafter(x, 1e9));
    }
    for (const double q : queries) {
      const int want = static_cast<int>(std::upper_bound(a.begin(), a.end(), q) - a.begin());
      ASSERT_EQ(internal::UpperBoundIndex(a.data(), n, q), want) << "n " << n << " x " << q;
    }
  }
}

TEST(RansacTest, OptionsAreValidated) {
  EXPECT_TRUE(RansacOptions{}.Validate().ok());
  EXPECT_TRUE(RansacOptions{0}.Validate().ok());  // only an initial model scored
  EXPECT_FALSE(RansacOptions{-1}.Validate().ok());
  EXPECT_FALSE(RansacOptions{10001}.Validate().ok());
  // The adaptive stop's floor cannot lie above the trials, and the message
  // names the config file's keys.
  const absl::Status above = RansacOptions{3, 0.999, 5}.Validate("line_ransac");
  EXPECT_EQ(above.message(), "line_ransac.min_iterations (5) must not exceed iterations (3)");
  EXPECT_TRUE((RansacOptions{5, 0.999, 5}.Validate().ok()));
  RansacOptions o;
  o.confidence = 1.0;
  EXPECT_FALSE(o.Validate().ok());
  o.confidence = 0.999;
  EXPECT_TRUE(o.Validate().ok());
  o.min_iterations = 0;
  EXPECT_FALSE(o.Validate().ok());
}

}  // namespace
}  // namespace lane
