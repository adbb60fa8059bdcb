#include "session_config.h"

#include <string>

#include "io/cli_config.h"
#include "lane/config/config.h"
#include "wire/config_proto.h"

namespace lane::client {

void AddSessionConfigOptions(CLI::App* app, SessionConfigFlags* flags) {
  const std::string group = "Session";
  io::AddOptional(app, "--config", &flags->config,
                  "session config: the JSON format of `lane` (docs/config.md)")
      ->type_name("FILE")
      ->group(group);
  io::OneOf(io::AddOptional(app, "--mode", &flags->mode, "detector mode instead of the config's"),
            {"all", "two"})
      ->group(group);
  io::OneOf(io::AddOptional(app, "--backpressure", &flags->backpressure,
                            "what the server does at the stream's in-flight bound"),
            {"block", "drop_oldest"})
      ->group(group);
  io::AddOptional(app, "--max-inflight-frames,--session-inflight", &flags->max_inflight_frames,
                  "the session's bound on a stream's frames in flight in the server")
      ->type_name("N")
      ->check(io::Between(1, 1 << 20))
      ->default_str("the server's --max_inflight_frames")
      ->group(group);
  app->add_flag("--full-decode", flags->full_decode,
                "the session decodes whole JPEG/PNG frames (by default only the rows and "
                "channel its detector reads: the same lanes)")
      ->group(group);
  app->add_flag("--auto-calibrate", flags->auto_calibrate,
                "the session refines the camera's pitch and yaw from the stream's straight-road "
                "frames (docs/calibration.md)")
      ->group(group);
}

absl::StatusOr<std::optional<lane::v1::SessionConfig>> SessionConfigFromFlags(
    const SessionConfigFlags& flags, bool required) {
  if (!required && !flags.config && !flags.mode) {
    if (flags.backpressure || flags.max_inflight_frames || flags.full_decode ||
        flags.auto_calibrate) {
      return absl::InvalidArgumentError(
          "--backpressure, --max-inflight-frames, --full-decode and --auto-calibrate need "
          "--config");
    }
    return std::optional<lane::v1::SessionConfig>();
  }
  absl::StatusOr<lane::Config> config = io::LoadEffectiveConfig(flags.config, flags.mode);
  if (!config.ok()) return config.status();
  lane::v1::SessionConfig proto;
  lane::wire::ConfigToProto(*config, &proto);
  lane::v1::StreamOptions* stream = proto.mutable_stream();
  if (flags.backpressure) {
    stream->set_backpressure(*flags.backpressure == "drop_oldest"
                                 ? lane::v1::BACKPRESSURE_DROP_OLDEST
                                 : lane::v1::BACKPRESSURE_BLOCK);
  }
  if (flags.max_inflight_frames) stream->set_max_inflight_frames(*flags.max_inflight_frames);
  if (flags.full_decode) proto.mutable_decode()->set_full_decode(true);
  if (flags.auto_calibrate) proto.mutable_calibration()->set_auto_calibrate(true);
  return std::optional<lane::v1::SessionConfig>(std::move(proto));
}

}  // namespace lane::client
