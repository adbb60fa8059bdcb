// The detector's configuration file: calibration, IPM and detector options in
// one JSON document. Every key is optional; missing keys keep their defaults.
// The format, every key, is documented in docs/config.md.
#ifndef LANE_CONFIG_H_
#define LANE_CONFIG_H_

#include <cstddef>
#include <string>

#include "absl/status/statusor.h"
#include "lane/detector/detector.h"
#include "lane/geometry/camera.h"
#include "lane/geometry/ipm.h"

namespace lane {

struct Config {
  CameraModel camera;
  IpmOptions ipm;
  DetectorOptions detector;

  absl::Status Validate() const;
};

// Limits on a config document, checked before it is parsed: configs are a few
// kB and nest 4 levels deep (sections, subsections, lists, values), so these leave
// ample room while keeping every walk of client data shallow and short.
inline constexpr size_t kMaxConfigBytes = size_t{1} << 20;
inline constexpr int kMaxConfigDepth = 16;

// Parses a JSON document. Larger or deeper documents than the limits above
// are INVALID_ARGUMENT before parsing. `mode` in the document (if present) selects the
// mode's defaults before the other detector keys are applied. A document that
// gives "camera" and no "ipm" gets the top view the camera needs (BuiltInIpm,
// lane/geometry/ground_view_rule.h; INVALID_ARGUMENT when the camera sees no
// road). Unknown keys are an error (they are usually typos). INVALID_ARGUMENT
// names the key.
absl::StatusOr<Config> ParseConfig(const std::string& json_text);
absl::StatusOr<Config> LoadConfigFile(const std::string& path);
// The full document for a config, every key present.
std::string ConfigToJson(const Config& config);

}  // namespace lane

#endif  // LANE_CONFIG_H_
