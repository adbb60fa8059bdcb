#include "common.h"

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "status_map.h"

namespace lane_client {

int UsageError(const std::string& command, const std::string& message, const char* usage) {
  std::fprintf(stderr, "lane-client %s: %s\n\n%s", command.c_str(), message.c_str(), usage);
  return kExitUsage;
}

int Failure(const std::string& command, const std::string& message) {
  Note(command, message);
  return kExitFailure;
}

void Note(const std::string& command, const std::string& message) {
  std::fprintf(stderr, "lane-client %s: %s\n", command.c_str(), message.c_str());
}

absl::StatusOr<std::optional<absl::Duration>> GetDuration(const lane_tools::Args& args,
                                                          const std::string& name) {
  const std::optional<std::string> text = args.Get(name);
  if (!text) return std::optional<absl::Duration>();
  absl::Duration d;
  double seconds = 0;
  if (absl::SimpleAtod(*text, &seconds) && std::isfinite(seconds)) {
    d = absl::Seconds(seconds);
  } else if (!absl::ParseDuration(*text, &d)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--", name, " must be a duration such as 500ms, 10s or 2.5, got \"", *text, "\""));
  }
  if (d < absl::ZeroDuration()) {
    return absl::InvalidArgumentError(absl::StrCat("--", name, " must not be negative"));
  }
  return std::optional<absl::Duration>(d);
}

absl::StatusOr<std::optional<double>> GetNumber(const lane_tools::Args& args,
                                                const std::string& name) {
  const std::optional<std::string> text = args.Get(name);
  if (!text) return std::optional<double>();
  double v = 0;
  if (!absl::SimpleAtod(*text, &v) || !std::isfinite(v) || v < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("--", name, " must be a non-negative number, got \"", *text, "\""));
  }
  return std::optional<double>(v);
}

absl::StatusOr<std::vector<int>> ParseIntList(const std::string& text, const std::string& name) {
  std::vector<int> out;
  for (absl::string_view part : absl::StrSplit(text, ',')) {
    int v = 0;
    if (!absl::SimpleAtoi(part, &v) || v <= 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--", name, " must be a comma-separated list of positive integers, got \"", text, "\""));
    }
    out.push_back(v);
  }
  return out;
}

absl::StatusOr<std::vector<std::string>> SplitTargets(const std::string& spec) {
  if (absl::StartsWith(spec, "ipv4:") || absl::StartsWith(spec, "ipv6:") ||
      absl::StartsWith(spec, "unix:")) {
    return std::vector<std::string>{spec};
  }
  std::vector<std::string> targets;
  for (absl::string_view part : absl::StrSplit(spec, ',')) {
    part = absl::StripAsciiWhitespace(part);
    if (part.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat("--target has an empty entry: \"", spec, "\""));
    }
    targets.emplace_back(part);
  }
  return targets;
}

std::shared_ptr<grpc::Channel> MakeChannel(const std::string& target, int connection) {
  grpc::ChannelArguments args;
  args.SetLoadBalancingPolicyName("round_robin");
  args.SetMaxReceiveMessageSize(64 * 1024 * 1024);
  args.SetMaxSendMessageSize(-1);
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 100);
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 100);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 2000);
  // The server accepts pings every 10 s at most (--keepalive_min_client_interval).
  args.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, 20000);
  args.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 10000);
  // Channels otherwise share subchannels (and so TCP connections) process-wide.
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  args.SetInt("lane.client.connection", connection);
  return grpc::CreateCustomChannel(target, grpc::InsecureChannelCredentials(), args);
}

void SetDeadline(grpc::ClientContext* context, absl::Duration timeout) {
  context->set_deadline(std::chrono::system_clock::now() + absl::ToChronoMilliseconds(timeout));
}

std::string StatusText(const grpc::Status& status) {
  const char* name = lane::server::GrpcCodeName(status.error_code());
  if (status.ok() || status.error_message().empty()) return name;
  return absl::StrCat(name, ": ", status.error_message());
}

}  // namespace lane_client
