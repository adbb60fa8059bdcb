// The session options shared by `session create`, `stream` and `bench`: a
// config file in the format of the `lane` command (docs/config.md), the
// detector mode, and the stream policy, as the proto SessionConfig.
#ifndef LANE_CLIENT_SESSION_CONFIG_H_
#define LANE_CLIENT_SESSION_CONFIG_H_

#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "args.h"
#include "lane/v1/lane_service.pb.h"

namespace lane_client {

// --config FILE, --mode all|two, --backpressure block|drop_oldest,
// --session-inflight N.
std::vector<lane_tools::OptionSpec> SessionConfigOptionSpecs();

inline constexpr char kSessionConfigUsage[] =
    "  --config FILE        session config: the JSON format of `lane` (docs/config.md)\n"
    "  --mode all|two       detector mode instead of the config's\n"
    "  --backpressure block|drop_oldest\n"
    "                       what the server does at the stream's in-flight bound\n"
    "  --session-inflight N the session's bound on a stream's frames in flight\n"
    "                       (default: the server's --max_inflight_frames)\n";

// The SessionConfig the options describe: the config file (or the defaults)
// loaded with lane::LoadConfigFile and converted field by field
// (lane::server::ConfigToProto), plus the stream options. nullopt when none
// of the options is given and `required` is false.
absl::StatusOr<std::optional<lane::v1::SessionConfig>> SessionConfigFromArgs(
    const lane_tools::Args& args, bool required);

}  // namespace lane_client

#endif  // LANE_CLIENT_SESSION_CONFIG_H_
