// The lane-client subcommands. Each Add*Command registers its subcommand,
// with its options, on the program's CLI11 app and returns it with the
// function that runs it once the command line is parsed; that function
// returns the exit status (common.h).
#ifndef LANE_CLIENT_COMMANDS_H_
#define LANE_CLIENT_COMMANDS_H_

#include <string>
#include <vector>

#include "io/command_line.h"

namespace lane::client {

using io::Command;

// session create|get|list|delete.
std::vector<Command> AddSessionCommands(CLI::App& client);
Command AddStreamCommand(CLI::App& client);
Command AddBenchCommand(CLI::App& client);
Command AddHealthCommand(CLI::App& client);
Command AddInfoCommand(CLI::App& client);
// view: the live view's URL.
Command AddViewCommand(CLI::App& client);

// Parses the arguments after the program name and runs the command.
int RunCommand(const std::vector<std::string>& args);

}  // namespace lane::client

#endif  // LANE_CLIENT_COMMANDS_H_
