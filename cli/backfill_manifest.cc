#include "backfill_manifest.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <queue>
#include <set>
#include <utility>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "io/input_file.h"
#include "io/inputs.h"

namespace lane::cli {
namespace {

bool ValidBackfillOutputName(const std::string& name) {
  if (name.empty() || name.size() > 200 || name[0] == '.') return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
  });
}

}  // namespace

int JsonNestingDepth(std::string_view text) {
  int depth = 0, deepest = 0;
  bool in_string = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') {
        ++i;  // the escaped character, whatever it is
      } else if (c == '"') {
        in_string = false;
      }
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return deepest;
}

absl::StatusOr<std::vector<BackfillRecording>> ReadBackfillManifest(const std::string& path,
                                                                    bool with_sizes) {
  namespace fs = std::filesystem;
  using Json = nlohmann::json;
  absl::StatusOr<io::OpenedFile> file = io::OpenRegularFile(path);
  if (!file.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot read the manifest ", file.status().message()));
  }
  if (file->size > kMaxManifestBytes) {
    return absl::InvalidArgumentError(absl::StrCat("the manifest ", path, " is ", file->size,
                                                   " bytes, over the cap of ", kMaxManifestBytes));
  }
  std::error_code ec;
  const fs::path base = fs::absolute(path, ec).parent_path();
  const auto resolve = [&base](const std::string& p) {
    return fs::path(p).is_absolute() ? p : (base / p).lexically_normal().string();
  };
  std::vector<BackfillRecording> recordings;
  std::set<std::string> outputs;
  io::BoundedLineReader lines(std::move(file->fd), kMaxManifestLineBytes);
  for (;;) {
    absl::StatusOr<std::optional<std::string>> text = lines.Next();
    if (!text.ok()) {
      return absl::InvalidArgumentError(absl::StrCat(path, ": ", text.status().message()));
    }
    if (!text->has_value()) break;
    const std::string& line = **text;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const auto where = absl::StrCat(path, ":", lines.line_number(), ": ");
    if (const int depth = JsonNestingDepth(line); depth > kMaxManifestDepth) {
      return absl::InvalidArgumentError(absl::StrCat(
          where, "nested ", depth, " deep; a manifest line may nest at most ", kMaxManifestDepth));
    }
    const Json j = Json::parse(line, nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded() || !j.is_object()) {
      return absl::InvalidArgumentError(absl::StrCat(where, "not a JSON object"));
    }
    for (const char* key : {"recording", "config", "output"}) {
      if (!j.contains(key) || !j[key].is_string() || j[key].get<std::string>().empty()) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, "\"", key, "\" must be a non-empty string"));
      }
    }
    BackfillRecording r;
    r.line = lines.line_number();
    r.recording = resolve(j["recording"].get<std::string>());
    r.config = resolve(j["config"].get<std::string>());
    r.output = j["output"].get<std::string>();
    if (!ValidBackfillOutputName(r.output)) {
      return absl::InvalidArgumentError(absl::StrCat(
          where, "output \"", r.output, "\" must be letters, digits, '.', '_' or '-'"));
    }
    if (!outputs.insert(r.output).second) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, "output \"", r.output, "\" is used twice"));
    }
    if (with_sizes) {
      // Listed, not opened: a FIFO or a device among them has no size here
      // and fails when its recording runs.
      for (const io::InputEntry& e : io::ExpandInputs({r.recording})) {
        if (e.kind == io::InputEntry::kError) continue;
        const uintmax_t size = fs::file_size(e.path, ec);
        if (!ec) r.bytes += size;
      }
    }
    recordings.push_back(std::move(r));
  }
  if (recordings.empty()) return absl::InvalidArgumentError(path + " lists no recording");
  return recordings;
}

absl::StatusOr<ShardSpec> ParseShardSpec(const std::string& text) {
  ShardSpec spec;
  const std::vector<std::string> parts = absl::StrSplit(text, '/');
  if (parts.size() != 2 || !absl::SimpleAtoi(parts[0], &spec.index) ||
      !absl::SimpleAtoi(parts[1], &spec.count) || spec.count < 1 || spec.index < 0 ||
      spec.index >= spec.count) {
    return absl::InvalidArgumentError(
        absl::StrCat("--shard ", text, ": expected I/N, 0 <= I < N (N at most 2147483647)"));
  }
  return spec;
}

std::vector<BackfillRecording> ShareOfShard(const std::vector<BackfillRecording>& all,
                                            ShardSpec shard) {
  const size_t used = std::min(all.size(), static_cast<size_t>(shard.count));
  if (static_cast<size_t>(shard.index) >= used) return {};
  std::vector<size_t> order(all.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&all](size_t a, size_t b) { return all[a].bytes > all[b].bytes; });
  // (load, shard): the least load first, then the lower shard.
  using Load = std::pair<uintmax_t, size_t>;
  std::priority_queue<Load, std::vector<Load>, std::greater<Load>> loads;
  for (size_t s = 0; s < used; ++s) loads.push({0, s});
  std::vector<size_t> owner(all.size(), 0);
  for (size_t k : order) {
    Load least = loads.top();
    loads.pop();
    owner[k] = least.second;
    least.first += std::max<uintmax_t>(all[k].bytes, 1);
    loads.push(least);
  }
  std::vector<BackfillRecording> mine;
  for (size_t k = 0; k < all.size(); ++k) {
    if (owner[k] == static_cast<size_t>(shard.index)) mine.push_back(all[k]);
  }
  return mine;
}

}  // namespace lane::cli
