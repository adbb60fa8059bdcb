// Synthetic road frames with exact ground truth, rendered through a camera
// model: painted markings on textured asphalt with shadows, occluding
// vehicles, sensor noise and JPEG artefacts.
#ifndef LANE_SYNTHETIC_H_
#define LANE_SYNTHETIC_H_

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "lane/camera.h"

namespace lane {

struct SyntheticOptions {
  // Number of lanes on the road (boundaries = lanes + 1). 0 = random in [1, 5].
  int num_lanes = 0;
  double lane_width_m = 3.6;
  // Curvature: radius is random with |R| >= min_radius_m; straight with
  // probability straight_probability.
  double min_radius_m = 150.0;
  double straight_probability = 0.4;
  // The road's heading relative to the camera's ground axis is uniform in
  // +-max_heading_rad (the car is never perfectly aligned with its lane).
  double max_heading_rad = 0.02;
  // Markings.
  double min_marking_width_m = 0.10;
  double max_marking_width_m = 0.15;
  double dashed_probability = 0.5;
  double yellow_probability = 0.25;
  // Clutter and degradations.
  int max_vehicles = 2;
  int max_shadows = 3;
  double noise_sigma = 4.0;  // grey levels
  int jpeg_quality = 80;     // 0 = no JPEG round trip
  // Ground truth covers the boundary from this far ahead (metres) ...
  double truth_near_m = 0.0;  // 0 = the bottom of the image
  // ... to this far ahead (metres).
  double truth_far_m = 40.0;
};

// One painted boundary of the rendered road.
struct SyntheticBoundary {
  std::array<Eigen::Vector2d, 4> image;  // Bezier control points, image pixels
  bool dashed = false;
  bool yellow = false;
  double lateral_offset_m = 0;  // at y = 0, metres (right +)
};

struct SyntheticFrame {
  cv::Mat bgr;  // CV_8UC3 of the camera's size
  std::vector<SyntheticBoundary> boundaries;
  int ego_left = -1;   // index of the ego lane's left boundary, or -1
  int ego_right = -1;  // index of the ego lane's right boundary, or -1
};

// Deterministic for a given camera, options and seed.
absl::StatusOr<SyntheticFrame> RenderSyntheticFrame(const CameraModel& camera,
                                                    const SyntheticOptions& options, uint64_t seed);


}  // namespace lane

#endif  // LANE_SYNTHETIC_H_
