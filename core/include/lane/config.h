// The detector's configuration file: calibration, IPM and detector options in
// one JSON document. Every key is optional; missing keys keep their defaults.
// The format is documented in README.md ("Configuration file").
#ifndef LANE_CONFIG_H_
#define LANE_CONFIG_H_

#include <string>

#include "absl/status/statusor.h"
#include "lane/camera.h"
#include "lane/detector.h"
#include "lane/ipm.h"

namespace lane {

struct Config {
  CameraModel camera;
  IpmOptions ipm;
  DetectorOptions detector;

  absl::Status Validate() const;
};

// Parses a JSON document. `mode` in the document (if present) selects the
// mode's defaults before the other detector keys are applied. Unknown keys
// are an error (they are usually typos). INVALID_ARGUMENT names the key.
absl::StatusOr<Config> ParseConfig(const std::string& json_text);
absl::StatusOr<Config> LoadConfigFile(const std::string& path);
// The full document for a config, every key present.
std::string ConfigToJson(const Config& config);

}  // namespace lane

#endif  // LANE_CONFIG_H_
