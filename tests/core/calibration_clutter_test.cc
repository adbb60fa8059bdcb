// Issue 35's clutter rules for `lane calibrate`'s estimator and self-check,
// over 50 random cameras (pitch -5..15 deg, yaw -5..5 deg, height
// 1.2..2.5 m), each on rendered frames with tree rows (white trunks half the
// time), extra trees, buildings and poles, signs, guardrails, up to three
// vehicles ahead, and boundaries whose paint is worn or gone:
//   * no estimate more than 10 px off passes the self-check (a config is
//     written only when it passes);
//   * at least 80 % of the cameras are calibrated within 3 px, the rest
//     refused with a reason;
//   * the 95 % interval covers the true error in at least 90 % of the
//     calibrated runs.
// About 45 s in the plain build; the ASan pass leaves it out.
// LANE_CLUTTER_SEED=N draws another 50 cameras (the interval's systematic
// term, kSystematicIntervalDeg, was measured with N = 777).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "lane/calibrate/calibration.h"
#include "lane/synthetic.h"
#include "test_cameras.h"

namespace lane {
namespace {

struct Outcome {
  bool calibrated = false;  // passed the estimator and the self-check
  double error_px = 0;
  bool covered = false;  // the true point inside the 95 % interval
  std::string reason;    // when refused
  Eigen::Vector2d interval = Eigen::Vector2d::Zero();
  LaneGeometryReport check;
  int curved = 0;
};

Outcome CalibrateCluttered(const CameraModel& truth, int frames, uint64_t seed) {
  SyntheticOptions so;
  so.max_heading_rad = 0.005;
  SetRoadsideClutter(&so);
  std::vector<cv::Mat> images;
  for (int i = 0; i < frames; ++i) {
    absl::StatusOr<SyntheticFrame> f = RenderSyntheticFrame(truth, so, seed + i);
    if (!f.ok()) {
      Outcome failed;
      failed.reason = std::string(f.status().message());
      return failed;
    }
    images.push_back(f->bgr);
  }
  CalibrationOptions o;
  o.height_m = truth.height_m;
  o.focal_px = truth.fu;
  o.lane_width_m = 3.6;
  CameraCalibrator calibrator(o);
  Outcome out;
  auto refuse = [&](const absl::Status& s) {
    out.reason = std::string(s.message());
    return out;
  };
  for (const cv::Mat& f : images) {
    if (absl::Status s = calibrator.AddFirstPass(f); !s.ok()) return refuse(s);
  }
  if (absl::Status s = calibrator.FinishFirstPass(); !s.ok()) return refuse(s);
  for (const cv::Mat& f : images) {
    if (absl::StatusOr<FrameVanishingPoint> p = calibrator.AddSecondPass(f); !p.ok()) {
      return refuse(p.status());
    }
  }
  const absl::StatusOr<CalibrationResult> r = calibrator.Finish();
  if (!r.ok()) return refuse(r.status());
  absl::StatusOr<CalibrationSelfCheck> check = CalibrationSelfCheck::Create(*r, o.lane_width_m);
  if (!check.ok()) return refuse(check.status());
  for (int k : r->used_frames) {
    if (absl::Status s = check->AddFrame(images[static_cast<size_t>(k)]); !s.ok()) return refuse(s);
  }
  const Eigen::Vector2d error = r->vanishing_point.point - truth.VanishingPoint();
  out.error_px = error.norm();
  out.covered =
      std::abs(error.x()) <= r->interval_px.x() && std::abs(error.y()) <= r->interval_px.y();
  const LaneGeometryReport report = check->Report();
  out.interval = r->interval_px;
  out.check = report;
  out.curved = r->frames_curved;
  if (!report.verdict.ok()) return refuse(report.verdict);
  out.calibrated = true;
  return out;
}

TEST(CalibrationClutterTest, FiftyRandomCamerasInClutter) {
  std::mt19937_64 rng(std::getenv("LANE_CLUTTER_SEED")
                          ? std::strtoull(std::getenv("LANE_CLUTTER_SEED"), nullptr, 10)
                          : 20261206);
  std::uniform_real_distribution<double> pitch(-5.0, 15.0), yaw(-5.0, 5.0), height(1.2, 2.5);
  constexpr int kCameras = 50, kFrames = 24;
  int calibrated = 0, within3 = 0, covered = 0, curved = 0;
  for (int k = 0; k < kCameras; ++k) {
    const CameraModel truth = testing::TestCamera(pitch(rng), yaw(rng), height(rng));
    const Outcome o = CalibrateCluttered(truth, kFrames, 100000 + 1000 * k);
    std::printf(
        "camera %2d pitch %6.2f yaw %5.2f height %.2f: %s error %5.2f px, interval +-(%.2f, "
        "%.2f)%s; check: heading %5.2f divergence %5.2f pairs %d of %d %s\n",
        k, truth.pitch_deg, truth.yaw_deg, truth.height_m,
        o.calibrated ? "calibrated" : "refused   ", o.error_px, o.interval.x(), o.interval.y(),
        o.covered ? " covers" : " misses", o.check.heading_deg, o.check.divergence_deg,
        o.check.frames_with_pair, o.check.frames, o.reason.c_str());
    curved += o.curved;
    if (!o.calibrated) {
      EXPECT_FALSE(o.reason.empty()) << "camera " << k << " refused without a reason";
      continue;
    }
    ++calibrated;
    EXPECT_LE(o.error_px, 10.0) << "camera " << k << ": a wrong camera would be written";
    within3 += o.error_px <= 3.0 ? 1 : 0;
    covered += o.covered ? 1 : 0;
  }
  std::printf("%d of %d calibrated, %d within 3 px, interval covers %d of %d\n", calibrated,
              kCameras, within3, covered, calibrated);
  EXPECT_GE(within3, kCameras * 8 / 10);
  EXPECT_GT(curved, 0);  // frames on curves are recognised and left out
  EXPECT_GE(covered, static_cast<int>(std::ceil(0.9 * calibrated)));
}

}  // namespace
}  // namespace lane
