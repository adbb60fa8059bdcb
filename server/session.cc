#include "session.h"

namespace lane::server {

std::shared_ptr<const lane::Detector> Session::CurrentDetector() const {
  if (calibration.auto_calibrate) {
    absl::MutexLock lock(&refine_mu_);
    if (refined_) return refined_;
  }
  // Not owned: the caller holds the session, which holds `detector`.
  return std::shared_ptr<const lane::Detector>(std::shared_ptr<const lane::Detector>(), &detector);
}

void Session::ObserveLanes(const std::vector<lane::Lane>& lanes) {
  if (!calibration.auto_calibrate) return;
  lane::CameraModel camera;
  uint64_t generation = 0;
  {
    absl::MutexLock lock(&refine_mu_);
    if (!calibrator_.Observe(lanes)) return;
    camera = calibrator_.camera();
    generation = ++refine_generation_;
  }
  // Expensive (the IPM maps): outside the lock. The top view is re-derived
  // from the same ipm options (a ground view keeps its rectangle on the
  // road; an image ROI stays where it is in the image).
  absl::StatusOr<lane::Detector> rebuilt =
      lane::Detector::Create(camera, config.ipm, config.detector);
  if (!rebuilt.ok()) return;  // keeps the detector in use
  auto shared = std::make_shared<const lane::Detector>(*std::move(rebuilt));
  absl::MutexLock lock(&refine_mu_);
  // A later re-derivation may have finished first.
  if (generation == refine_generation_) refined_ = std::move(shared);
}

CalibrationSnapshot Session::Calibration() const {
  absl::MutexLock lock(&refine_mu_);
  CalibrationSnapshot s;
  s.camera = calibrator_.camera();
  s.confidence = calibrator_.confidence();
  s.uncertainty_deg = calibrator_.frames_used() > 0 ? calibrator_.uncertainty_deg() : 0.0;
  s.frames_seen = static_cast<uint64_t>(calibrator_.frames_seen());
  s.frames_used = static_cast<uint64_t>(calibrator_.frames_used());
  s.drift_pitch_deg = calibrator_.drift_pitch_deg();
  s.drift_yaw_deg = calibrator_.drift_yaw_deg();
  s.rederived = static_cast<uint32_t>(calibrator_.rederived());
  s.refused = static_cast<uint32_t>(calibrator_.refused());
  s.last_refusal = std::string(calibrator_.last_refusal().message());
  return s;
}

uint64_t Session::epoch() const {
  absl::MutexLock lock(&epoch_mu_);
  return epoch_;
}

uint64_t Session::SealEpoch() {
  absl::MutexLock lock(&epoch_mu_);
  epoch_fixed_ = true;
  return epoch_;
}

bool Session::ContinueEpoch(uint64_t epoch) {
  absl::MutexLock lock(&epoch_mu_);
  if (epoch_fixed_) return epoch == epoch_;
  epoch_ = epoch;
  epoch_fixed_ = true;
  return true;
}

}  // namespace lane::server
