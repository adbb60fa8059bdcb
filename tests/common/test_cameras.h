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

}  // namespace lane::testing

#endif  // LANE_TESTS_CORE_TEST_CAMERAS_H_
