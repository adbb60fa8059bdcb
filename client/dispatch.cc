#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "commands.h"
#include "common.h"

namespace lane::client {

int RunCommand(const std::vector<std::string>& args) {
  CLI::App app("The bundled client of lane-server (docs/client.md).", "lane-client");
  io::SetUpProgram(app);
  app.footer("Run 'lane-client COMMAND --help' for the options of a command.");
  SecurityFlags security_flags;
  AddSecurityOptions(app, &security_flags);
  std::vector<Command> commands = AddSessionCommands(app);
  for (Command command : {AddStreamCommand(app), AddBenchCommand(app), AddHealthCommand(app),
                          AddInfoCommand(app), AddViewCommand(app)}) {
    commands.push_back(std::move(command));
  }
  if (const std::optional<int> exit_code = io::ParseCommandLine(app, args)) {
    return *exit_code;
  }
  absl::StatusOr<Security> security = LoadSecurity(security_flags);
  if (!security.ok()) {
    for (const Command& command : commands) {
      if (command.app->parsed()) {
        return io::UsageError(*command.app, std::string(security.status().message()));
      }
    }
    return io::UsageError(app, std::string(security.status().message()));
  }
  SetSecurity(*std::move(security));
  return io::RunChosen(commands);
}

}  // namespace lane::client
