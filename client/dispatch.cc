#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "commands.h"
#include "common.h"

namespace lane_client {
namespace {

constexpr char kUsage[] =
    "usage: lane-client COMMAND [options]\n"
    "\n"
    "The bundled client of lane-server (docs/client.md).\n"
    "\n"
    "commands:\n"
    "  session create|get|list|delete   manage camera sessions\n"
    "  stream                           frames of files or videos in, JSON Lines out\n"
    "  bench                            load test with per-frame latency\n"
    "  health                           gRPC health check (exit 0 when SERVING)\n"
    "  info                             the server's version, limits and defaults\n"
    "\n"
    "`lane-client COMMAND --help` describes a command's options.\n"
    "\n";

}  // namespace

int RunCommand(const std::vector<std::string>& args) {
  if (args.empty()) {
    std::fputs(kUsage, stderr);
    std::fputs(kSecurityUsage, stderr);
    return kExitUsage;
  }
  const std::string& command = args.front();
  std::vector<std::string> rest(args.begin() + 1, args.end());
  absl::StatusOr<Security> security = TakeSecurityOptions(rest);
  if (!security.ok()) {
    std::fprintf(stderr, "lane-client %s: %s\n", command.c_str(),
                 std::string(security.status().message()).c_str());
    return kExitUsage;
  }
  SetSecurity(*std::move(security));
  if (command == "session") return RunSession(rest);
  if (command == "stream") return RunStream(rest);
  if (command == "bench") return RunBench(rest);
  if (command == "health") return RunHealth(rest);
  if (command == "info") return RunInfo(rest);
  if (command == "-h" || command == "--help" || command == "help") {
    std::fputs(kUsage, stdout);
    std::fputs(kSecurityUsage, stdout);
    return kExitOk;
  }
  std::fprintf(stderr, "lane-client: unknown command %s\n\n%s", command.c_str(), kUsage);
  return kExitUsage;
}

}  // namespace lane_client
