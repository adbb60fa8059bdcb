// Latency summaries and timelines of `lane-client bench`.
#include <algorithm>
#include <cmath>
#include <vector>

#include "bench.h"

namespace lane::client {

LatencySummary Summarize(std::vector<double>& values) {
  LatencySummary s;
  s.count = values.size();
  if (values.empty()) return s;
  std::sort(values.begin(), values.end());
  const auto rank = [&values](double p) {
    const double r = std::ceil(p / 100.0 * static_cast<double>(values.size()));
    const size_t index = static_cast<size_t>(std::max(1.0, r)) - 1;
    return values[std::min(index, values.size() - 1)];
  };
  s.min = values.front();
  s.p50 = rank(50);
  s.p90 = rank(90);
  s.p95 = rank(95);
  s.p99 = rank(99);
  s.p999 = rank(99.9);
  s.max = values.back();
  double sum = 0;
  for (double v : values) sum += v;
  s.mean = sum / static_cast<double>(values.size());
  return s;
}

double LatencyHistogram::Edge(int i) {
  return kHistogramMinMs *
         std::pow(kHistogramMaxMs / kHistogramMinMs, static_cast<double>(i - 1) / kHistogramBins);
}

LatencyHistogram Histogram(const std::vector<double>& values) {
  LatencyHistogram h;
  h.counts.assign(kHistogramBins + 2, 0);
  const double span = std::log(kHistogramMaxMs / kHistogramMinMs);
  for (double v : values) {
    int bin = 0;
    if (v >= kHistogramMaxMs) {
      bin = kHistogramBins + 1;
    } else if (v >= kHistogramMinMs) {
      bin = 1 + static_cast<int>(std::log(v / kHistogramMinMs) / span * kHistogramBins);
      bin = std::min(bin, kHistogramBins);
    }
    ++h.counts[static_cast<size_t>(bin)];
  }
  return h;
}

std::vector<TimelinePoint> Timeline(const std::vector<double>& latency_ms,
                                    const std::vector<float>& ok_at_s,
                                    const std::vector<float>& error_at_s, double interval_s,
                                    double measured_s) {
  std::vector<TimelinePoint> points;
  if (interval_s <= 0 || measured_s <= 0) return points;
  const size_t n = static_cast<size_t>(std::ceil(measured_s / interval_s - 1e-9));
  points.resize(std::max<size_t>(n, 1));
  for (size_t i = 0; i < points.size(); ++i) {
    points[i].start_s = static_cast<double>(i) * interval_s;
    points[i].end_s = std::min(measured_s, static_cast<double>(i + 1) * interval_s);
  }
  // Answers after the window (the drain) count in the last interval.
  const auto bucket = [&](float t) {
    const double k = std::floor(std::max(0.0, static_cast<double>(t)) / interval_s);
    return std::min(points.size() - 1, static_cast<size_t>(k));
  };
  std::vector<std::vector<double>> values(points.size());
  for (size_t i = 0; i < latency_ms.size() && i < ok_at_s.size(); ++i) {
    values[bucket(ok_at_s[i])].push_back(latency_ms[i]);
  }
  for (const float t : error_at_s) ++points[bucket(t)].errors;
  for (size_t i = 0; i < points.size(); ++i) {
    points[i].ok = values[i].size();
    points[i].latency_ms = Summarize(values[i]);
  }
  return points;
}

}  // namespace lane::client
