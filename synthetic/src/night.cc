// The rendered night (SyntheticOptions::night): the light model measured on
// a CULane night clip (Night, scene.h), sampled per frame, and the day
// image relit by it.
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "scene.h"

namespace lane::synthetic_internal {

double NightAxisGrey(double y, double unlit) {
  // The beam's part (grey above the measured unlit 17) at these distances.
  static constexpr double kY[] = {0, 3, 6, 8, 10, 12, 15, 20, 30, 40, 60};
  static constexpr double kBeam[] = {0, 45, 90, 115, 130, 138, 138, 107, 65, 35, 21};
  constexpr int kN = sizeof(kY) / sizeof(kY[0]);
  if (!(y > 0)) return unlit;
  if (y >= kY[kN - 1]) return unlit + kBeam[kN - 1] * std::pow(kY[kN - 1] / y, 2);
  int i = 1;
  while (y > kY[i]) ++i;
  const double t = (y - kY[i - 1]) / (kY[i] - kY[i - 1]);
  return unlit + kBeam[i - 1] + t * (kBeam[i] - kBeam[i - 1]);
}

double NightPaintFactor(double y) {
  constexpr double kFrom = 45, kTo = 60, kFar = 0.75;
  if (y <= kFrom) return 1.0;
  if (y >= kTo) return kFar;
  return 1.0 - (1.0 - kFar) * (y - kFrom) / (kTo - kFrom);
}

double NightGrey(double d, double g) {
  g = std::clamp(g, 0.0, 254.0);
  const double q = g / (255.0 - g) * std::pow(std::max(d, 0.0) / 100.0, kNightGamma);
  return 255.0 * q / (1.0 + q);
}

double Night::GroundLight(double x, double y) const {
  double g = unlit;
  if (y > 0) {
    const double sigma = std::hypot(y * std::tan(pool_sigma_deg * kDegToRad), kNightLampSpreadM);
    const double across = (x - y * std::tan(pool_centre_deg * kDegToRad)) / sigma;
    g += pool_gain * (NightAxisGrey(y, unlit) - unlit) * std::exp(-0.5 * across * across);
  }
  for (const Lamp& l : lamps) {
    const double d2 = (x - l.x) * (x - l.x) + (y - l.y) * (y - l.y);
    g += l.gain * std::exp(-0.5 * d2 / (l.radius_m * l.radius_m));
  }
  return std::min(g, 250.0);
}

Night SampleNight(const CameraModel& cam, const Road& road, Rng& rng) {
  Night n;
  n.on = true;
  n.unlit = Uniform(rng, 15.0, 19.0);
  n.sky = Uniform(rng, 5.0, 10.0);
  n.pool_gain = Uniform(rng, 0.95, 1.05);
  n.pool_sigma_deg = Uniform(rng, 6.1, 7.6);
  n.pool_centre_deg = Uniform(rng, 0.5, 1.1);
  // Street lamps beside the asphalt, lighting stretches 15-60 m ahead.
  const int lamps = UniformInt(rng, 0, 2);
  for (int i = 0; i < lamps; ++i) {
    Night::Lamp l;
    const bool left = Chance(rng, 0.5);
    l.y = Uniform(rng, 15.0, 60.0);
    l.x = BesideRoad(road, left, l.y, Uniform(rng, 0.5, 2.0));
    l.radius_m = Uniform(rng, 4.0, 6.0);
    l.gain = Uniform(rng, 24.0, 32.0);
    l.height_m = Uniform(rng, 7.0, 10.0);
    n.lamps.push_back(l);
  }
  // Glare above the horizon: areas log-uniform from 20 to 2,200 px at
  // 1640x590, scaled by the image's area.
  const double horizon = cam.HorizonRow();
  const double area_scale =
      static_cast<double>(cam.image_width) * cam.image_height / (1640.0 * 590.0);
  const double top = std::max(0.0, horizon - 0.35 * cam.image_height);
  const int blobs = horizon > 4.0 ? UniformInt(rng, 4, 19) : 0;
  for (int i = 0; i < blobs; ++i) {
    Night::Glare g;
    const double area = area_scale * std::exp(Uniform(rng, std::log(20.0), std::log(2200.0)));
    g.round = Chance(rng, 0.5);
    const double aspect = g.round ? Uniform(rng, 0.7, 1.4) : Uniform(rng, 1.5, 5.0);
    // Ellipse area pi a b; rectangle 4 a b.
    const double ab = area / (g.round ? kPi : 4.0);
    g.half_w = std::sqrt(ab * aspect);
    g.half_h = std::sqrt(ab / aspect);
    g.at = {Uniform(rng, 0.0, cam.image_width - 1.0),
            Uniform(rng, top, std::max(top, horizon - g.half_h - 1.0))};
    n.glare.push_back(g);
  }
  // Oncoming headlights on the horizon.
  const int count = UniformInt(rng, 0, 3);
  for (int i = 0; i < count; ++i) {
    Night::Light l;
    l.at = {Uniform(rng, 0.0, cam.image_width - 1.0),
            horizon + Uniform(rng, 0.0, 0.02 * cam.image_height)};
    l.radius = Uniform(rng, 1.5, 4.0) * cam.image_width / 640.0;
    n.lights.push_back(l);
  }
  return n;
}

// Relights a day image for the night (Night's response): ground pixels by
// the light on the ground there (low beams, street lamps, the unlit road's
// level), their paint's contrast faded with the distance
// (NightPaintFactor); the sky and the hood (HoodRow) by the sky's light.
// Then the glare, the lamps' heads and the oncoming headlights, saturated.
void ApplyNight(const CameraModel& cam, const SyntheticOptions& options, const Night& night,
                const Look& look, cv::Mat& img) {
  const double horizon = cam.HorizonRow();
  cv::Mat3f f;
  img.convertTo(f, CV_32FC3);
  std::vector<double> hood_top(f.cols);
  for (int u = 0; u < f.cols; ++u) hood_top[u] = HoodRow(cam, options, u);
  for (int v = 0; v < f.rows; ++v) {
    cv::Vec3f* row = f.ptr<cv::Vec3f>(v);
    for (int u = 0; u < f.cols; ++u) {
      double light = night.sky;
      double paint = 1.0;
      if (v > horizon + 0.5 && v < hood_top[u]) {
        const Eigen::Vector2d g =
            cam.ImageToGround({static_cast<double>(u), static_cast<double>(v)});
        if (g.allFinite() && g.y() > 0) {
          light = night.GroundLight(g.x(), g.y());
          paint = NightPaintFactor(g.y());
        }
      }
      for (int c = 0; c < 3; ++c) {
        const double day = look.asphalt + (row[u][c] - look.asphalt) * paint;
        row[u][c] = static_cast<float>(NightGrey(day, light));
      }
    }
  }
  const cv::Scalar white(255, 255, 255), halo(70, 75, 80);
  for (const Night::Glare& g : night.glare) {
    const cv::Point c = Fp(g.at.x(), g.at.y());
    if (g.round) {
      cv::ellipse(f, c, cv::Size(cvRound(2 * g.half_w * 16), cvRound(2 * g.half_h * 16)), 0, 0, 360,
                  halo, cv::FILLED, cv::LINE_AA, kShift);
      cv::ellipse(f, c, cv::Size(cvRound(g.half_w * 16), cvRound(g.half_h * 16)), 0, 0, 360, white,
                  cv::FILLED, cv::LINE_AA, kShift);
    } else {
      const double m = std::min(g.half_w, g.half_h);
      FillRect(f, g.at.x() - g.half_w - m, g.at.y() - g.half_h - m, g.at.x() + g.half_w + m,
               g.at.y() + g.half_h + m, halo);
      FillRect(f, g.at.x() - g.half_w, g.at.y() - g.half_h, g.at.x() + g.half_w,
               g.at.y() + g.half_h, white);
    }
  }
  for (const Night::Lamp& l : night.lamps) {
    if (Depth(cam, l.x, l.y, l.height_m) < 1.0) continue;
    const Eigen::Vector2d head = Project(cam, l.x, l.y, l.height_m);
    const double r = std::max(1.0, 0.3 * cam.fu / Depth(cam, l.x, l.y, l.height_m));
    cv::circle(f, Fp(head.x(), head.y()), cvRound(3.0 * r * 16), halo, cv::FILLED, cv::LINE_AA,
               kShift);
    cv::circle(f, Fp(head.x(), head.y()), cvRound(r * 16), white, cv::FILLED, cv::LINE_AA, kShift);
  }
  for (const Night::Light& l : night.lights) {
    cv::circle(f, Fp(l.at.x(), l.at.y()), cvRound(3.0 * l.radius * 16), halo, cv::FILLED,
               cv::LINE_AA, kShift);
    cv::circle(f, Fp(l.at.x(), l.at.y()), cvRound(l.radius * 16), cv::Scalar(235, 245, 255),
               cv::FILLED, cv::LINE_AA, kShift);
  }
  f.convertTo(img, CV_8UC3);
}

}  // namespace lane::synthetic_internal
