// One RANSAC loop shared by the line and spline fitters.
//
// An Estimator provides:
//   using Model = ...;
//   static constexpr int kSampleSize;
//   std::optional<Model> Estimate(const std::vector<Eigen::Vector2d>& sample) const;
//   double Score(const Model& model) const;   // higher is better
// Points are drawn without replacement with probability proportional to their
// weight (the thresholded filter response), as the paper prescribes.
#ifndef LANE_RANSAC_H_
#define LANE_RANSAC_H_

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <optional>
#include <random>
#include <vector>

namespace lane {

template <typename Model>
struct RansacReport {
  std::optional<Model> model;  // nullopt when no trial produced a model
  double score = 0.0;
  int trials = 0;
};

// Draws `out.size()` distinct indices with probability proportional to
// `cumulative` (the running sum of the weights) into `out`. Returns false if
// that many distinct indices could not be drawn. Deterministic for a given
// engine state.
inline bool WeightedSample(const std::vector<double>& cumulative, std::vector<int>& out,
                           std::mt19937_64& rng) {
  const int k = static_cast<int>(out.size());
  const int n = static_cast<int>(cumulative.size());
  if (n < k || cumulative.back() <= 0) return false;
  std::uniform_real_distribution<double> uni(0.0, cumulative.back());
  int have = 0;
  for (int attempts = 0; have < k && attempts < 20 * k; ++attempts) {
    const double r = uni(rng);
    int idx = static_cast<int>(std::upper_bound(cumulative.begin(), cumulative.end(), r) -
                               cumulative.begin());
    idx = std::min(idx, n - 1);
    if (std::find(out.begin(), out.begin() + have, idx) == out.begin() + have) out[have++] = idx;
  }
  return have == k;
}

// Runs `iterations` trials. `initial` (if any) is scored first, so a good
// initial guess survives when no sample beats it.
template <typename Estimator>
RansacReport<typename Estimator::Model> Ransac(
    const Estimator& estimator, const std::vector<Eigen::Vector2d>& points,
    const std::vector<double>& weights, int iterations, std::mt19937_64& rng,
    const std::optional<typename Estimator::Model>& initial = std::nullopt) {
  RansacReport<typename Estimator::Model> report;
  if (initial) {
    report.model = *initial;
    report.score = estimator.Score(*initial);
  }
  if (static_cast<int>(points.size()) < Estimator::kSampleSize) return report;
  std::vector<double> cumulative(weights.size());
  double acc = 0;
  for (size_t i = 0; i < weights.size(); ++i) cumulative[i] = (acc += std::max(0.0, weights[i]));
  std::vector<Eigen::Vector2d> sample(Estimator::kSampleSize);
  std::vector<int> idx(Estimator::kSampleSize);
  for (int it = 0; it < iterations; ++it) {
    ++report.trials;
    if (!WeightedSample(cumulative, idx, rng)) break;
    for (int j = 0; j < Estimator::kSampleSize; ++j) sample[j] = points[idx[j]];
    const auto model = estimator.Estimate(sample);
    if (!model) continue;
    const double score = estimator.Score(*model);
    if (!report.model || score > report.score) {
      report.model = *model;
      report.score = score;
    }
  }
  return report;
}

}  // namespace lane

#endif  // LANE_RANSAC_H_
