#include "io/command_line.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <sstream>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace lane::io {
namespace {

constexpr size_t kHelpWidth = 100;
constexpr size_t kHelpColumn = 30;

// `text` with its words wrapped into lines of at most `width` characters;
// its own line breaks are kept.
std::string Wrap(const std::string& text, size_t width) {
  std::string out;
  size_t line = 0;
  std::istringstream lines(text);
  std::string paragraph;
  bool first_paragraph = true;
  while (std::getline(lines, paragraph)) {
    if (!first_paragraph) out += '\n';
    first_paragraph = false;
    line = 0;
    std::istringstream words(paragraph);
    std::string word;
    while (words >> word) {
      if (line > 0 && line + 1 + word.size() > width) {
        out += '\n';
        line = 0;
      } else if (line > 0) {
        out += ' ';
        ++line;
      }
      out += word;
      line += word.size();
    }
  }
  return out;
}

// CLI11's formatter with the usage line first, a command's long description
// in its own --help (the short one in its parent's list), one name per
// option (the first long name: aliases stay hidden), and "(default X)"
// after the wrapped description.
class HelpFormatter final : public CLI::Formatter {
 public:
  HelpFormatter() {
    label("Usage", "usage");
    label("OPTIONS", "options");
    label("SUBCOMMAND", "COMMAND");
    label("Positionals", "Arguments");
    column_width(kHelpColumn);
  }

  void SetDescription(const CLI::App* app, std::string description) {
    descriptions_[app] = std::move(description);
  }

  std::string make_description(const CLI::App* app) const override {
    const auto it = descriptions_.find(app);
    if (it == descriptions_.end()) return CLI::Formatter::make_description(app);
    return it->second + "\n";
  }

  std::string make_help(const CLI::App* app, std::string name,
                        CLI::AppFormatMode mode) const override {
    if (mode == CLI::AppFormatMode::Sub) return make_expanded(app);
    std::ostringstream out;
    out << make_usage(app, name);
    const std::string description = make_description(app);
    if (!description.empty()) out << '\n' << description;
    out << make_positionals(app) << OptionGroups(app) << make_subcommands(app, mode) << '\n'
        << make_footer(app);
    return out.str();
  }

  // The option groups, one blank line between them.
  std::string OptionGroups(const CLI::App* app) const {
    std::string out;
    for (const std::string& group : app->get_groups()) {
      const std::vector<const CLI::Option*> options =
          app->get_options([&group](const CLI::Option* opt) {
            return opt->get_group() == group && opt->nonpositional();
          });
      if (!group.empty() && !options.empty()) out += make_group(group, false, options);
    }
    return out;
  }

  std::string make_option_name(const CLI::Option* opt, bool positional) const override {
    if (positional) return opt->get_name(true, false);
    std::vector<std::string> names;
    for (const std::string& s : opt->get_snames()) names.push_back("-" + s);
    if (!opt->get_lnames().empty()) names.push_back("--" + opt->get_lnames().front());
    return absl::StrJoin(names, ", ");
  }

  std::string make_option_opts(const CLI::Option* opt) const override {
    std::string out;
    if (opt->get_type_size() == 0) return out;
    if (!opt->get_type_name().empty() && opt->nonpositional())
      absl::StrAppend(&out, " ", opt->get_type_name());
    if (opt->get_expected_max() == CLI::detail::expected_max_vector_size) out += " ...";
    if (opt->get_required()) out += " (required)";
    return out;
  }

  std::string make_option_desc(const CLI::Option* opt) const override {
    std::string description = opt->get_description();
    const std::string& shown = opt->get_default_str();
    if (opt->get_type_size() != 0 && opt->nonpositional() && !opt->get_required() &&
        !shown.empty() && shown != "[]") {
      absl::StrAppend(&description, " (default ", shown, ")");
    }
    return Wrap(description, kHelpWidth - kHelpColumn);
  }

 private:
  std::map<const CLI::App*, std::string> descriptions_;
};

// The deepest (sub)command the parse reached.
const CLI::App& DeepestCommand(const CLI::App& app) {
  const CLI::App* current = &app;
  while (!current->get_subcommands().empty()) current = current->get_subcommands().front();
  return *current;
}

}  // namespace

void SetUpProgram(CLI::App& app) {
  app.formatter(std::make_shared<HelpFormatter>());
  app.set_help_flag("-h,--help", "show this help");
  app.set_version_flag("--version", absl::StrCat(app.get_name(), " ", VersionString()),
                       "print the version and exit");
  app.require_subcommand(1);
  // An option given twice: the last value counts, as before CLI11.
  app.option_defaults()->always_capture_default()->multi_option_policy(
      CLI::MultiOptionPolicy::TakeLast);
}

CLI::App* AddCommand(CLI::App& parent, const std::string& name, const std::string& summary,
                     const std::string& description, const std::string& footer) {
  CLI::App* command = parent.add_subcommand(name, summary);
  command->group("Commands");
  if (!description.empty()) {
    if (auto* formatter = dynamic_cast<HelpFormatter*>(command->get_formatter().get())) {
      formatter->SetDescription(command, description);
    }
  }
  command->footer(footer);  // not the parent's
  return command;
}

std::optional<int> ParseCommandLine(CLI::App& app, const std::vector<std::string>& args) {
  // CLI11 takes the arguments last first. `PROGRAM help` is `PROGRAM --help`.
  std::vector<std::string> reversed(args.rbegin(), args.rend());
  if (!reversed.empty() && reversed.back() == "help") reversed.back() = "--help";
  try {
    app.parse(reversed);
  } catch (const CLI::CallForHelp&) {
    std::fputs(app.help().c_str(), stdout);
    return kExitOk;
  } catch (const CLI::CallForAllHelp&) {
    std::fputs(app.help("", CLI::AppFormatMode::All).c_str(), stdout);
    return kExitOk;
  } catch (const CLI::CallForVersion& e) {
    std::printf("%s\n", e.what());
    return kExitOk;
  } catch (const CLI::Error& e) {
    const CLI::App& command = DeepestCommand(app);
    // "lane frobnicate", "lane": CLI11 only says a subcommand is required.
    if (dynamic_cast<const CLI::RequiredError*>(&e) != nullptr &&
        !command.get_subcommands({}).empty()) {
      const std::vector<std::string> rest = app.remaining(true);
      return UsageError(command, rest.empty()
                                     ? std::string("no COMMAND given")
                                     : absl::StrCat("unknown command \"", rest.front(), "\""));
    }
    return UsageError(command, e.what());
  }
  return std::nullopt;
}

int RunChosen(const std::vector<Command>& commands) {
  for (const Command& command : commands) {
    if (command.app->parsed()) return command.run();
  }
  return kExitUsage;
}

std::string CommandPath(const CLI::App& command) {
  std::string path = command.get_name();
  for (const CLI::App* p = command.get_parent(); p != nullptr; p = p->get_parent()) {
    path = absl::StrCat(p->get_name(), " ", path);
  }
  return path;
}

void PrintMessage(const std::string& path, const std::string& message) {
  std::fprintf(stderr, "%s: %s\n", path.c_str(), message.c_str());
}

int UsageError(const CLI::App& command, const std::string& message) {
  const std::string path = CommandPath(command);
  PrintMessage(path, message);
  if (const auto* formatter = dynamic_cast<const CLI::Formatter*>(command.get_formatter().get())) {
    std::fputs(formatter->make_usage(&command, path).c_str(), stderr);
  }
  std::fprintf(stderr, "Run '%s --help' for the options.\n", path.c_str());
  return kExitUsage;
}

std::optional<absl::Duration> ParseDurationText(const std::string& text) {
  absl::Duration d;
  double seconds = 0;
  if (absl::SimpleAtod(text, &seconds) && std::isfinite(seconds)) {
    d = absl::Seconds(seconds);
  } else if (!absl::ParseDuration(text, &d)) {
    return std::nullopt;
  }
  if (d < absl::ZeroDuration()) return std::nullopt;
  return d;
}

CLI::Option* AddDuration(CLI::App* app, const std::string& names,
                         std::optional<absl::Duration>* out, const std::string& description,
                         const std::string& shown_default) {
  CLI::Option* option = app->add_option_function<std::string>(
      names, [out](const std::string& text) { *out = ParseDurationText(text); }, description);
  option->type_name("DURATION");
  option->check(CLI::Validator(
      [](std::string& text) -> std::string {
        if (ParseDurationText(text)) return "";
        return absl::StrCat("must be a duration such as 500ms, 10s or 2.5, not negative; got \"",
                            text, "\"");
      },
      "", "Duration"));
  if (!shown_default.empty()) option->default_str(shown_default);
  return option;
}

CLI::Option* OneOf(CLI::Option* option, const std::vector<std::string>& choices) {
  option->type_name(absl::StrJoin(choices, "|"));
  return option->check(CLI::IsMember(choices).description(""));
}

CLI::Validator NonNegativeInteger() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        if (!text.empty() && text.find_first_not_of("0123456789") == std::string::npos) return "";
        return absl::StrCat("must be a non-negative integer, got \"", text, "\"");
      },
      "", "NonNegativeInteger");
}

CLI::Validator Between(int64_t min, int64_t max) {
  return CLI::Range(min, max).description(absl::StrCat(min, "..", max));
}

CLI::Validator NonNegativeNumber() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        double v = 0;
        if (absl::SimpleAtod(text, &v) && std::isfinite(v) && v >= 0) return "";
        return absl::StrCat("must be a non-negative number, got \"", text, "\"");
      },
      "", "NonNegativeNumber");
}

void AddReadFlags(CLI::App* app, ReadFlags* flags) {
  app->add_option("--fps", flags->fps,
                  "pace the frames at R per second, like a camera (0 = as fast as they go)")
      ->type_name("R")
      ->check(CLI::Range(0.0, 1000.0));
  app->add_flag("--realtime", flags->realtime,
                "pace each video at its own frame rate (image files: --fps, else 30/s); live "
                "sources are never paced");
  app->add_option("--max-frames", flags->max_frames,
                  "stop after N frames (0 = all; a live source runs until it ends)")
      ->type_name("N")
      ->check(CLI::Range(0LL, 1LL << 40));
}

}  // namespace lane::io
