// The report of `lane-client bench`: text, CSV, JSON or a self-contained HTML
// page (the fields are in docs/client.md). CSV has a row per run with the
// same fields as the JSON's runs, flattened (latency_ms.p99 -> latency_p99_ms).
#ifndef LANE_CLIENT_BENCH_REPORT_H_
#define LANE_CLIENT_BENCH_REPORT_H_

#include <optional>
#include <string>
#include <vector>

#include "bench.h"

namespace lane::client {

inline constexpr int kBenchReportSchema = 1;

struct FramesInfo {
  std::string source;    // "synthetic" or "inputs"
  std::string encoding;  // "jpeg", "png", "raw" or "mixed"
  double mean_bytes = 0;
  int width = 0;
  int height = 0;
};

// Where and how the run was made.
struct RunMetadata {
  std::string date_utc;        // ISO 8601, when the report was made
  std::string client_version;  // lane-client's version and git revision
  std::string server_version;  // GetServerInfo's version and build, or "unknown"
  std::string command_line;
  std::string machine;  // host name, cores, kernel
};
// The metadata of this process and machine; the server's is filled by the
// caller.
RunMetadata LocalMetadata();

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
  RunMetadata meta;
  // Print the runs' timelines (--timeline); they may be computed anyway for
  // the warnings and the HTML page.
  bool show_timeline = false;

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
  // The servers' CPU per frame over the in-process reference's.
  std::optional<double> CpuRatio(const LoadResult& run) const {
    if (!inprocess || inprocess->cpu_ms_per_frame <= 0 || run.server_cpu_ms_per_frame <= 0) {
      return std::nullopt;
    }
    return run.server_cpu_ms_per_frame / inprocess->cpu_ms_per_frame;
  }
};

// Why a run's figures may not be trusted: a service/in-process ratio over
// 100 %, throughput or latency that moved between timeline intervals, too few
// frames for the tail percentiles. Empty when none.
std::vector<std::string> Warnings(const Report& r, const LoadResult& run);

std::string JsonReport(const Report& r);
std::string CsvReport(const Report& r);
std::string TextReport(const Report& r);
// One page with no external resources: metadata, the percentiles, errors by
// code, the server's split, and per run the latency over time and its
// histogram as inline SVG (bench_html.cc).
std::string HtmlReport(const Report& r);

}  // namespace lane::client

#endif  // LANE_CLIENT_BENCH_REPORT_H_
