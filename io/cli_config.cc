#include "io/cli_config.h"

#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "absl/strings/str_cat.h"

namespace lane::io {

absl::StatusOr<lane::Config> LoadEffectiveConfig(const std::optional<std::string>& path,
                                                 const std::optional<std::string>& mode) {
  if (!mode) {
    return path ? lane::LoadConfigFile(*path) : lane::ParseConfig("{}");
  }
  // Load the file normally first: that reports unreadable files, malformed
  // JSON and bad values with the file's name.
  nlohmann::ordered_json doc = nlohmann::ordered_json::object();
  if (path) {
    if (absl::StatusOr<lane::Config> plain = lane::LoadConfigFile(*path); !plain.ok()) {
      return plain.status();
    }
    std::ifstream in(*path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    doc = nlohmann::ordered_json::parse(text.str(), nullptr, /*allow_exceptions=*/false,
                                        /*ignore_comments=*/true);
    if (doc.is_discarded()) {
      return absl::UnavailableError(absl::StrCat(*path, ": changed while it was read"));
    }
  }
  doc["detector"]["mode"] = *mode;
  absl::StatusOr<lane::Config> config = lane::ParseConfig(doc.dump());
  if (!config.ok() && path) {
    return absl::Status(config.status().code(), absl::StrCat(*path, " with --mode ", *mode, ": ",
                                                             config.status().message()));
  }
  return config;
}

}  // namespace lane::io
