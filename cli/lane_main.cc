// `lane`: the command-line front end of the detector.
#include <string>
#include <vector>

#include "commands.h"
#include "io/command_line.h"

int main(int argc, char** argv) {
  namespace cli = lane::cli;
  namespace io = lane::io;
  const std::vector<std::string> args(argv + 1, argv + argc);
  CLI::App app("Real-time lane marker detection (after Aly, IV 2008).", "lane");
  io::SetUpProgram(app);
  app.footer("Run 'lane COMMAND --help' for the options of a command.");
  const std::vector<std::string> eval_args =
      args.size() > 1 ? std::vector<std::string>(args.begin() + 1, args.end())
                      : std::vector<std::string>();
  const std::vector<io::Command> commands = {
      cli::AddDetectCommand(app),    cli::AddRenderCommand(app),
      cli::AddConfigCommand(app),    cli::AddEvalCommand(app, eval_args),
      cli::AddCalibrateCommand(app), cli::AddBackfillCommand(app)};
  if (const std::optional<int> exit_code = io::ParseCommandLine(app, args)) return *exit_code;
  return io::RunChosen(commands);
}
