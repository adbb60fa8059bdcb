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
// refit uses exactly the inliers the score counted. For the adaptive stop
// (RansacOptions::confidence), optionally
//   double SupportFraction(const Model& model) const;    // in [0, 1]
// the share of the points' total weight that supports `model`.
//
// Points are drawn without replacement with probability proportional to
// their weight (the thresholded filter response), as the paper prescribes.
#ifndef LANE_RANSAC_H_
#define LANE_RANSAC_H_

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
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
  // Trials (samples drawn and scored), at most. The paper's 40 for lines
  // and splines in all-lanes mode; fewer samples than kSampleSize end the
  // loop early. 0: no sample is drawn, only a given initial model is scored.
  int iterations = 40;
  // Adaptive stop (Fischler and Bolles; Hartley and Zisserman, Algorithm
  // 4.5): with a best model whose support is a share e of the weight, a
  // weighted sample of kSampleSize points is all support with probability
  // about e^kSampleSize, so N = log(1 - confidence) / log(1 - e^kSampleSize)
  // trials draw at least one such sample with that confidence. The loop ends
  // once it has run max(min_iterations, N) trials, and never more than
  // iterations. 0 turns it off: always `iterations`. Needs the estimator's
  // SupportFraction.
  double confidence = 0.0;
  int min_iterations = 1;

  // OK, or INVALID_ARGUMENT naming the field as `where`.field (the config
  // file's names): iterations in 0..10000, confidence in [0, 1),
  // min_iterations in 1..10000 and at most iterations.
  absl::Status Validate(absl::string_view where = "ransac") const {
    if (iterations < 0 || iterations > 10000) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ".iterations must lie in 0..10000, got ", iterations));
    }
    if (!(confidence >= 0 && confidence < 1)) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ".confidence must lie in [0, 1), got ", confidence));
    }
    if (min_iterations < 1 || min_iterations > 10000) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ".min_iterations must lie in 1..10000, got ", min_iterations));
    }
    if (iterations > 0 && min_iterations > iterations) {
      return absl::InvalidArgumentError(absl::StrCat(where, ".min_iterations (", min_iterations,
                                                     ") must not exceed iterations (", iterations,
                                                     ")"));
    }
    return absl::OkStatus();
  }
};

// The trials the adaptive stop asks for: log(1 - confidence) / log(1 - e^s),
// rounded up, for support share e and sample size s; `cap` when e^s is too
// small to matter (or confidence is 0).
inline int AdaptiveTrials(double confidence, double support, int sample_size, int cap) {
  if (!(confidence > 0)) return cap;
  const double all_support = std::pow(std::clamp(support, 0.0, 1.0), sample_size);
  if (all_support >= 1.0) return 1;
  if (!(all_support > 1e-12)) return cap;
  const double n = std::ceil(std::log(1.0 - confidence) / std::log1p(-all_support));
  return n >= cap ? cap : std::max(1, static_cast<int>(n));
}

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

namespace internal {
// std::upper_bound(a, a + n, x) - a: the first index whose value exceeds x
// (n if none), for a sorted `a`. Without branches on the comparisons (a
// conditional move per halving): the draws of the RANSAC samples land
// anywhere in the cumulative weights, so the library's branching search
// mispredicted at every step.
inline int UpperBoundIndex(const double* a, int n, double x) {
  if (n <= 0) return 0;
  const double* base = a;
  // The answer lies in [base - a, base - a + n]; each step halves n.
  while (n > 1) {
    const int half = n / 2;
    base = x < base[half] ? base : base + half;
    n -= half;
  }
  return static_cast<int>(base - a) + (x < *base ? 0 : 1);
}
}  // namespace internal

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
    const int idx = std::min(internal::UpperBoundIndex(cumulative.data(), n, r), n - 1);
    if (std::find(out.begin(), out.begin() + have, idx) == out.begin() + have) out[have++] = idx;
  }
  return have == k;
}

namespace internal {
template <typename E, typename = void>
struct HasSupportFraction : std::false_type {};
template <typename E>
struct HasSupportFraction<E, std::void_t<decltype(std::declval<const E&>().SupportFraction(
                                 std::declval<const typename E::Model&>()))>> : std::true_type {};
template <typename E, typename = void>
struct HasIsInlier : std::false_type {};
template <typename E>
struct HasIsInlier<E, std::void_t<decltype(std::declval<const E&>().IsInlier(
                          std::declval<const typename E::Model&>(), size_t{0}))>> : std::true_type {
};
}  // namespace internal

// Runs options.iterations trials, or fewer with the adaptive stop. `initial`
// (if any) is scored first, so a good initial guess survives when no sample
// beats it. report.trials counts the trials run.
template <typename Estimator>
RansacReport<typename Estimator::Model> Ransac(
    const Estimator& estimator, const std::vector<Eigen::Vector2d>& points,
    const std::vector<double>& weights, const RansacOptions& options, std::mt19937_64& rng,
    const std::optional<typename Estimator::Model>& initial = std::nullopt) {
  RansacReport<typename Estimator::Model> report;
  // Trials the adaptive stop asks for, updated when the best model changes.
  int needed = options.iterations;
  const auto update_needed = [&] {
    if constexpr (internal::HasSupportFraction<Estimator>::value) {
      if (options.confidence > 0 && report.model) {
        needed = AdaptiveTrials(options.confidence, estimator.SupportFraction(*report.model),
                                Estimator::kSampleSize, options.iterations);
      }
    }
  };
  if (initial) {
    report.model = *initial;
    report.score = estimator.Score(*initial);
    update_needed();
  }
  if (static_cast<int>(points.size()) >= Estimator::kSampleSize) {
    std::vector<double> cumulative(weights.size());
    double acc = 0;
    for (size_t i = 0; i < weights.size(); ++i) cumulative[i] = (acc += std::max(0.0, weights[i]));
    std::vector<Eigen::Vector2d> sample(Estimator::kSampleSize);
    std::vector<int> idx(Estimator::kSampleSize);
    for (int it = 0; it < options.iterations; ++it) {
      if (it >= options.min_iterations && it >= needed) break;
      ++report.trials;
      if (!WeightedSample(cumulative, idx, rng)) break;
      for (int j = 0; j < Estimator::kSampleSize; ++j) sample[j] = points[idx[j]];
      const auto model = estimator.Estimate(sample);
      if (!model) continue;
      const double score = estimator.Score(*model);
      if (!report.model || score > report.score) {
        report.model = *model;
        report.score = score;
        update_needed();
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
