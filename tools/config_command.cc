// `lane config`: prints the effective configuration.
#include <cstdio>

#include "args.h"
#include "cli_config.h"
#include "commands.h"
#include "lane/config.h"

namespace lane_tools {
namespace {

constexpr char kUsage[] =
    "usage: lane config [--config CONFIG] [--mode all|two]\n"
    "\n"
    "Prints the full effective configuration as JSON, every key present: the\n"
    "built-in defaults or CONFIG, with --mode applied as in 'lane detect'.\n"
    "The output is itself a valid config file (docs/config.md).\n"
    "\n"
    "options:\n"
    "  --config CONFIG   JSON config file (default: built-in defaults)\n"
    "  --mode all|two    use this detector mode: the mode's defaults, then\n"
    "                    CONFIG's other detector keys\n"
    "  -h, --help        show this help\n";

}  // namespace

int RunConfig(const std::vector<std::string>& argv) {
  const absl::StatusOr<Args> args = Args::Parse(argv, {{"config"}, {"mode"}});
  if (!args.ok()) return UsageError("config", std::string(args.status().message()), kUsage);
  if (args->help()) {
    std::fputs(kUsage, stdout);
    return kExitOk;
  }
  if (!args->positional().empty()) {
    return UsageError("config", "unexpected argument " + args->positional()[0], kUsage);
  }
  const auto mode = args->GetChoice("mode", {"all", "two"});
  if (!mode.ok()) return UsageError("config", std::string(mode.status().message()), kUsage);

  const absl::StatusOr<lane::Config> config = LoadEffectiveConfig(args->Get("config"), *mode);
  if (!config.ok()) return Failure("config", std::string(config.status().message()));
  std::fputs(lane::ConfigToJson(*config).c_str(), stdout);
  return kExitOk;
}

}  // namespace lane_tools
