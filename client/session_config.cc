#include "session_config.h"

#include <string>

#include "cli_config.h"
#include "lane/config.h"
#include "wire/config_proto.h"

namespace lane_client {

std::vector<lane_tools::OptionSpec> SessionConfigOptionSpecs() {
  return {{"config"}, {"mode"}, {"backpressure"}, {"session-inflight"}};
}

absl::StatusOr<std::optional<lane::v1::SessionConfig>> SessionConfigFromArgs(
    const lane_tools::Args& args, bool required) {
  const auto mode = args.GetChoice("mode", {"all", "two"});
  if (!mode.ok()) return mode.status();
  const auto backpressure = args.GetChoice("backpressure", {"block", "drop_oldest"});
  if (!backpressure.ok()) return backpressure.status();
  const auto inflight = args.GetInt("session-inflight", 1, 1 << 20);
  if (!inflight.ok()) return inflight.status();
  const std::optional<std::string> path = args.Get("config");
  if (!required && !path && !*mode) {
    if (*backpressure || *inflight) {
      return absl::InvalidArgumentError("--backpressure and --session-inflight need --config");
    }
    return std::optional<lane::v1::SessionConfig>();
  }
  absl::StatusOr<lane::Config> config = lane_tools::LoadEffectiveConfig(path, *mode);
  if (!config.ok()) return config.status();
  lane::v1::SessionConfig proto;
  lane::wire::ConfigToProto(*config, &proto);
  lane::v1::StreamOptions* stream = proto.mutable_stream();
  if (*backpressure) {
    stream->set_backpressure(**backpressure == "drop_oldest" ? lane::v1::BACKPRESSURE_DROP_OLDEST
                                                             : lane::v1::BACKPRESSURE_BLOCK);
  }
  if (*inflight) stream->set_max_inflight_frames(static_cast<uint32_t>(**inflight));
  return std::optional<lane::v1::SessionConfig>(std::move(proto));
}

}  // namespace lane_client
