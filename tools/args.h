// A small command-line parser for the `lane` subcommands:
//   --name value, --name=value, boolean --flag, positionals, "--" ends options,
//   -h/--help.
#ifndef LANE_TOOLS_ARGS_H_
#define LANE_TOOLS_ARGS_H_

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace lane_tools {

// Exit codes shared by the subcommands.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;  // a run-time error (file, config, frame)
inline constexpr int kExitUsage = 2;    // bad command line

// Prints "lane COMMAND: MESSAGE", a blank line and the usage to stderr;
// returns kExitUsage.
int UsageError(const std::string& command, const std::string& message, const char* usage);
// Prints "lane COMMAND: MESSAGE" to stderr; returns kExitFailure.
int Failure(const std::string& command, const std::string& message);

struct OptionSpec {
  std::string name;  // without the leading "--"
  bool takes_value = true;
};

class Args {
 public:
  // INVALID_ARGUMENT for an unknown option or a missing value. args excludes
  // the program and subcommand names.
  static absl::StatusOr<Args> Parse(const std::vector<std::string>& args,
                                    const std::vector<OptionSpec>& specs);

  bool help() const { return help_; }
  bool Has(const std::string& name) const { return values_.count(name) > 0; }
  // The last value given for an option.
  std::optional<std::string> Get(const std::string& name) const;
  // Typed values; INVALID_ARGUMENT naming the option when malformed, nullopt
  // inside when the option is absent.
  absl::StatusOr<std::optional<int64_t>> GetInt(const std::string& name, int64_t min,
                                                int64_t max) const;
  absl::StatusOr<std::optional<uint64_t>> GetUint64(const std::string& name) const;
  // One of `choices`.
  absl::StatusOr<std::optional<std::string>> GetChoice(
      const std::string& name, const std::vector<std::string>& choices) const;
  const std::vector<std::string>& positional() const { return positional_; }

 private:
  bool help_ = false;
  std::map<std::string, std::string> values_;
  std::vector<std::string> positional_;
};

}  // namespace lane_tools

#endif  // LANE_TOOLS_ARGS_H_
