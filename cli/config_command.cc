// `lane config`: prints the effective configuration.
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "commands.h"
#include "io/cli_config.h"
#include "lane/config/config.h"

namespace lane::cli {
namespace {

constexpr char kConfigDescription[] =
    "Prints the full effective configuration as JSON, every key present: the\n"
    "built-in defaults or CONFIG, with --mode applied as in 'lane detect'.\n"
    "The output is itself a valid config file (docs/config.md).";

struct ConfigFlags {
  std::optional<std::string> config;
  std::optional<std::string> mode;
};

int RunConfig(const ConfigFlags& flags) {
  const absl::StatusOr<lane::Config> config = io::LoadEffectiveConfig(flags.config, flags.mode);
  if (!config.ok()) return Failure("config", std::string(config.status().message()));
  std::fputs(lane::ConfigToJson(*config).c_str(), stdout);
  return io::kExitOk;
}

}  // namespace

io::Command AddConfigCommand(CLI::App& lane) {
  auto flags = std::make_shared<ConfigFlags>();
  CLI::App* app = io::AddCommand(lane, "config", "print the effective configuration (every key)",
                                 kConfigDescription);
  io::AddOptional(app, "--config", &flags->config, "JSON config file")
      ->type_name("CONFIG")
      ->default_str("the built-in defaults");
  io::OneOf(
      io::AddOptional(app, "--mode", &flags->mode,
                      "use this detector mode: the mode's defaults, then CONFIG's other detector "
                      "keys"),
      {"all", "two"});
  return {app, [flags] { return RunConfig(*flags); }};
}

}  // namespace lane::cli
