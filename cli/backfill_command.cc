// `lane backfill`: a fleet's recordings re-processed in shards (docs/backfill.md).
//
//   lane backfill --manifest M.jsonl --output-dir OUT [--shard I/N] [--jobs J]
//   lane backfill --verify --manifest M.jsonl --output-dir OUT
//
// The manifest is JSON Lines, one recording a line:
//   {"recording": "drives/cam7-0412.mp4", "config": "configs/cam7.json",
//    "output": "cam7-0412"}
// (relative paths against the manifest's folder; cli/backfill_manifest.h).
// Shard I of N takes a deterministic share, balanced by the recordings'
// sizes on disk. Each recording is one camera's frames, tracked in order:
// its results go to OUT/OUTPUT.jsonl, ended with a trailer that checks the
// whole file, written under a name of this process's own and published only
// where no output exists, under an exclusive claim (cli/backfill_output.h):
// two processes running the same shard at once share its work and never
// tear an output. A recording whose output checks is skipped, so a killed
// shard resumes where it stopped; one whose output does not check is redone.
// OUT/summary-shard-I-of-N.json says what was done. One recording's work:
// cli/backfill_recording.h.
#include <malloc.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/strings/str_cat.h"
#include "absl/synchronization/mutex.h"
#include "backfill_manifest.h"
#include "backfill_output.h"
#include "backfill_recording.h"
#include "commands.h"
#include "io/input_file.h"
#include "io/inputs.h"
#include "io/results_json.h"
#include "io/video_input.h"
#include "lane/config/config.h"
#include "lane/detector/detector.h"
#include "lane/track/frame_tracker.h"

namespace lane::cli {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr char kBackfillDescription[] =
    "Re-processes recorded drives listed in a manifest, in shards that can run\n"
    "anywhere (a Kubernetes Indexed Job: deploy/k8s/backfill; one machine:\n"
    "scripts/backfill-local.sh). docs/backfill.md has the details.\n"
    "\n"
    "MANIFEST is JSON Lines, one recording a line (a line at most 64 KiB):\n"
    "  {\"recording\": PATH, \"config\": CONFIG, \"output\": NAME}\n"
    "PATH is a video, an image folder or a list file (as `lane detect`'s INPUT;\n"
    "regular files only: a FIFO, a socket, a device or a /proc file fails),\n"
    "CONFIG its camera's config, NAME the output's name (letters, digits, '.',\n"
    "'_', '-'); relative paths are taken from the manifest's folder.\n"
    "\n"
    "Each recording is one camera's drive, tracked in order (as lane detect\n"
    "--track); its frames are decoded and detected on --jobs threads. Results:\n"
    "OUTPUT-DIR/NAME.jsonl (docs/results-format.md), its last line a trailer\n"
    "(frame count and SHA-256 of the lines before it); written under a name of\n"
    "this process's own and renamed into place when complete. A recording whose\n"
    "NAME.jsonl checks against its trailer is skipped; one whose output does not\n"
    "check (cut short, no trailer) is redone. Two processes running the same\n"
    "shard at once share it: each recording is claimed (a lock beside the\n"
    "output), a recording claimed by the other process is left to it and waited\n"
    "for at the end, and an output is published only where none exists. The\n"
    "shard's summary: OUTPUT-DIR/summary-shard-I-of-N.json.\n"
    "\n"
    "--verify checks OUTPUT-DIR against the manifest without computing\n"
    "anything: every output present and whole.";

constexpr char kBackfillFooter[] =
    "Exit status: 0 when every recording of the shard was done (or skipped) with\n"
    "no failed frame, 1 when a recording or a frame failed (see the summary),\n"
    "2 for a bad command line or manifest. With --verify: 0 when every output is\n"
    "there and whole, 1 when one is missing or torn, 2 for a bad command line or\n"
    "manifest.";

struct BackfillFlags {
  std::string manifest;
  std::string output_dir;
  std::string shard = "0/1";
  int jobs = 0;
  bool quiet = false;
  bool verify = false;
  int64_t max_image_bytes = io::kDefaultMaxImageBytes;
};
double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// --verify: every output of the manifest (or of the shard's share) present
// and whole; nothing is computed.
int RunVerify(const CLI::App& app, const BackfillFlags& flags, std::optional<ShardSpec> shard) {
  absl::StatusOr<std::vector<BackfillRecording>> all =
      ReadBackfillManifest(flags.manifest, /*with_sizes=*/shard.has_value());
  if (!all.ok()) return io::UsageError(app, std::string(all.status().message()));
  const std::vector<BackfillRecording> mine = shard ? ShareOfShard(*all, *shard) : *all;
  int ok = 0, missing = 0, torn = 0;
  long frames = 0;
  for (const BackfillRecording& r : mine) {
    const std::string path = (fs::path(flags.output_dir) / (r.output + ".jsonl")).string();
    const OutputCheck check = CheckBackfillOutput(path);
    switch (check.state) {
      case OutputCheck::kOk:
        ++ok;
        frames += check.frames;
        break;
      case OutputCheck::kMissing:
        ++missing;
        std::printf("missing %s\n", path.c_str());
        break;
      case OutputCheck::kTorn:
        ++torn;
        std::printf("torn %s: %s\n", path.c_str(), check.reason.c_str());
        break;
    }
  }
  std::fflush(stdout);
  if (!flags.quiet || missing + torn > 0) {
    std::fprintf(stderr,
                 "lane backfill --verify: %zu outputs: %d whole (%ld frames), %d missing, %d "
                 "torn\n",
                 mine.size(), ok, frames, missing, torn);
  }
  return missing + torn > 0 ? io::kExitFailure : io::kExitOk;
}

// The shard's recordings, in order, each processed (ProcessRecording);
// those another process holds are left to it, then waited for at the end:
// done by it (skipped here), or, if it died or failed, done here.
std::vector<RecordingResult> RunShare(const std::vector<BackfillRecording>& mine,
                                      const BackfillFlags& flags, ShardSpec shard, int jobs) {
  std::vector<RecordingResult> results(mine.size());
  const auto report = [&](size_t k) {
    const RecordingResult& res = results[k];
    if (!flags.quiet || res.status == "failed") {
      std::fprintf(stderr, "lane backfill: shard %d/%d: %s: %s%s%s (%ld frames, %ld failed)%s\n",
                   shard.index, shard.count, mine[k].output.c_str(), res.status.c_str(),
                   res.error.empty() ? "" : ": ", res.error.c_str(), res.frames, res.failed_frames,
                   res.claimed_elsewhere ? " (claimed by another process first)" : "");
    }
  };
  BackfillWorkers workers(jobs);
  BackfillContext ctx;
  ctx.out_dir = flags.output_dir;
  ctx.workers = &workers;
  ctx.max_image_bytes = flags.max_image_bytes;
  ctx.partials = ListPartialOutputs(flags.output_dir);
  std::vector<size_t> deferred;
  for (size_t k = 0; k < mine.size(); ++k) {
    results[k] = ProcessRecording(mine[k], ctx, /*wait=*/false);
    if (results[k].status == "claimed_elsewhere") {
      deferred.push_back(k);
      continue;
    }
    report(k);
  }
  for (size_t k : deferred) {
    if (!flags.quiet) {
      std::fprintf(stderr,
                   "lane backfill: shard %d/%d: %s: claimed by another process; waiting for it\n",
                   shard.index, shard.count, mine[k].output.c_str());
    }
    results[k] = ProcessRecording(mine[k], ctx, /*wait=*/true);
    results[k].claimed_elsewhere = true;
    report(k);
  }
  return results;
}

// OUTPUT-DIR/summary-shard-I-of-N.json's content.
Json ShardSummary(const std::vector<BackfillRecording>& mine,
                  const std::vector<RecordingResult>& results, const BackfillFlags& flags,
                  ShardSpec shard, int jobs, double wall_s) {
  Json summary = Json::object();
  summary["schema"] = 1;
  summary["shard"] = shard.index;
  summary["shards"] = shard.count;
  summary["manifest"] = flags.manifest;
  summary["jobs"] = jobs;
  summary["version"] = io::VersionString();
  Json list = Json::array();
  long frames = 0, failed_frames = 0, lanes = 0;
  int failed = 0, done = 0, redone = 0, skipped = 0, claimed = 0;
  const auto per_frame = [](long n, long frames_, long failed_) {
    return frames_ > failed_ ? static_cast<double>(n) / static_cast<double>(frames_ - failed_)
                             : 0.0;
  };
  for (size_t k = 0; k < mine.size(); ++k) {
    const RecordingResult& res = results[k];
    Json e = Json::object();
    e["output"] = mine[k].output;
    e["recording"] = mine[k].recording;
    e["status"] = res.status;
    if (!res.error.empty()) e["error"] = res.error;
    if (!res.redo_reason.empty()) e["redone_because"] = res.redo_reason;
    if (res.claimed_elsewhere) e["claimed_elsewhere"] = true;
    if (res.removed_partials > 0) e["removed_partials"] = res.removed_partials;
    e["frames"] = res.frames;
    e["failed_frames"] = res.failed_frames;
    e["lanes_per_frame"] = per_frame(res.lanes, res.frames, res.failed_frames);
    e["wall_s"] = res.wall_s;
    e["bytes"] = mine[k].bytes;
    list.push_back(e);
    frames += res.frames;
    failed_frames += res.failed_frames;
    lanes += res.lanes;
    failed += res.status == "failed" ? 1 : 0;
    done += res.status == "done" ? 1 : 0;
    redone += res.status == "redone" ? 1 : 0;
    skipped += res.status == "skipped" ? 1 : 0;
    claimed += res.claimed_elsewhere ? 1 : 0;
  }
  summary["recordings"] = list;
  summary["done"] = done;
  summary["redone"] = redone;
  summary["skipped"] = skipped;
  summary["failed"] = failed;
  summary["claimed_elsewhere"] = claimed;
  summary["frames"] = frames;
  summary["failed_frames"] = failed_frames;
  summary["lanes_per_frame"] = per_frame(lanes, frames, failed_frames);
  summary["wall_s"] = wall_s;
  summary["frames_per_s"] = wall_s > 0 ? static_cast<double>(frames) / wall_s : 0.0;
  return summary;
}

int RunBackfill(const CLI::App& app, const BackfillFlags& flags) {
  absl::StatusOr<ShardSpec> shard = ParseShardSpec(flags.shard);
  if (!shard.ok()) return io::UsageError(app, std::string(shard.status().message()));
  if (flags.verify) {
    const bool shard_given = app.count("--shard") > 0;
    return RunVerify(app, flags, shard_given ? std::optional<ShardSpec>(*shard) : std::nullopt);
  }
  absl::StatusOr<std::vector<BackfillRecording>> all =
      ReadBackfillManifest(flags.manifest, /*with_sizes=*/true);
  if (!all.ok()) return io::UsageError(app, std::string(all.status().message()));
  std::error_code ec;
  fs::create_directories(flags.output_dir, ec);
  if (!fs::is_directory(flags.output_dir)) {
    return Failure("backfill", absl::StrCat("cannot create ", flags.output_dir));
  }
  const int jobs = std::clamp(
      flags.jobs > 0 ? flags.jobs : static_cast<int>(std::thread::hardware_concurrency()), 1,
      kBackfillWindow);
  // Frames run in parallel, one per thread: OpenCV's own threads would only
  // compete with them (as in lane-server, --opencv_threads 1).
  cv::setNumThreads(1);
  // Every frame's images (2.9 MB for a 1640x590 BGR frame) are allocated and
  // freed again. Above glibc's mmap threshold each is a fresh mmap, its pages
  // faulted in and its munmap a TLB shootdown across the cores: measured, two
  // threads then ran no faster than one (1640x590: 406 against 401
  // frames/s). Kept in the heap, they are reused: 694-828 frames/s.
  mallopt(M_MMAP_THRESHOLD, 64 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
  const std::vector<BackfillRecording> mine = ShareOfShard(*all, *shard);
  const auto start = Clock::now();
  const std::vector<RecordingResult> results = RunShare(mine, flags, *shard, jobs);
  const Json summary = ShardSummary(mine, results, flags, *shard, jobs, SecondsSince(start));
  const std::string name =
      absl::StrCat("summary-shard-", shard->index, "-of-", shard->count, ".json");
  // Through a temporary file of this process's own: two processes of one
  // shard each write theirs whole, the last one stays.
  if (absl::Status s = ReplaceFileDurably(flags.output_dir, name, summary.dump(2) + "\n");
      !s.ok()) {
    return Failure("backfill", std::string(s.message()));
  }
  if (!flags.quiet) {
    const std::string path = (fs::path(flags.output_dir) / name).string();
    std::fprintf(stderr,
                 "lane backfill: shard %d/%d: %zu recordings (%d done, %d redone, %d skipped, %d "
                 "failed; %d claimed by another process first), %ld frames (%ld failed) in "
                 "%.1f s; %s\n",
                 shard->index, shard->count, mine.size(), summary["done"].get<int>(),
                 summary["redone"].get<int>(), summary["skipped"].get<int>(),
                 summary["failed"].get<int>(), summary["claimed_elsewhere"].get<int>(),
                 summary["frames"].get<long>(), summary["failed_frames"].get<long>(),
                 summary["wall_s"].get<double>(), path.c_str());
  }
  return summary["failed"].get<int>() > 0 || summary["failed_frames"].get<long>() > 0
             ? io::kExitFailure
             : io::kExitOk;
}

}  // namespace

io::Command AddBackfillCommand(CLI::App& lane) {
  auto flags = std::make_shared<BackfillFlags>();
  CLI::App* app =
      io::AddCommand(lane, "backfill",
                     "re-process a manifest of recordings in shards (Kubernetes Indexed "
                     "Jobs, or processes on one machine)",
                     kBackfillDescription, kBackfillFooter);
  app->add_option("--manifest", flags->manifest, "JSON Lines: recording, config, output")
      ->type_name("FILE")
      ->required();
  app->add_option("--output-dir", flags->output_dir, "where NAME.jsonl and the summary go")
      ->type_name("DIR")
      ->required();
  app->add_option("--shard", flags->shard,
                  "this process's share: shard I of N (0-based; default 0/1, everything); a "
                  "shard beyond the manifest's length has nothing to do")
      ->type_name("I/N");
  app->add_option("--jobs", flags->jobs,
                  "threads decoding and detecting a recording's frames (default: the cores, "
                  "at most 8)")
      ->type_name("J");
  app->add_option("--max-image-bytes", flags->max_image_bytes,
                  "an image file larger than this fails before it is read, and one declaring a "
                  "frame of more than this many bytes as BGR (width x height x 3) before it is "
                  "decoded (64 MiB: a 16-megapixel frame is 48 MiB)")
      ->type_name("BYTES")
      ->check(CLI::PositiveNumber);
  app->add_flag("--verify", flags->verify,
                "check OUTPUT-DIR against the manifest (every output there and whole: its "
                "trailer checks) without computing anything; with --shard, that shard's share");
  app->add_flag("--quiet,-q", flags->quiet, "print only failures and errors on stderr");
  return {app, [app, flags] { return RunBackfill(*app, *flags); }};
}

}  // namespace lane::cli
