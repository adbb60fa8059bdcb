#include "args.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace lane_tools {

int UsageError(const std::string& command, const std::string& message, const char* usage) {
  std::fprintf(stderr, "lane %s: %s\n\n%s", command.c_str(), message.c_str(), usage);
  return kExitUsage;
}

int Failure(const std::string& command, const std::string& message) {
  std::fprintf(stderr, "lane %s: %s\n", command.c_str(), message.c_str());
  return kExitFailure;
}

absl::StatusOr<Args> Args::Parse(const std::vector<std::string>& args,
                                 const std::vector<OptionSpec>& specs) {
  Args out;
  bool options_done = false;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (options_done || arg.size() < 2 || arg[0] != '-') {
      out.positional_.push_back(arg);
      continue;
    }
    if (arg == "--") {
      options_done = true;
      continue;
    }
    if (arg == "-h" || arg == "--help") {
      out.help_ = true;
      continue;
    }
    if (arg.rfind("--", 0) != 0) {
      return absl::InvalidArgumentError(absl::StrCat("unknown option ", arg));
    }
    std::string name = arg.substr(2);
    std::optional<std::string> value;
    if (const size_t eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
    }
    const auto spec = std::find_if(specs.begin(), specs.end(),
                                   [&](const OptionSpec& s) { return s.name == name; });
    if (spec == specs.end()) {
      return absl::InvalidArgumentError(absl::StrCat("unknown option --", name));
    }
    if (!spec->takes_value) {
      if (value) {
        return absl::InvalidArgumentError(absl::StrCat("option --", name, " takes no value"));
      }
      out.values_[name] = "true";
      continue;
    }
    if (!value) {
      if (i + 1 >= args.size()) {
        return absl::InvalidArgumentError(absl::StrCat("option --", name, " needs a value"));
      }
      value = args[++i];
    }
    out.values_[name] = *value;
  }
  return out;
}

std::optional<std::string> Args::Get(const std::string& name) const {
  const auto it = values_.find(name);
  if (it == values_.end()) return std::nullopt;
  return it->second;
}

absl::StatusOr<std::optional<int64_t>> Args::GetInt(const std::string& name, int64_t min,
                                                    int64_t max) const {
  const std::optional<std::string> text = Get(name);
  if (!text) return std::optional<int64_t>();
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text->c_str(), &end, 10);
  if (text->empty() || *end != '\0' || errno == ERANGE || v < min || v > max) {
    return absl::InvalidArgumentError(absl::StrCat("--", name, " must be an integer in [", min,
                                                   ", ", max, "], got \"", *text, "\""));
  }
  return std::optional<int64_t>(v);
}

absl::StatusOr<std::optional<uint64_t>> Args::GetUint64(const std::string& name) const {
  const std::optional<std::string> text = Get(name);
  if (!text) return std::optional<uint64_t>();
  errno = 0;
  char* end = nullptr;
  const unsigned long long v = std::strtoull(text->c_str(), &end, 10);
  if (text->empty() || (*text)[0] == '-' || *end != '\0' || errno == ERANGE) {
    return absl::InvalidArgumentError(
        absl::StrCat("--", name, " must be a non-negative integer, got \"", *text, "\""));
  }
  return std::optional<uint64_t>(v);
}

absl::StatusOr<std::optional<std::string>> Args::GetChoice(
    const std::string& name, const std::vector<std::string>& choices) const {
  const std::optional<std::string> text = Get(name);
  if (!text) return std::optional<std::string>();
  if (std::find(choices.begin(), choices.end(), *text) == choices.end()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--", name, " must be one of ", absl::StrJoin(choices, ", "), ", got \"", *text, "\""));
  }
  return text;
}

}  // namespace lane_tools
