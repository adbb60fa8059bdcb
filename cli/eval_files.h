// The files `lane eval` writes besides its tables: overlay names, the
// per-frame matching (frames.jsonl), folders, and the command line recorded
// with a baseline.
#ifndef LANE_CLI_EVAL_FILES_H_
#define LANE_CLI_EVAL_FILES_H_

#include <filesystem>
#include <set>
#include <string>

#include "lane/eval/evaluate.h"

namespace lane::cli {

// A file name stem for a frame name: extension dropped, '/', '#', ':' and
// spaces replaced by '_'; "-2", "-3", ... appended on a clash with `used`
// (which it extends).
std::string OverlayStem(const std::string& name, std::set<std::string>& used);

// Writes `text` to `path` (replacing it); false on any error.
bool WriteFile(const std::filesystem::path& path, const std::string& text);

// One line of DIR/frames.jsonl: which label each detection matched under both
// rules (-1: a false positive) and which detection found each scored label
// (-1: a miss). Label numbers are indices into the frame's label list.
std::string FrameMatchJsonLine(const std::string& name, const lane::eval::FrameScore& score);

// Creates `dir` (and its parents); an error message or "".
std::string MakeDir(const std::filesystem::path& dir);

// `word` as one word of a POSIX shell command line (quoted when needed).
std::string ShellWord(const std::string& word);

}  // namespace lane::cli

#endif  // LANE_CLI_EVAL_FILES_H_
