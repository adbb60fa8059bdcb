#include "lane/eval/paper_rule.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "absl/strings/str_cat.h"
#include "lane/eval/curve_distances.h"

namespace lane::eval {

absl::Status PaperRuleOptions::Validate() const {
  if (!(median_px > 0) || !(mean_px > 0) || !std::isfinite(median_px) || !std::isfinite(mean_px)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "paper rule thresholds must be positive, got median ", median_px, " mean ", mean_px));
  }
  if (!(reference_width > 0)) {
    return absl::InvalidArgumentError("paper rule reference_width must be positive");
  }
  if (samples < 2) return absl::InvalidArgumentError("paper rule needs >= 2 samples per curve");
  return absl::OkStatus();
}

const char* RuleName(PaperRuleOptions::Rule rule) {
  return rule == PaperRuleOptions::Rule::kAnd ? "and" : "or";
}

const char* AssignmentName(PaperRuleOptions::Assignment assignment) {
  return assignment == PaperRuleOptions::Assignment::kOneToOne ? "one-to-one" : "many-to-one";
}

bool PassesPaperRule(double median, double mean, int image_width, const PaperRuleOptions& options) {
  const double scale = image_width / options.reference_width;
  const bool median_ok = median <= options.median_px * scale;
  const bool mean_ok = mean <= options.mean_px * scale;
  return options.rule == PaperRuleOptions::Rule::kAnd ? median_ok && mean_ok : median_ok || mean_ok;
}

Matching MatchPaperRule(const std::vector<Curve>& detections, const std::vector<Curve>& labels,
                        int image_width, const PaperRuleOptions& options) {
  Matching m;
  m.detection_label.assign(detections.size(), -1);
  m.label_detection.assign(labels.size(), -1);
  std::vector<std::vector<Eigen::Vector2d>> label_samples;
  label_samples.reserve(labels.size());
  for (const Curve& l : labels) label_samples.push_back(l.Sample(options.samples));

  struct Pair {
    double mean, median;
    int det, label;
  };
  std::vector<Pair> pairs;
  for (size_t d = 0; d < detections.size(); ++d) {
    const std::vector<Eigen::Vector2d> det_samples = detections[d].Sample(options.samples);
    for (size_t l = 0; l < labels.size(); ++l) {
      const MatchDistances dist = CurveMatchDistances(det_samples, label_samples[l]);
      if (PassesPaperRule(dist.median, dist.mean, image_width, options)) {
        pairs.push_back({dist.mean, dist.median, static_cast<int>(d), static_cast<int>(l)});
      }
    }
  }
  // Best first; ties broken by index so the result does not depend on sort
  // stability.
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    return std::tie(a.mean, a.median, a.det, a.label) < std::tie(b.mean, b.median, b.det, b.label);
  });
  const bool one_to_one = options.assignment == PaperRuleOptions::Assignment::kOneToOne;
  for (const Pair& p : pairs) {
    if (m.detection_label[p.det] >= 0) continue;  // this detection has its best label
    if (one_to_one && m.label_detection[p.label] >= 0) continue;
    m.detection_label[p.det] = p.label;
    if (m.label_detection[p.label] < 0) m.label_detection[p.label] = p.det;
  }
  return m;
}

}  // namespace lane::eval
