// The report of `lane-client bench`: text, CSV or JSON (the fields are in
// docs/client.md).
#ifndef LANE_CLIENT_BENCH_REPORT_H_
#define LANE_CLIENT_BENCH_REPORT_H_

#include <optional>
#include <string>
#include <vector>

#include "bench.h"

namespace lane_client {

inline constexpr int kBenchReportSchema = 1;

struct FramesInfo {
  std::string source;    // "synthetic" or "inputs"
  std::string encoding;  // "jpeg", "png", "raw" or "mixed"
  double mean_bytes = 0;
  int width = 0;
  int height = 0;
};

// What the frames are, for the report: `source` is "synthetic" or "inputs".
FramesInfo DescribeFrames(const std::vector<BenchFrame>& frames, const std::string& source);

struct Report {
  std::vector<std::string> targets;
  int connections = 1;
  bool connections_given = false;  // else one per camera
  bool open_loop = false;
  int inflight = 0;
  double fps = 0;
  double warmup_s = 0;
  double duration_s = 0;
  FramesInfo frames;
  std::vector<LoadResult> runs;
  std::optional<InprocessResult> inprocess;
  std::optional<double> slo_p99_ms;

  bool SloMet(const LoadResult& run) const {
    return !slo_p99_ms || (run.latency_ms.count > 0 && run.latency_ms.p99 <= *slo_p99_ms);
  }
  bool AllSloMet() const {
    for (const LoadResult& run : runs) {
      if (!SloMet(run)) return false;
    }
    return true;
  }
  std::optional<double> Ratio(const LoadResult& run) const {
    if (!inprocess || inprocess->fps <= 0) return std::nullopt;
    return run.achieved_fps / inprocess->fps;
  }
};

std::string JsonReport(const Report& r);
std::string CsvReport(const Report& r);
std::string TextReport(const Report& r);

}  // namespace lane_client

#endif  // LANE_CLIENT_BENCH_REPORT_H_
