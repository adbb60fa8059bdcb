// The standard process_* metrics of Prometheus client libraries, read from
// /proc/self when scraped (Linux only):
//
//   process_cpu_seconds_total       user + system CPU time
//   process_resident_memory_bytes   resident set size
//   process_virtual_memory_bytes    virtual memory size
//   process_start_time_seconds      start time, seconds since the Unix epoch
//   process_open_fds                open file descriptors
//   process_max_fds                 the soft limit on them
#ifndef LANE_SERVER_PROCESS_METRICS_H_
#define LANE_SERVER_PROCESS_METRICS_H_

#include <prometheus/collectable.h>
#include <prometheus/metric_family.h>

#include <vector>

namespace lane::server {

// User + system CPU time of this process, seconds (process_cpu_seconds_total's
// value; ServerInfo.process_cpu_seconds), to 1/CLK_TCK; 0 when
// /proc/self/stat is unreadable.
double ProcessCpuSeconds();

class ProcessMetrics final : public prometheus::Collectable {
 public:
  std::vector<prometheus::MetricFamily> Collect() const override;
};

}  // namespace lane::server

#endif  // LANE_SERVER_PROCESS_METRICS_H_
