#include "lane/eval/seeds.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

namespace lane::eval {
namespace {

ClipSpread SpreadOf(const std::vector<const ClipCounts*>& runs) {
  ClipSpread out;
  if (runs.empty()) return out;
  out.clip = runs.front()->clip;
  const auto over = [&](const std::function<double(const ClipCounts&)>& figure) {
    std::vector<double> values;
    values.reserve(runs.size());
    for (const ClipCounts* c : runs) values.push_back(figure(*c));
    return Spread::Of(values);
  };
  out.detected = over([](const ClipCounts& c) { return c.paper.detections; });
  out.correct_rate = over([](const ClipCounts& c) { return c.paper.CorrectRate(); });
  out.false_positive_rate = over([](const ClipCounts& c) { return c.paper.FalsePositiveRate(); });
  out.fp_per_frame =
      over([](const ClipCounts& c) { return c.paper.FalsePositivesPerFrame(c.frames); });
  out.paper_precision = over([](const ClipCounts& c) { return c.paper.Precision(); });
  out.paper_f1 = over([](const ClipCounts& c) { return c.paper.F1(); });
  out.culane_precision = over([](const ClipCounts& c) { return c.culane.Precision(); });
  out.culane_recall = over([](const ClipCounts& c) { return c.culane.Recall(); });
  out.culane_f1 = over([](const ClipCounts& c) { return c.culane.F1(); });
  return out;
}

}  // namespace

Spread Spread::Of(const std::vector<double>& values) {
  Spread s;
  double sum = 0;
  s.min = std::numeric_limits<double>::infinity();
  s.max = -std::numeric_limits<double>::infinity();
  for (double v : values) {
    if (std::isnan(v)) continue;
    ++s.n;
    sum += v;
    s.min = std::min(s.min, v);
    s.max = std::max(s.max, v);
  }
  if (s.n == 0) {
    s.mean = s.std = s.min = s.max = std::numeric_limits<double>::quiet_NaN();
    return s;
  }
  s.mean = sum / s.n;
  double ss = 0;
  for (double v : values) {
    if (!std::isnan(v)) ss += (v - s.mean) * (v - s.mean);
  }
  s.std = s.n > 1 ? std::sqrt(ss / (s.n - 1)) : 0.0;
  return s;
}

SeedSummary SummariseSeeds(const std::vector<EvalReport>& reports,
                           const std::vector<uint64_t>& seeds) {
  SeedSummary out;
  out.seeds = seeds;
  if (reports.empty()) return out;
  for (size_t k = 0; k < reports.front().clips.size(); ++k) {
    std::vector<const ClipCounts*> runs;
    for (const EvalReport& r : reports) {
      if (k < r.clips.size()) runs.push_back(&r.clips[k]);
    }
    out.clips.push_back(SpreadOf(runs));
  }
  std::vector<const ClipCounts*> totals;
  for (const EvalReport& r : reports) totals.push_back(&r.total);
  out.total = SpreadOf(totals);
  return out;
}

}  // namespace lane::eval
