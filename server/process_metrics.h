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

class ProcessMetrics final : public prometheus::Collectable {
 public:
  std::vector<prometheus::MetricFamily> Collect() const override;
};

}  // namespace lane::server

#endif  // LANE_SERVER_PROCESS_METRICS_H_
