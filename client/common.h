// What every lane-client subcommand shares: exit codes, messages, the
// security options, and channels to the service.
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
#include "io/command_line.h"

namespace lane::client {

// The metadata header that names a call's camera: a proxy hashes it to keep
// each camera on one replica (deploy/nginx). Set on every call that concerns
// one camera (its streams and its session calls).
inline constexpr char kCameraIdHeader[] = "x-camera-id";

// Exit codes (io/command_line.h has 0, 1 and 2).
inline constexpr int kExitOk = io::kExitOk;
inline constexpr int kExitFailure = io::kExitFailure;  // run-time error
inline constexpr int kExitUsage = io::kExitUsage;      // bad command line
inline constexpr int kExitSlo = 3;                     // bench: --slo-p99-ms breached

inline constexpr char kDefaultTarget[] = "127.0.0.1:50051";

// "lane-client COMMAND: MESSAGE" on stderr; returns kExitFailure.
int Failure(const std::string& command, const std::string& message);
// "lane-client COMMAND: MESSAGE" on stderr.
void Note(const std::string& command, const std::string& message);

// --target T: the server address, or a comma list (SplitTargets).
CLI::Option* AddTargetOption(CLI::App* app, std::string* target, const std::string& description);

// The options of the commands that make one call per target: --target (a
// comma list: every target is asked) and --timeout.
struct CallFlags {
  std::string target;
  std::optional<absl::Duration> timeout;
};
void AddCallOptions(CLI::App* app, CallFlags* flags, const std::string& default_timeout);
struct CallSetup {
  std::vector<std::string> targets;
  absl::Duration timeout;
};
// INVALID_ARGUMENT for a bad target list.
absl::StatusOr<CallSetup> ParseCallSetup(const CallFlags& flags, absl::Duration default_timeout);

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
// The files the security options name.
struct SecurityFlags {
  std::string ca;
  std::string cert;
  std::string key;
  std::string token_file;
};
// --ca FILE, --cert FILE, --key FILE and --token-file FILE on the program's
// app: subcommands pass them up (fallthrough), so they are accepted after
// any command, anywhere before a "--".
void AddSecurityOptions(CLI::App& app, SecurityFlags* flags);
// Reads the files; the token comes from --token-file or else the
// environment variable LANE_TOKEN. INVALID_ARGUMENT on an unreadable file
// or options that do not go together.
absl::StatusOr<Security> LoadSecurity(const SecurityFlags& flags);
// The security options taken out of `args` (options before a "--" only,
// also --name=FILE), the rest left in order, and LoadSecurity: for callers
// that parse the rest themselves. INVALID_ARGUMENT on a missing value too.
absl::StatusOr<Security> TakeSecurityOptions(std::vector<std::string>& args);
// The security of the channels built from now on (default: plaintext, no
// token).
void SetSecurity(Security security);
// Whether the channels send a Bearer token (the live view's URL is then its
// login page).
bool HasToken();

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

}  // namespace lane::client

#endif  // LANE_CLIENT_COMMON_H_
