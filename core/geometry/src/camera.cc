#include "lane/geometry/camera.h"

#include <Eigen/Dense>
#include <cmath>

#include "absl/strings/str_cat.h"

namespace lane {
namespace {

struct Trig {
  double c1, s1, c2, s2;  // cos/sin of pitch (1) and yaw (2)
};

// The transforms run thousands of times per frame for one camera: the last
// angles' sines and cosines are kept per thread (the same values, computed
// once; a CameraModel is a plain struct whose angles may change).
Trig MakeTrig(const CameraModel& cam) {
  thread_local double pitch = std::nan(""), yaw = std::nan("");
  thread_local Trig trig;
  if (cam.pitch_deg != pitch || cam.yaw_deg != yaw) {
    const double a = cam.pitch_deg * kDegToRad;
    const double b = cam.yaw_deg * kDegToRad;
    trig = {std::cos(a), std::sin(a), std::cos(b), std::sin(b)};
    pitch = cam.pitch_deg;
    yaw = cam.yaw_deg;
  }
  return trig;
}

}  // namespace

absl::Status CameraModel::Validate() const {
  const double values[] = {fu, fv, cu, cv, pitch_deg, yaw_deg, height_m};
  const char* names[] = {"fu", "fv", "cu", "cv", "pitch_deg", "yaw_deg", "height_m"};
  for (int i = 0; i < 7; ++i) {
    if (!std::isfinite(values[i])) {
      return absl::InvalidArgumentError(
          absl::StrCat("camera.", names[i], " must be a finite number, got ", values[i]));
    }
  }
  if (fu <= 0 || fv <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("camera focal lengths must be > 0 pixels, got fu=", fu, " fv=", fv));
  }
  if (std::abs(pitch_deg) >= 90.0) {
    return absl::InvalidArgumentError(
        absl::StrCat("camera.pitch_deg must lie in (-90, 90) degrees, got ", pitch_deg));
  }
  if (std::abs(yaw_deg) >= 90.0) {
    return absl::InvalidArgumentError(
        absl::StrCat("camera.yaw_deg must lie in (-90, 90) degrees, got ", yaw_deg));
  }
  if (height_m <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("camera.height_m must be > 0 metres, got ", height_m));
  }
  if (image_width <= 0 || image_height <= 0 || image_width > 16384 || image_height > 16384) {
    return absl::InvalidArgumentError(absl::StrCat("camera image size must be in 1..16384, got ",
                                                   image_width, "x", image_height));
  }
  return absl::OkStatus();
}

Eigen::Vector2d CameraModel::GroundToImage(const Eigen::Vector2d& ground) const {
  // Paper, section II-A: i_gT applied to (x, y, -h, 1), then the homogeneous
  // part is divided out. The fourth row equals the third and is not needed.
  const Trig t = MakeTrig(*this);
  Eigen::Matrix3d m;
  m << fu * t.c2 + cu * t.c1 * t.s2, cu * t.c1 * t.c2 - t.s2 * fu, -cu * t.s1,  //
      t.s2 * (cv * t.c1 - fv * t.s1), t.c2 * (cv * t.c1 - fv * t.s1), -fv * t.c1 - cv * t.s1,
      t.c1 * t.s2, t.c1 * t.c2, -t.s1;
  const Eigen::Vector3d p = m * Eigen::Vector3d(ground.x(), ground.y(), -height_m);
  return {p.x() / p.z(), p.y() / p.z()};
}

Eigen::Vector2d CameraModel::ImageToGround(const Eigen::Vector2d& image) const {
  // Paper, section II-A: g_iT applied to (u, v, 1, 1), then divided by the
  // fourth (homogeneous) coordinate. Rows 1, 2 and 4 give x, y and w.
  const Trig t = MakeTrig(*this);
  const double h = height_m;
  const double u = image.x();
  const double v = image.y();
  const double x = h * (-t.c2 / fu * u + t.s1 * t.s2 / fv * v +
                        (cu * t.c2 / fu - cv * t.s1 * t.s2 / fv - t.c1 * t.s2));
  // The paper prints s1*c1 in row 2 where inverting i_gT gives s1*c2: a typo
  // (with c1 the round trip is off by up to a pixel even at zero yaw).
  const double y = h * (t.s2 / fu * u + t.s1 * t.c2 / fv * v +
                        (-cu * t.s2 / fu - cv * t.s1 * t.c2 / fv - t.c1 * t.c2));
  const double w = h * (-t.c1 / (h * fv) * v + (cv * t.c1 / (h * fv) - t.s1 / h));
  return {x / w, y / w};
}

double CameraModel::HorizonRow() const {
  thread_local double pitch = std::nan(""), tan_pitch = 0;
  if (pitch_deg != pitch) {
    tan_pitch = std::tan(pitch_deg * kDegToRad);
    pitch = pitch_deg;
  }
  return cv - fv * tan_pitch;
}

Eigen::Vector2d CameraModel::VanishingPoint() const {
  const double a = pitch_deg * kDegToRad;
  const double b = yaw_deg * kDegToRad;
  return {cu - fu * std::tan(b) / std::cos(a), HorizonRow()};
}

}  // namespace lane
