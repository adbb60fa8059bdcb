// The session options shared by `session create`, `stream` and `bench`: a
// config file in the format of the `lane` command (docs/config.md), the
// detector mode, and the stream policy, as the proto SessionConfig.
#ifndef LANE_CLIENT_SESSION_CONFIG_H_
#define LANE_CLIENT_SESSION_CONFIG_H_

#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "io/command_line.h"
#include "lane/v1/lane_service.pb.h"

namespace lane::client {

struct SessionConfigFlags {
  std::optional<std::string> config;
  std::optional<std::string> mode;
  std::optional<std::string> backpressure;
  std::optional<uint32_t> max_inflight_frames;
  bool full_decode = false;
  bool auto_calibrate = false;
};

// --config FILE, --mode all|two, --backpressure block|drop_oldest,
// --max-inflight-frames N (old spelling --session-inflight), --full-decode,
// --auto-calibrate.
void AddSessionConfigOptions(CLI::App* app, SessionConfigFlags* flags);

// The SessionConfig the options describe: the config file (or the defaults)
// loaded with lane::LoadConfigFile and converted field by field
// (lane::wire::ConfigToProto), plus the stream options. nullopt when none
// of the options is given and `required` is false.
absl::StatusOr<std::optional<lane::v1::SessionConfig>> SessionConfigFromFlags(
    const SessionConfigFlags& flags, bool required);

}  // namespace lane::client

#endif  // LANE_CLIENT_SESSION_CONFIG_H_
