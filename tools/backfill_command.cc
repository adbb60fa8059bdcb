// `lane backfill`: a fleet's recordings re-processed in shards (docs/backfill.md).
//
//   lane backfill --manifest M.jsonl --output-dir OUT [--shard I/N] [--jobs J]
//   lane backfill --verify --manifest M.jsonl --output-dir OUT
//
// The manifest is JSON Lines, one recording a line:
//   {"recording": "drives/cam7-0412.mp4", "config": "configs/cam7.json",
//    "output": "cam7-0412"}
// (relative paths against the manifest's folder; tools/backfill_manifest.h).
// Shard I of N takes a deterministic share, balanced by the recordings'
// sizes on disk. Each recording is one camera's frames, tracked in order:
// its results go to OUT/OUTPUT.jsonl, ended with a trailer that checks the
// whole file, written under a name of this process's own and published only
// where no output exists, under an exclusive claim (tools/backfill_output.h):
// two processes running the same shard at once share its work and never
// tear an output. A recording whose output checks is skipped, so a killed
// shard resumes where it stopped; one whose output does not check is redone.
// OUT/summary-shard-I-of-N.json says what was done.
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
#include "cli/input_file.h"
#include "cli/inputs.h"
#include "cli/results_json.h"
#include "cli/video_input.h"
#include "commands.h"
#include "lane/config/config.h"
#include "lane/detector.h"
#include "lane/track/frame_tracker.h"

namespace lane_tools {
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

// Frames in flight per recording, and the tracker's prior lag: frame i is
// detected with the tracker's state after frame i - kWindow (the lanes do not
// depend on the threads' timing, nor on --jobs up to kWindow).
constexpr int kWindow = 8;

// A camera's config file: refused over 1 MiB before it is read (a config is
// a few KiB; lane::ParseConfig bounds its size and depth again).
constexpr int64_t kMaxBackfillConfigBytes = int64_t{1} << 20;

struct BackfillFlags {
  std::string manifest;
  std::string output_dir;
  std::string shard = "0/1";
  int jobs = 0;
  bool quiet = false;
  bool verify = false;
  int64_t max_image_bytes = kDefaultMaxImageBytes;
};

// A fixed set of threads running tasks in submission order.
class Workers {
 public:
  explicit Workers(int n) {
    for (int i = 0; i < n; ++i) threads_.emplace_back([this] { Loop(); });
  }
  ~Workers() {
    {
      absl::MutexLock lock(&mu_);
      done_ = true;
    }
    for (std::thread& t : threads_) t.join();
  }
  // `task` must not throw (RecordingRun's catch everything themselves).
  void Submit(std::function<void()> task) {
    absl::MutexLock lock(&mu_);
    tasks_.push_back(std::move(task));
  }

 private:
  bool HasWorkOrDone() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) { return done_ || !tasks_.empty(); }
  void Loop() {
    for (;;) {
      std::function<void()> task;
      {
        absl::MutexLock lock(&mu_);
        mu_.Await(absl::Condition(this, &Workers::HasWorkOrDone));
        if (tasks_.empty()) return;
        task = std::move(tasks_.front());
        tasks_.pop_front();
      }
      task();
    }
  }
  absl::Mutex mu_;
  std::deque<std::function<void()>> tasks_ ABSL_GUARDED_BY(mu_);
  bool done_ ABSL_GUARDED_BY(mu_) = false;
  std::vector<std::thread> threads_;
};

// One frame on its way: read (and decoded) on a worker or by the video
// reader, detected on a worker, then tracked and written in order. `frame`
// and `measured` belong to the worker until Finish and to the committer
// after Wait.
struct Slot {
  InputFrame frame;
  absl::StatusOr<lane::MeasuredFrame> measured = lane::MeasuredFrame();

  void Finish() {
    absl::MutexLock lock(&mu);
    ready = true;
  }
  void Wait() {
    absl::MutexLock lock(&mu);
    mu.Await(absl::Condition(&ready));
  }

 private:
  absl::Mutex mu;
  bool ready ABSL_GUARDED_BY(mu) = false;
};

struct RecordingResult {
  std::string status;  // done, redone, skipped, failed; claimed_elsewhere (deferred)
  std::string error;
  std::string redo_reason;         // redone: what was wrong with the output found
  bool claimed_elsewhere = false;  // another process held it first; waited for
  int removed_partials = 0;        // dead processes' partial files removed
  long frames = 0;
  long failed_frames = 0;
  long lanes = 0;
  double wall_s = 0;
};

class RecordingRun {
 public:
  RecordingRun(const lane::Config& config, const lane::Detector& detector, Workers& workers,
               PartialOutput& out, int64_t max_image_bytes)
      : config_(config),
        detector_(detector),
        tracker_(config.camera),
        workers_(workers),
        out_(out) {
    read_options_.max_image_bytes = max_image_bytes;
  }

  // Every frame of `entries`, in order. Nothing throws out of it: an
  // exception while reading is that frame's error, and every frame in
  // flight is committed before it returns (the workers use this object).
  void Run(const std::vector<InputEntry>& entries) {
    for (const InputEntry& entry : entries) {
      try {
        RunEntry(entry);
      } catch (const std::exception& e) {
        SubmitError(entry.name, absl::StrCat("error reading ", entry.path, ": ", e.what()));
      } catch (...) {
        SubmitError(entry.name, absl::StrCat("error reading ", entry.path));
      }
    }
    while (!window_.empty()) CommitOldest();
  }

  long frames() const { return frames_; }
  long failed() const { return failed_; }
  long lanes() const { return lanes_; }
  // The first failed frame's name and error, or "".
  const std::string& first_error() const { return first_error_; }

 private:
  void RunEntry(const InputEntry& entry) {
    if (entry.kind == InputEntry::kVideo) {
      // A video decodes in order, here; its frames are detected on the workers.
      FrameReader reader({entry.path}, read_options_);
      auto slot = std::make_shared<Slot>();
      while (reader.Next(&slot->frame)) {
        slot->frame.name = VideoFrameName(entry.name, video_index_++);
        Submit(slot, /*decode=*/nullptr);
        slot = std::make_shared<Slot>();
      }
      video_index_ = 0;
      return;
    }
    if (entry.kind == InputEntry::kError) {
      SubmitError(entry.name, entry.error);
      return;
    }
    // An image: read and decoded on a worker (only the detector's rows and
    // channel, as lane detect does).
    auto slot = std::make_shared<Slot>();
    slot->frame.name = entry.name;
    const std::string path = entry.path;
    const std::string name = entry.name;
    Submit(slot, [this, path, name](InputFrame* frame) {
      FrameReader reader({path}, read_options_);
      reader.DecodeOnly(detector_.Needs(), config_.camera.image_width, config_.camera.image_height);
      if (!reader.Next(frame)) frame->error = "no frame";
      frame->name = name;
    });
  }

  void SubmitError(const std::string& name, const std::string& error) {
    auto slot = std::make_shared<Slot>();
    slot->frame.name = name;
    slot->frame.error = error;
    Submit(slot, nullptr);
  }

  // Frame i's prior is taken after frame i - kWindow is committed: the
  // window is full, the oldest is committed first.
  void Submit(const std::shared_ptr<Slot>& slot, std::function<void(InputFrame*)> decode) {
    if (static_cast<int>(window_.size()) >= kWindow) CommitOldest();
    const lane::DetectionPrior prior = tracker_.Prior(detector_);
    window_.push_back(slot);
    workers_.Submit([this, slot, decode = std::move(decode), prior] {
      // No exception leaves a worker: it is this frame's error, and the
      // slot is finished whatever happens (the committer waits for it).
      try {
        if (decode) decode(&slot->frame);
        if (slot->frame.error.empty()) {
          slot->measured = Measure(slot->frame, prior);
          if (!slot->measured.ok()) {
            slot->frame.error = std::string(slot->measured.status().message());
          }
        }
      } catch (const std::exception& e) {
        slot->frame.bgr.release();
        slot->frame.error = absl::StrCat("error: ", e.what());
      } catch (...) {
        slot->frame.bgr.release();
        slot->frame.error = "error: an unknown exception";
      }
      slot->Finish();
    });
  }

  // The frame measured with `prior`, or why it was not: the frame has the
  // wrong size, or the detector failed.
  absl::StatusOr<lane::MeasuredFrame> Measure(const InputFrame& f,
                                              const lane::DetectionPrior& prior) const {
    if (f.bgr.cols != config_.camera.image_width || f.bgr.rows != config_.camera.image_height) {
      return absl::InvalidArgumentError(
          absl::StrCat("frame is ", f.bgr.cols, "x", f.bgr.rows, " but the camera expects ",
                       config_.camera.image_width, "x", config_.camera.image_height,
                       " (camera.image_width/image_height)"));
    }
    try {
      return tracker_.Measure(detector_, f.bgr, prior);
    } catch (const std::exception& e) {
      return absl::InternalError(absl::StrCat("detector error: ", e.what()));
    }
  }

  void CommitOldest() {
    std::shared_ptr<Slot> slot = window_.front();
    window_.pop_front();
    slot->Wait();
    ++frames_;
    const InputFrame& f = slot->frame;
    const ResultsFrame record{f.name, config_.camera.image_width, config_.camera.image_height,
                              detector_.options().mode};
    if (!f.error.empty()) {
      ++failed_;
      if (first_error_.empty()) first_error_ = absl::StrCat(f.name, ": ", f.error);
      out_.WriteLine(JsonLine(ErrorJson(record, f.error)));
      return;
    }
    const lane::TrackedFrame tracked =
        tracker_.Commit(detector_, *std::move(slot->measured), std::nullopt);
    lanes_ += static_cast<long>(tracked.lanes.size());
    out_.WriteLine(JsonLine(DetectionJson(record, tracked, f.decode_ms)));
  }

  const lane::Config& config_;
  const lane::Detector& detector_;
  lane::FrameTracker tracker_;
  Workers& workers_;
  PartialOutput& out_;
  ReadOptions read_options_;
  std::deque<std::shared_ptr<Slot>> window_;
  int video_index_ = 0;
  long frames_ = 0, failed_ = 0, lanes_ = 0;
  std::string first_error_;
};

// What a shard's recordings share.
struct BackfillContext {
  std::string out_dir;
  Workers* workers = nullptr;
  int64_t max_image_bytes = kDefaultMaxImageBytes;
  // Partial outputs found in out_dir at the start, by output name; removed
  // once the output's claim is held.
  std::map<std::string, std::vector<std::string>> partials;
};

// The recording's path, before anything reads it: a folder, or a regular
// file (a video or a list, or one image), on a real file system; never a
// live source, a FIFO, a socket, a device or a /proc file.
absl::Status CheckRecordingPath(const std::string& path) {
  if (const std::optional<LiveSource> live = ClassifyLiveSource(path)) {
    return absl::FailedPreconditionError(
        absl::StrCat(path, ": a live source (", live->kind, ") is not a recording"));
  }
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) {
    return absl::NotFoundError(absl::StrCat(path, ": ", std::strerror(errno)));
  }
  if (S_ISDIR(st.st_mode)) return CheckDirectory(path);
  return OpenRegularFile(path).status();
}

// A recording's camera config, read within bounds (cli/input_file.h).
absl::StatusOr<lane::Config> LoadRecordingConfig(const std::string& path) {
  absl::StatusOr<std::string> text = ReadRegularFile(path, kMaxBackfillConfigBytes);
  if (!text.ok()) {
    return absl::Status(text.status().code(),
                        absl::StrCat("cannot read config ", text.status().message()));
  }
  absl::StatusOr<lane::Config> config = lane::ParseConfig(*text);
  if (!config.ok()) {
    return absl::Status(config.status().code(),
                        absl::StrCat(path, ": ", config.status().message()));
  }
  return config;
}

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// One recording: skipped when its output checks; claimed, else left to the
// process that holds it (status claimed_elsewhere; with `wait`, waited for);
// computed into a partial file of this process's own; published only where
// no output exists (a torn one is removed first, under the claim).
RecordingResult ProcessRecording(const BackfillRecording& r, BackfillContext& ctx, bool wait) {
  RecordingResult result;
  const auto start = Clock::now();
  const auto fail = [&result, &start](absl::string_view error) {
    result.status = "failed";
    result.error = std::string(error);
    result.wall_s = SecondsSince(start);
    return result;
  };
  const std::string final_path = (fs::path(ctx.out_dir) / (r.output + ".jsonl")).string();
  if (CheckBackfillOutput(final_path).state == OutputCheck::kOk) {
    result.status = "skipped";
    return result;
  }
  absl::StatusOr<std::optional<OutputClaim>> claim =
      OutputClaim::Acquire(ctx.out_dir, r.output, wait);
  if (!claim.ok()) return fail(claim.status().message());
  if (!claim->has_value()) {
    result.status = "claimed_elsewhere";
    return result;
  }
  // Claimed: any partial file of this output is a dead process's.
  if (auto found = ctx.partials.find(r.output);
      found != ctx.partials.end() && (*claim)->exclusive()) {
    for (const std::string& stale : found->second) {
      if (::unlink(stale.c_str()) == 0) ++result.removed_partials;
    }
    ctx.partials.erase(found);
  }
  // Published while we waited for the claim (or checked before it)?
  const OutputCheck found = CheckBackfillOutput(final_path);
  if (found.state == OutputCheck::kOk) {
    result.status = "skipped";
    return result;
  }
  const bool redo = found.state == OutputCheck::kTorn;
  if (redo) result.redo_reason = found.reason;

  if (absl::Status s = CheckRecordingPath(r.recording); !s.ok()) return fail(s.message());
  absl::StatusOr<lane::Config> config = LoadRecordingConfig(r.config);
  if (!config.ok()) return fail(config.status().message());
  absl::StatusOr<lane::Detector> detector =
      lane::Detector::Create(config->camera, config->ipm, config->detector);
  if (!detector.ok()) return fail(detector.status().message());
  const std::vector<InputEntry> entries = ExpandInputs({r.recording});
  absl::StatusOr<std::unique_ptr<PartialOutput>> out = PartialOutput::Create(ctx.out_dir, r.output);
  if (!out.ok()) return fail(out.status().message());
  RecordingRun run(*config, *detector, *ctx.workers, **out, ctx.max_image_bytes);
  run.Run(entries);
  result.frames = run.frames();
  result.failed_frames = run.failed();
  result.lanes = run.lanes();
  if (result.frames == 0) return fail("the recording has no frames");  // a re-run tries again
  if (result.failed_frames == result.frames) {
    return fail(
        absl::StrCat("all ", result.frames, " frames failed; the first: ", run.first_error()));
  }
  if (absl::Status s = (*out)->Finish(result.failed_frames, VersionString()); !s.ok()) {
    return fail(s.message());
  }
  if (redo && ::unlink(final_path.c_str()) != 0 && errno != ENOENT) {
    return fail(absl::StrCat("cannot remove the torn ", final_path, ": ", std::strerror(errno)));
  }
  if (absl::Status s = (*out)->Publish(); !s.ok()) {
    // Only a process that does not claim outputs can have put one there.
    if (absl::IsAlreadyExists(s) && CheckBackfillOutput(final_path).state == OutputCheck::kOk) {
      result.status = "skipped";
      return result;
    }
    return fail(s.message());
  }
  result.status = redo ? "redone" : "done";
  result.wall_s = SecondsSince(start);
  return result;
}

// --verify: every output of the manifest (or of the shard's share) present
// and whole; nothing is computed.
int RunVerify(const CLI::App& app, const BackfillFlags& flags, std::optional<ShardSpec> shard) {
  absl::StatusOr<std::vector<BackfillRecording>> all =
      ReadBackfillManifest(flags.manifest, /*with_sizes=*/shard.has_value());
  if (!all.ok()) return UsageError(app, std::string(all.status().message()));
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
  return missing + torn > 0 ? kExitFailure : kExitOk;
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
  Workers workers(jobs);
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
  summary["version"] = VersionString();
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
  if (!shard.ok()) return UsageError(app, std::string(shard.status().message()));
  if (flags.verify) {
    const bool shard_given = app.count("--shard") > 0;
    return RunVerify(app, flags, shard_given ? std::optional<ShardSpec>(*shard) : std::nullopt);
  }
  absl::StatusOr<std::vector<BackfillRecording>> all =
      ReadBackfillManifest(flags.manifest, /*with_sizes=*/true);
  if (!all.ok()) return UsageError(app, std::string(all.status().message()));
  std::error_code ec;
  fs::create_directories(flags.output_dir, ec);
  if (!fs::is_directory(flags.output_dir)) {
    return Failure("backfill", absl::StrCat("cannot create ", flags.output_dir));
  }
  const int jobs = std::clamp(
      flags.jobs > 0 ? flags.jobs : static_cast<int>(std::thread::hardware_concurrency()), 1,
      kWindow);
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
  return summary["failed"].get<int>() > 0 || summary["failed_frames"].get<long>() > 0 ? kExitFailure
                                                                                      : kExitOk;
}

}  // namespace

Command AddBackfillCommand(CLI::App& lane) {
  auto flags = std::make_shared<BackfillFlags>();
  CLI::App* app = AddCommand(lane, "backfill",
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

}  // namespace lane_tools
