// The `lane` subcommands. Each Add*Command registers its subcommand, with
// its options, on the program's CLI11 app and returns it with the function
// that runs it once the command line is parsed; that function returns the
// exit status (io/command_line.h: 0 ok, 1 failure, 2 bad command line).
#ifndef LANE_TOOLS_COMMANDS_H_
#define LANE_TOOLS_COMMANDS_H_

#include <string>
#include <vector>

#include "io/command_line.h"

namespace lane::cli {

io::Command AddDetectCommand(CLI::App& lane);
io::Command AddRenderCommand(CLI::App& lane);
io::Command AddConfigCommand(CLI::App& lane);
io::Command AddCalibrateCommand(CLI::App& lane);
io::Command AddBackfillCommand(CLI::App& lane);
// `args`: the words after "eval", recorded in a --write-baseline file.
io::Command AddEvalCommand(CLI::App& lane, const std::vector<std::string>& args);

// "lane COMMAND: MESSAGE" on stderr; returns kExitFailure.
inline int Failure(const std::string& command, const std::string& message) {
  io::PrintMessage("lane " + command, message);
  return io::kExitFailure;
}

}  // namespace lane::cli

#endif  // LANE_TOOLS_COMMANDS_H_
