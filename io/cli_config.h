// The effective configuration of a `lane` subcommand: a config file (or the
// defaults) and the --mode override.
#ifndef LANE_IO_CLI_CONFIG_H_
#define LANE_IO_CLI_CONFIG_H_

#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "lane/config/config.h"

namespace lane::io {

// Loads `path` (the built-in defaults when nullopt). With `mode` ("all" or
// "two"), the result is as if the file's "detector.mode" were `mode`: the
// mode's defaults (DetectorOptions::ForMode), then every other detector key
// of the file on top.
absl::StatusOr<lane::Config> LoadEffectiveConfig(const std::optional<std::string>& path,
                                                 const std::optional<std::string>& mode);

}  // namespace lane::io

#endif  // LANE_IO_CLI_CONFIG_H_
