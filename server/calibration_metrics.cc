#include "calibration_metrics.h"

#include <string>

namespace lane::server {
namespace {

prometheus::ClientMetric Gauge(double value, std::vector<prometheus::ClientMetric::Label> labels) {
  prometheus::ClientMetric metric;
  metric.label = std::move(labels);
  metric.gauge.value = value;
  return metric;
}

}  // namespace

std::vector<prometheus::MetricFamily> CalibrationMetrics::Collect() const {
  prometheus::MetricFamily drift;
  drift.name = "lanesvc_calibration_drift_degrees";
  drift.help =
      "Online calibration: the refined camera's pitch or yaw minus the session's configured "
      "one, per auto-calibrating session.";
  drift.type = prometheus::MetricType::Gauge;
  prometheus::MetricFamily confidence;
  confidence.name = "lanesvc_calibration_confidence";
  confidence.help = "Online calibration: confidence of the refined camera, 0..1.";
  confidence.type = prometheus::MetricType::Gauge;
  for (const SessionRegistry::Entry& entry : sessions_.List()) {
    const Session& s = *entry.session;
    if (!s.calibration.auto_calibrate) continue;
    const CalibrationSnapshot c = s.Calibration();
    drift.metric.push_back(Gauge(c.drift_pitch_deg, {{"camera", s.camera_id}, {"axis", "pitch"}}));
    drift.metric.push_back(Gauge(c.drift_yaw_deg, {{"camera", s.camera_id}, {"axis", "yaw"}}));
    confidence.metric.push_back(Gauge(c.confidence, {{"camera", s.camera_id}}));
  }
  return {drift, confidence};
}

}  // namespace lane::server
