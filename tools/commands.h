// The `lane` subcommands. Each Add*Command registers its subcommand, with
// its options, on the program's CLI11 app and returns it with the function
// that runs it once the command line is parsed; that function returns the
// exit status (cli/command_line.h: 0 ok, 1 failure, 2 bad command line).
#ifndef LANE_TOOLS_COMMANDS_H_
#define LANE_TOOLS_COMMANDS_H_

#include <string>
#include <vector>

#include "cli/command_line.h"

namespace lane_tools {

Command AddDetectCommand(CLI::App& lane);
Command AddRenderCommand(CLI::App& lane);
Command AddConfigCommand(CLI::App& lane);
Command AddCalibrateCommand(CLI::App& lane);
Command AddBackfillCommand(CLI::App& lane);
// `args`: the words after "eval", recorded in a --write-baseline file.
Command AddEvalCommand(CLI::App& lane, const std::vector<std::string>& args);

// "lane COMMAND: MESSAGE" on stderr; returns kExitFailure.
inline int Failure(const std::string& command, const std::string& message) {
  PrintMessage("lane " + command, message);
  return kExitFailure;
}

}  // namespace lane_tools

#endif  // LANE_TOOLS_COMMANDS_H_
