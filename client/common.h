// What every lane-client subcommand shares: exit codes, messages, option
// parsing helpers, and channels to the service.
#ifndef LANE_CLIENT_COMMON_H_
#define LANE_CLIENT_COMMON_H_

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "args.h"

namespace lane_client {

// Exit codes (args.h has 0, 1 and 2).
inline constexpr int kExitOk = lane_tools::kExitOk;
inline constexpr int kExitFailure = lane_tools::kExitFailure;  // run-time error
inline constexpr int kExitUsage = lane_tools::kExitUsage;      // bad command line
inline constexpr int kExitSlo = 3;                             // bench: --slo-p99-ms breached

inline constexpr char kDefaultTarget[] = "127.0.0.1:50051";

// "lane-client COMMAND: MESSAGE", a blank line and the usage, on stderr;
// returns kExitUsage.
int UsageError(const std::string& command, const std::string& message, const char* usage);
// "lane-client COMMAND: MESSAGE" on stderr; returns kExitFailure.
int Failure(const std::string& command, const std::string& message);
// "lane-client COMMAND: MESSAGE" on stderr.
void Note(const std::string& command, const std::string& message);

// A duration option: absl syntax ("500ms", "10s", "1m") or plain seconds
// ("2.5"). INVALID_ARGUMENT naming the option when malformed or negative.
absl::StatusOr<std::optional<absl::Duration>> GetDuration(const lane_tools::Args& args,
                                                          const std::string& name);
// A non-negative number option.
absl::StatusOr<std::optional<double>> GetNumber(const lane_tools::Args& args,
                                                const std::string& name);
// "1,2,4" -> {1, 2, 4}: positive integers.
absl::StatusOr<std::vector<int>> ParseIntList(const std::string& text, const std::string& name);

// Transport security and credentials of every channel MakeChannel builds:
// TLS when ca_pem is set (cert/key: a client certificate for mutual TLS), a
// Bearer token sent as `authorization` metadata on every call when token is
// set.
struct Security {
  std::string ca_pem;
  std::string cert_pem;
  std::string key_pem;
  std::string token;
};
// Takes --ca FILE, --cert FILE, --key FILE and --token-file FILE (also
// --name=FILE) out of `args` (options before a "--" only) and reads the
// files; the token comes from --token-file or else the environment variable
// LANE_TOKEN. INVALID_ARGUMENT on a missing value or an unreadable file.
absl::StatusOr<Security> TakeSecurityOptions(std::vector<std::string>& args);
// The security of the channels built from now on (default: plaintext, no
// token).
void SetSecurity(Security security);
// The usage text of the options above.
extern const char kSecurityUsage[];

// --target: "host:port", "dns:///name[:port]", or a comma list "a:1,b:2".
// A gRPC URI with its own address list ("ipv4:a:1,b:2", "ipv6:...") is kept
// whole. Empty entries are an error.
absl::StatusOr<std::vector<std::string>> SplitTargets(const std::string& spec);

// A channel to `target`: round_robin over every address the target resolves
// to, message size limits fit for raw frames, a reconnect backoff of 100 ms
// to 2 s (gRPC's default starts at 1 s and reaches 120 s), keepalive pings
// every 20 s during calls. Channels with different `connection` values never
// share a TCP connection.
std::shared_ptr<grpc::Channel> MakeChannel(const std::string& target, int connection = 0);

// A context with a deadline `timeout` from now.
void SetDeadline(grpc::ClientContext* context, absl::Duration timeout);

// "UNAVAILABLE: the server is draining" (or "OK").
std::string StatusText(const grpc::Status& status);

}  // namespace lane_client

#endif  // LANE_CLIENT_COMMON_H_
