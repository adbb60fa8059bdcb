// One RANSAC loop shared by the line and spline fitters (COLMAP's shape: an
// estimator interface, an options struct, a report value).
//
// An Estimator provides:
//   using Model = ...;
//   static constexpr int kSampleSize;
//   std::optional<Model> Estimate(const std::vector<Eigen::Vector2d>& sample) const;
//   double Score(const Model& model) const;   // higher is better
// and, when its score counts inliers, optionally
//   bool IsInlier(const Model& model, size_t i) const;   // point i of the set
// in which case the report carries the best model's inlier mask, so that a
// refit uses exactly the inliers the score counted.
//
// Points are drawn without replacement with probability proportional to
// their weight (the thresholded filter response), as the paper prescribes.
#ifndef LANE_RANSAC_H_
#define LANE_RANSAC_H_

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <random>
#include <type_traits>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace lane {

struct RansacOptions {
  // Trials (samples drawn and scored). The paper's 40 for lines and splines
  // in all-lanes mode; fewer samples than kSampleSize end the loop early.
  int max_trials = 40;

  absl::Status Validate() const {
    if (max_trials < 1 || max_trials > 100000) {
      return absl::InvalidArgumentError(
          absl::StrCat("RANSAC max_trials must lie in 1..100000, got ", max_trials));
    }
    return absl::OkStatus();
  }
};

template <typename Model>
struct RansacReport {
  std::optional<Model> model;  // nullopt when no trial produced a model
  double score = 0.0;
  int trials = 0;
  // For estimators with IsInlier: inlier_mask[i] != 0 when point i is an
  // inlier of `model` (empty without a model or without IsInlier).
  std::vector<char> inlier_mask;
  size_t num_inliers = 0;
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

namespace internal {
template <typename E, typename = void>
struct HasIsInlier : std::false_type {};
template <typename E>
struct HasIsInlier<E, std::void_t<decltype(std::declval<const E&>().IsInlier(
                          std::declval<const typename E::Model&>(), size_t{0}))>> : std::true_type {
};
}  // namespace internal

// Runs options.max_trials trials. `initial` (if any) is scored first, so a
// good initial guess survives when no sample beats it.
template <typename Estimator>
RansacReport<typename Estimator::Model> Ransac(
    const Estimator& estimator, const std::vector<Eigen::Vector2d>& points,
    const std::vector<double>& weights, const RansacOptions& options, std::mt19937_64& rng,
    const std::optional<typename Estimator::Model>& initial = std::nullopt) {
  RansacReport<typename Estimator::Model> report;
  if (initial) {
    report.model = *initial;
    report.score = estimator.Score(*initial);
  }
  if (static_cast<int>(points.size()) >= Estimator::kSampleSize) {
    std::vector<double> cumulative(weights.size());
    double acc = 0;
    for (size_t i = 0; i < weights.size(); ++i) cumulative[i] = (acc += std::max(0.0, weights[i]));
    std::vector<Eigen::Vector2d> sample(Estimator::kSampleSize);
    std::vector<int> idx(Estimator::kSampleSize);
    for (int it = 0; it < options.max_trials; ++it) {
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
  }
  if constexpr (internal::HasIsInlier<Estimator>::value) {
    if (report.model) {
      report.inlier_mask.resize(points.size());
      for (size_t i = 0; i < points.size(); ++i) {
        report.inlier_mask[i] = estimator.IsInlier(*report.model, i) ? 1 : 0;
        report.num_inliers += report.inlier_mask[i];
      }
    }
  }
  return report;
}

}  // namespace lane

#endif  // LANE_RANSAC_H_
