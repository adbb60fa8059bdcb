// The `lane` subcommands. Each takes the arguments after its name and returns
// the process exit code (args.h: 0 ok, 1 failure, 2 bad command line).
#ifndef LANE_TOOLS_COMMANDS_H_
#define LANE_TOOLS_COMMANDS_H_

#include <string>
#include <vector>

namespace lane_tools {

int RunDetect(const std::vector<std::string>& args);
int RunRender(const std::vector<std::string>& args);
int RunConfig(const std::vector<std::string>& args);
int RunEval(const std::vector<std::string>& args);

}  // namespace lane_tools

#endif  // LANE_TOOLS_COMMANDS_H_
