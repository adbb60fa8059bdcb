// Per-session calibration gauges, read from the session registry when
// scraped (sessions with calibration.auto_calibrate only, so at most
// --max_sessions cameras):
//
//   lanesvc_calibration_drift_degrees{camera, axis="pitch"|"yaw"}
//       the refined camera minus the session's configured one
//   lanesvc_calibration_confidence{camera}
//       CalibrationState.confidence, 0..1
//
// Deleted and replaced sessions leave no stale series: nothing is stored.
#ifndef LANE_SERVER_CALIBRATION_METRICS_H_
#define LANE_SERVER_CALIBRATION_METRICS_H_

#include <prometheus/collectable.h>
#include <prometheus/metric_family.h>

#include <vector>

#include "session_registry.h"

namespace lane::server {

class CalibrationMetrics final : public prometheus::Collectable {
 public:
  // `sessions` must outlive this (the server stops its HTTP endpoint first).
  explicit CalibrationMetrics(const SessionRegistry& sessions) : sessions_(sessions) {}
  std::vector<prometheus::MetricFamily> Collect() const override;

 private:
  const SessionRegistry& sessions_;
};

}  // namespace lane::server

#endif  // LANE_SERVER_CALIBRATION_METRICS_H_
