// Cameras shared by the core tests.
#ifndef LANE_TESTS_CORE_TEST_CAMERAS_H_
#define LANE_TESTS_CORE_TEST_CAMERAS_H_

#include <cstdio>
#include <cstdlib>

#include "lane/config/config.h"
#include "lane/geometry/camera.h"

namespace lane::testing {

// The camera of ../shared/data/culane-driver161-a (1640x590), as shipped in
// configs/culane-driver161.json, so the tests also check the shipped file.
inline CameraModel CulaneCamera() {
  const auto config = LoadConfigFile(LANE_SOURCE_DIR "/configs/culane-driver161.json");
  if (!config.ok()) {
    std::fprintf(stderr, "%s\n", config.status().ToString().c_str());
    std::abort();
  }
  return config->camera;
}

// The CULane-like night camera of configs/culane-night.json (1640x590,
// 1.23 m high, pitched 1.8 deg down, the hood's edge 6 m ahead), with its
// detector settings.
inline Config CulaneNightConfig() {
  const auto config = LoadConfigFile(LANE_SOURCE_DIR "/configs/culane-night.json");
  if (!config.ok()) {
    std::fprintf(stderr, "%s\n", config.status().ToString().c_str());
    std::abort();
  }
  return *config;
}

// A 640x480 camera with a 79 degree field of view (focal 390 px), for
// rendered frames.
inline CameraModel TestCamera(double pitch_deg, double yaw_deg, double height_m) {
  CameraModel c;
  c.image_width = 640;
  c.image_height = 480;
  c.fu = c.fv = 390.0;
  c.cu = 320.0;
  c.cv = 240.0;
  c.pitch_deg = pitch_deg;
  c.yaw_deg = yaw_deg;
  c.height_m = height_m;
  return c;
}

// Issue 49's held-out US highway camera: f = 730 px over a 512 px wide
// image, 1.67 m up, the road starting 6.7 m ahead at the image's bottom.
inline CameraModel HighwayCamera() {
  CameraModel c;
  c.image_width = 512;
  c.image_height = 288;
  c.fu = c.fv = 730.0;
  c.cu = 256.0;
  c.cv = 144.0;
  c.pitch_deg = 2.9;
  c.yaw_deg = 0.0;
  c.height_m = 1.67;
  return c;
}

}  // namespace lane::testing

#endif  // LANE_TESTS_CORE_TEST_CAMERAS_H_
