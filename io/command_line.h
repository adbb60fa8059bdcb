// The command-line conventions that `lane` and `lane-client` share, on CLI11:
//  * exit status 0 for success, 1 for a run-time failure, 2 for a bad
//    command line;
//  * --help: the usage line first, then the description, the options with
//    their defaults and the notes; an option shows one name, so the old
//    spellings kept as aliases stay hidden;
//  * --version: the project's version and git revision;
//  * errors: "PROGRAM COMMAND: MESSAGE", the command's usage line and a
//    pointer to its --help, on stderr.
#ifndef LANE_IO_COMMAND_LINE_H_
#define LANE_IO_COMMAND_LINE_H_

#include <CLI/CLI.hpp>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "absl/time/time.h"
#include "io/inputs.h"

namespace lane::io {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;  // a run-time error (file, config, frame, server)
inline constexpr int kExitUsage = 2;    // a bad command line

// "0.1.0 (git fa9daa6)": CMake's project version and `git describe --always
// --dirty` at configure time ("unknown" outside a checkout).
std::string VersionString();

// A (sub)command on the command line, and what runs it once the command
// line is parsed: a function that returns the exit status.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

// Runs the first command of `commands` that the parse chose; kExitUsage
// when there is none.
int RunChosen(const std::vector<Command>& commands);

// Sets up a program's top-level app: the help formatter, -h/--help,
// --version, and exactly one subcommand required.
void SetUpProgram(CLI::App& app);

// A subcommand of `parent`, set up like the program. `summary` is its line
// in the parent's --help; its own --help shows `description` (the summary
// when empty) after the usage line, and `footer` (notes, exit status) after
// the options.
CLI::App* AddCommand(CLI::App& parent, const std::string& name, const std::string& summary,
                     const std::string& description = "", const std::string& footer = "");

// Parses `args` (the program name excluded). nullopt: run the command that
// was chosen. Otherwise the exit status: kExitOk after --help or --version
// (printed on stdout), kExitUsage after a parse error (reported as
// UsageError does).
std::optional<int> ParseCommandLine(CLI::App& app, const std::vector<std::string>& args);

// "lane detect", "lane-client session create": the names of `command` and
// its parents.
std::string CommandPath(const CLI::App& command);

// "PATH: MESSAGE", the usage line of `command` and "Run 'PATH --help' for
// the options." on stderr; returns kExitUsage.
int UsageError(const CLI::App& command, const std::string& message);

// "PATH: MESSAGE" on stderr, PATH as CommandPath gives it.
void PrintMessage(const std::string& path, const std::string& message);

// A check: digits only (an unsigned integer without a sign).
CLI::Validator NonNegativeInteger();

// An option whose absence means something ("the config's value"): `*out`
// is set only when the option is given. CLI11 converts the value to T and
// runs the option's checks first.
// Unsigned types take no sign (CLI11 alone would wrap "-1" around).
template <typename T>
CLI::Option* AddOptional(CLI::App* app, const std::string& names, std::optional<T>* out,
                         const std::string& description) {
  CLI::Option* option = app->add_option_function<T>(
      names, [out](const T& value) { *out = value; }, description);
  if constexpr (std::is_unsigned_v<T>) option->check(NonNegativeInteger());
  return option;
}

// A duration: absl syntax ("500ms", "10s", "1m") or plain seconds ("2.5"),
// not negative. nullopt when malformed or negative.
std::optional<absl::Duration> ParseDurationText(const std::string& text);

// A duration option (ParseDurationText); `shown_default` is what --help
// shows when it is absent (the caller applies it).
CLI::Option* AddDuration(CLI::App* app, const std::string& names,
                         std::optional<absl::Duration>* out, const std::string& description,
                         const std::string& shown_default = "");

// Restricts `option` to `choices`, shown as its value in --help ("all|two").
CLI::Option* OneOf(CLI::Option* option, const std::vector<std::string>& choices);

// A check: an integer in [min, max], shown as "min..max" in --help.
CLI::Validator Between(int64_t min, int64_t max);

// A check: a finite number >= 0.
CLI::Validator NonNegativeNumber();

// --fps R, --realtime and --max-frames N of `lane detect` and `lane-client
// stream` (io/pacer.h, io/video_input.h).
struct ReadFlags {
  double fps = 0;
  bool realtime = false;
  long long max_frames = 0;

  // What the readers take (io/inputs.h).
  ReadOptions Options() const {
    ReadOptions options;
    options.max_frames = max_frames;
    options.pacer = Pacer(fps, realtime);
    return options;
  }
};
void AddReadFlags(CLI::App* app, ReadFlags* flags);

}  // namespace lane::io

#endif  // LANE_IO_COMMAND_LINE_H_
