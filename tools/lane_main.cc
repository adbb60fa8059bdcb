// `lane`: the command-line front end of the detector.
#include <string>
#include <vector>

#include "cli/command_line.h"
#include "commands.h"

int main(int argc, char** argv) {
  using namespace lane_tools;
  const std::vector<std::string> args(argv + 1, argv + argc);
  CLI::App app("Real-time lane marker detection (after Aly, IV 2008).", "lane");
  SetUpProgram(app);
  app.footer("Run 'lane COMMAND --help' for the options of a command.");
  const std::vector<std::string> eval_args =
      args.size() > 1 ? std::vector<std::string>(args.begin() + 1, args.end())
                      : std::vector<std::string>();
  const std::vector<Command> commands = {AddDetectCommand(app),    AddRenderCommand(app),
                                         AddConfigCommand(app),    AddEvalCommand(app, eval_args),
                                         AddCalibrateCommand(app), AddBackfillCommand(app)};
  if (const std::optional<int> exit_code = ParseCommandLine(app, args)) return *exit_code;
  return RunChosen(commands);
}
