// The lane-client subcommands. Each takes the arguments after its name and
// returns the process exit code (common.h).
#ifndef LANE_CLIENT_COMMANDS_H_
#define LANE_CLIENT_COMMANDS_H_

#include <string>
#include <vector>

namespace lane_client {

int RunSession(const std::vector<std::string>& args);
int RunStream(const std::vector<std::string>& args);
int RunBench(const std::vector<std::string>& args);
int RunHealth(const std::vector<std::string>& args);
int RunInfo(const std::vector<std::string>& args);

// Dispatches argv[1] (the subcommand) to the functions above.
int RunCommand(const std::vector<std::string>& args);

}  // namespace lane_client

#endif  // LANE_CLIENT_COMMANDS_H_
