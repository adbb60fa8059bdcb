// `lane backfill`'s outputs (docs/backfill.md): claimed with a lock, written
// under a name no other process uses, ended with a trailer that makes a
// whole file checkable, and published only where no output exists, so that
// two processes running the same shard at once (a replacement pod while the
// old one still runs) cannot tear or lose one.
//
// In OUT, for an output NAME:
//   NAME.jsonl                         the published output, trailer last;
//   .NAME.jsonl.lock                   the claim: flock(LOCK_EX) while a
//                                      process computes NAME, removed when
//                                      it is released;
//   .NAME.jsonl.partial.PID.RANDOM     a process's output being written
//                                      (PID alone is not unique across
//                                      containers: every pod's is 1).
#ifndef LANE_TOOLS_BACKFILL_OUTPUT_H_
#define LANE_TOOLS_BACKFILL_OUTPUT_H_

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "io/input_file.h"

namespace lane::cli {

// The trailer, an output's last line:
//   {"trailer":{"schema":1,"frames":N,"failed_frames":F,"sha256":"HEX",
//               "version":"0.1.0 (git ...)"}}
// N is the number of lines before it (one a frame), HEX the SHA-256 of
// those lines' bytes (each with its '\n'), version the tool's.
struct OutputCheck {
  enum State { kOk, kMissing, kTorn } state = kMissing;
  std::string reason;  // kTorn: what is wrong
  long frames = 0;     // kOk: the trailer's
};

// Whether OUT/NAME.jsonl at `path` is whole: it exists, is a regular file,
// ends with a trailer line, and the lines before it are as many and hash as
// the trailer says. Reads the file once, in bounded chunks.
OutputCheck CheckBackfillOutput(const std::string& path);

// The exclusive claim of one output: flock(LOCK_EX) on OUT/.NAME.jsonl.lock.
// Released (the lock file removed, then closed) when it goes.
class OutputClaim {
 public:
  // The claim, or nullopt when another process holds it and `wait` is
  // false; with `wait`, blocks until the holder releases it.
  static absl::StatusOr<std::optional<OutputClaim>> Acquire(const std::string& dir,
                                                            const std::string& name, bool wait);
  OutputClaim(OutputClaim&&) = default;
  OutputClaim& operator=(OutputClaim&&) = default;
  ~OutputClaim();

  // False on a file system without flock (ENOLCK, EOPNOTSUPP: a warning is
  // printed once): the claim then excludes no one, and its holder must not
  // remove partial files as stale.
  bool exclusive() const { return exclusive_; }

 private:
  OutputClaim(std::string path, io::ScopedFd fd, bool exclusive)
      : path_(std::move(path)), fd_(std::move(fd)), exclusive_(exclusive) {}
  std::string path_;
  io::ScopedFd fd_;
  bool exclusive_ = true;
};

// Stale partial outputs in `dir` (.NAME.jsonl.partial.PID.RANDOM, and the
// older .NAME.jsonl.partial), by output name. Only the holder of NAME's
// claim may remove NAME's: every partial file is made, and removed or
// renamed, by a claim's holder, so under the claim any that exist are a
// dead process's.
std::map<std::string, std::vector<std::string>> ListPartialOutputs(const std::string& dir);

// One output being written: OUT/.NAME.jsonl.partial.PID.RANDOM, created
// exclusively, buffered, and hashed line by line for the trailer. Removed
// when it goes unless published.
class PartialOutput {
 public:
  static absl::StatusOr<std::unique_ptr<PartialOutput>> Create(const std::string& dir,
                                                               const std::string& name);
  ~PartialOutput();

  // Appends `line` and a '\n'. An error is kept for Finish.
  void WriteLine(absl::string_view line);
  // Appends the trailer, then writes, fsyncs and closes the file.
  absl::Status Finish(long failed_frames, const std::string& version);
  // Renames the finished file to OUT/NAME.jsonl only if no such file exists
  // (renameat2 RENAME_NOREPLACE; link and unlink where the file system has
  // no RENAME_NOREPLACE), then fsyncs OUT. ALREADY_EXISTS when one does
  // (this file is then removed).
  absl::Status Publish();
  const std::string& path() const { return partial_path_; }

 private:
  class Impl;
  explicit PartialOutput(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
  std::string partial_path_;
};

// fsync of a directory (after a rename in it). Errors are returned.
absl::Status SyncDirectory(const std::string& dir);

// Writes `text` to OUT/FILE through a unique temporary file, fsynced and
// renamed over FILE (replacing it: the summary).
absl::Status ReplaceFileDurably(const std::string& dir, const std::string& file,
                                absl::string_view text);

}  // namespace lane::cli

#endif  // LANE_TOOLS_BACKFILL_OUTPUT_H_
