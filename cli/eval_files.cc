#include "eval_files.h"

#include <fstream>
#include <nlohmann/json.hpp>
#include <system_error>

#include "absl/strings/str_cat.h"

namespace lane::cli {

namespace fs = std::filesystem;

// A file name stem for a frame name: extension dropped, '/', '#', ':' and
// spaces replaced by '_'; "-2", "-3", ... appended on a clash.
std::string OverlayStem(const std::string& name, std::set<std::string>& used) {
  std::string stem = name;
  const size_t slash = stem.find_last_of('/');
  const size_t dot = stem.find_last_of('.');
  if (dot != std::string::npos && (slash == std::string::npos || dot > slash) && dot > 0) {
    stem.resize(dot);
  }
  for (char& c : stem) {
    if (c == '/' || c == '\\' || c == '#' || c == ':' || c == ' ') c = '_';
  }
  if (stem.empty()) stem = "frame";
  std::string candidate = stem;
  for (int i = 2; !used.insert(candidate).second; ++i) candidate = absl::StrCat(stem, "-", i);
  return candidate;
}

bool WriteFile(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  return static_cast<bool>(out);
}

// One line of DIR/frames.jsonl: which label each detection matched under both
// rules (-1: a false positive) and which detection found each scored label
// (-1: a miss). Label numbers are indices into the frame's label list.
std::string FrameMatchJsonLine(const std::string& name, const lane::eval::FrameScore& score) {
  using Json = nlohmann::ordered_json;
  auto matching = [&score](const lane::eval::Matching& m) {
    Json det = Json::array();
    for (int l : m.detection_label) det.push_back(l < 0 ? -1 : score.scored_labels[l]);
    return Json{{"detection_label", det}, {"label_detection", m.label_detection}};
  };
  Json out{{"frame", name},
           {"labels", score.scored_labels},
           {"paper", matching(score.paper)},
           {"culane", matching(score.culane)}};
  return out.dump();
}

// Creates `dir` (and its parents); an error message or "".
std::string MakeDir(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    return absl::StrCat("cannot create folder ", dir.string(), ec ? ": " + ec.message() : "");
  }
  return "";
}

// `word` as one word of a POSIX shell command line (quoted when needed).
std::string ShellWord(const std::string& word) {
  if (!word.empty() && word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                              "0123456789-_./=:,+") == std::string::npos) {
    return word;
  }
  std::string quoted = "'";
  for (char c : word) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

}  // namespace lane::cli
