// `lane backfill`: a fleet's recordings re-processed in shards (docs/backfill.md).
//
//   lane backfill --manifest M.jsonl --output-dir OUT [--shard I/N] [--jobs J]
//
// The manifest is JSON Lines, one recording a line:
//   {"recording": "drives/cam7-0412.mp4", "config": "configs/cam7.json",
//    "output": "cam7-0412"}
// (relative paths against the manifest's folder). Shard I of N takes a
// deterministic share, balanced by the recordings' sizes on disk. Each
// recording is one camera's frames, tracked in order: its results go to
// OUT/OUTPUT.jsonl, written under a temporary name and renamed when complete.
// A recording whose output exists is skipped, so a killed shard resumes
// where it stopped. OUT/summary-shard-I-of-N.json says what was done.
#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "cli/cli_config.h"
#include "cli/inputs.h"
#include "cli/results_json.h"
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
    "MANIFEST is JSON Lines, one recording a line:\n"
    "  {\"recording\": PATH, \"config\": CONFIG, \"output\": NAME}\n"
    "PATH is a video, an image folder or a list file (as `lane detect`'s INPUT),\n"
    "CONFIG its camera's config, NAME the output's name (letters, digits, '.',\n"
    "'_', '-'); relative paths are taken from the manifest's folder.\n"
    "\n"
    "Each recording is one camera's drive, tracked in order (as lane detect\n"
    "--track); its frames are decoded and detected on --jobs threads. Results:\n"
    "OUTPUT-DIR/NAME.jsonl (docs/results-format.md), renamed into place when\n"
    "complete; a recording whose NAME.jsonl exists is skipped. The shard's\n"
    "summary: OUTPUT-DIR/summary-shard-I-of-N.json.";

constexpr char kBackfillFooter[] =
    "Exit status: 0 when every recording of the shard was done (or skipped) with\n"
    "no failed frame, 1 when a recording or a frame failed (see the summary),\n"
    "2 for a bad command line or manifest.";

// Frames in flight per recording, and the tracker's prior lag: frame i is
// detected with the tracker's state after frame i - kWindow (the lanes do not
// depend on the threads' timing, nor on --jobs up to kWindow).
constexpr int kWindow = 8;

struct BackfillFlags {
  std::string manifest;
  std::string output_dir;
  std::string shard = "0/1";
  int jobs = 0;
  bool quiet = false;
};

struct Recording {
  int line = 0;  // in the manifest, from 1
  std::string recording;
  std::string config;
  std::string output;
  uintmax_t bytes = 0;  // the recording's size on disk, the shard's balance
};

bool ValidOutputName(const std::string& name) {
  if (name.empty() || name.size() > 200 || name[0] == '.') return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
  });
}

// The manifest's recordings, or why it cannot be used.
absl::StatusOr<std::vector<Recording>> ReadManifest(const std::string& path) {
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot read the manifest ", path));
  const fs::path base = fs::absolute(path).parent_path();
  const auto resolve = [&base](const std::string& p) {
    return fs::path(p).is_absolute() ? p : (base / p).lexically_normal().string();
  };
  std::vector<Recording> recordings;
  std::set<std::string> outputs;
  std::string text;
  for (int line = 1; std::getline(in, text); ++line) {
    if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
    const Json j = Json::parse(text, nullptr, false);
    const auto where = absl::StrCat(path, ":", line, ": ");
    if (j.is_discarded() || !j.is_object()) {
      return absl::InvalidArgumentError(absl::StrCat(where, "not a JSON object"));
    }
    for (const char* key : {"recording", "config", "output"}) {
      if (!j.contains(key) || !j[key].is_string() || j[key].get<std::string>().empty()) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, "\"", key, "\" must be a non-empty string"));
      }
    }
    Recording r;
    r.line = line;
    r.recording = resolve(j["recording"].get<std::string>());
    r.config = resolve(j["config"].get<std::string>());
    r.output = j["output"].get<std::string>();
    if (!ValidOutputName(r.output)) {
      return absl::InvalidArgumentError(absl::StrCat(
          where, "output \"", r.output, "\" must be letters, digits, '.', '_' or '-'"));
    }
    if (!outputs.insert(r.output).second) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, "output \"", r.output, "\" is used twice"));
    }
    for (const InputEntry& e : ExpandInputs({r.recording})) {
      std::error_code ec;
      const uintmax_t size = fs::file_size(e.path, ec);
      if (!ec) r.bytes += size;
    }
    recordings.push_back(std::move(r));
  }
  if (recordings.empty()) return absl::InvalidArgumentError(path + " lists no recording");
  return recordings;
}

// Shard i of n: the largest recordings first, each to the shard with the
// least bytes so far (ties: the lower shard; equal sizes: manifest order).
// Every shard computes the same assignment, so any one can run alone.
std::vector<Recording> ShareOf(const std::vector<Recording>& all, int shard, int shards) {
  std::vector<size_t> order(all.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&all](size_t a, size_t b) { return all[a].bytes > all[b].bytes; });
  std::vector<uintmax_t> load(static_cast<size_t>(shards), 0);
  std::vector<int> owner(all.size(), 0);
  for (size_t k : order) {
    const auto least = std::min_element(load.begin(), load.end());
    owner[k] = static_cast<int>(least - load.begin());
    *least += std::max<uintmax_t>(all[k].bytes, 1);
  }
  std::vector<Recording> mine;
  for (size_t k = 0; k < all.size(); ++k) {
    if (owner[k] == shard) mine.push_back(all[k]);
  }
  return mine;
}

// A fixed set of threads running tasks in submission order.
class Workers {
 public:
  explicit Workers(int n) {
    for (int i = 0; i < n; ++i) threads_.emplace_back([this] { Loop(); });
  }
  ~Workers() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      done_ = true;
    }
    cv_.notify_all();
    for (std::thread& t : threads_) t.join();
  }
  void Submit(std::function<void()> task) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      tasks_.push_back(std::move(task));
    }
    cv_.notify_one();
  }

 private:
  void Loop() {
    for (;;) {
      std::function<void()> task;
      {
        std::unique_lock<std::mutex> lock(mu_);
        cv_.wait(lock, [this] { return done_ || !tasks_.empty(); });
        if (tasks_.empty()) return;
        task = std::move(tasks_.front());
        tasks_.pop_front();
      }
      task();
    }
  }
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> tasks_;
  bool done_ = false;
  std::vector<std::thread> threads_;
};

// One frame on its way: read (and decoded) on a worker or by the video
// reader, detected on a worker, then tracked and written in order.
struct Slot {
  InputFrame frame;
  absl::StatusOr<lane::Detection> detection = lane::Detection();
  std::mutex mu;
  std::condition_variable cv;
  bool ready = false;

  void Finish() {
    {
      std::lock_guard<std::mutex> lock(mu);
      ready = true;
    }
    cv.notify_all();
  }
  void Wait() {
    std::unique_lock<std::mutex> lock(mu);
    cv.wait(lock, [this] { return ready; });
  }
};

struct RecordingResult {
  std::string status;  // done, skipped, failed
  std::string error;
  long frames = 0;
  long failed_frames = 0;
  long lanes = 0;
  double wall_s = 0;
};

class RecordingRun {
 public:
  RecordingRun(const lane::Config& config, const lane::Detector& detector, Workers& workers,
               std::ostream& out)
      : config_(config),
        detector_(detector),
        tracker_(config.camera),
        workers_(workers),
        out_(out) {}

  // Every frame of `inputs`, in order.
  void Run(const std::vector<InputEntry>& entries) {
    for (const InputEntry& entry : entries) {
      if (entry.kind == InputEntry::kVideo) {
        // A video decodes in order, here; its frames are detected on the workers.
        FrameReader reader({entry.path});
        auto slot = std::make_shared<Slot>();
        while (reader.Next(&slot->frame)) {
          slot->frame.name = VideoFrameName(entry.name, video_index_++);
          Submit(slot, /*decode=*/nullptr);
          slot = std::make_shared<Slot>();
        }
        video_index_ = 0;
        continue;
      }
      auto slot = std::make_shared<Slot>();
      slot->frame.name = entry.name;
      if (entry.kind == InputEntry::kError) {
        slot->frame.error = entry.error;
        Submit(slot, nullptr);
        continue;
      }
      // An image: read and decoded on a worker (only the detector's rows and
      // channel, as lane detect does).
      const std::string path = entry.path;
      const std::string name = entry.name;
      Submit(slot, [this, path, name](InputFrame* frame) {
        FrameReader reader({path});
        reader.DecodeOnly(detector_.Needs(), config_.camera.image_width,
                          config_.camera.image_height);
        if (!reader.Next(frame)) frame->error = "no frame";
        frame->name = name;
      });
    }
    while (!window_.empty()) CommitOldest();
  }

  long frames() const { return frames_; }
  long failed() const { return failed_; }
  long lanes() const { return lanes_; }

 private:
  // Frame i's prior is taken after frame i - kWindow is committed: the
  // window is full, the oldest is committed first.
  void Submit(const std::shared_ptr<Slot>& slot, std::function<void(InputFrame*)> decode) {
    if (static_cast<int>(window_.size()) >= kWindow) CommitOldest();
    const lane::DetectionPrior prior = tracker_.Prior(detector_);
    window_.push_back(slot);
    workers_.Submit([this, slot, decode = std::move(decode), prior] {
      if (decode) decode(&slot->frame);
      Detect(*slot, prior);
      slot->Finish();
    });
  }

  void Detect(Slot& slot, const lane::DetectionPrior& prior) const {
    InputFrame& f = slot.frame;
    if (f.error.empty() &&
        (f.bgr.cols != config_.camera.image_width || f.bgr.rows != config_.camera.image_height)) {
      f.error = absl::StrCat("frame is ", f.bgr.cols, "x", f.bgr.rows, " but the camera expects ",
                             config_.camera.image_width, "x", config_.camera.image_height,
                             " (camera.image_width/image_height)");
    }
    if (!f.error.empty()) return;
    try {
      slot.detection = tracker_.Measure(detector_, f.bgr, prior);
      if (!slot.detection.ok()) f.error = std::string(slot.detection.status().message());
    } catch (const std::exception& e) {
      f.error = absl::StrCat("detector error: ", e.what());
    }
  }

  void CommitOldest() {
    std::shared_ptr<Slot> slot = window_.front();
    window_.pop_front();
    slot->Wait();
    ++frames_;
    const InputFrame& f = slot->frame;
    const lane::Mode mode = detector_.options().mode;
    const int width = config_.camera.image_width, height = config_.camera.image_height;
    if (!f.error.empty()) {
      ++failed_;
      out_ << ErrorJsonLine(f.name, width, height, mode, f.error) << '\n';
      return;
    }
    tracker_.Commit(detector_, *slot->detection, std::nullopt);
    lanes_ += static_cast<long>(slot->detection->lanes.size());
    out_ << DetectionJsonLine(f.name, width, height, mode, *slot->detection, f.decode_ms, true)
         << '\n';
  }

  const lane::Config& config_;
  const lane::Detector& detector_;
  lane::FrameTracker tracker_;
  Workers& workers_;
  std::ostream& out_;
  std::deque<std::shared_ptr<Slot>> window_;
  int video_index_ = 0;
  long frames_ = 0, failed_ = 0, lanes_ = 0;
};

RecordingResult ProcessRecording(const Recording& r, const fs::path& out_dir, Workers& workers) {
  RecordingResult result;
  const auto start = Clock::now();
  const fs::path final_path = out_dir / (r.output + ".jsonl");
  if (fs::exists(final_path)) {
    result.status = "skipped";
    return result;
  }
  const auto fail = [&result, &start](const std::string& error) {
    result.status = "failed";
    result.error = error;
    result.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
    return result;
  };
  absl::StatusOr<lane::Config> config = LoadEffectiveConfig(r.config, std::nullopt);
  if (!config.ok()) return fail(std::string(config.status().message()));
  absl::StatusOr<lane::Detector> detector =
      lane::Detector::Create(config->camera, config->ipm, config->detector);
  if (!detector.ok()) return fail(std::string(detector.status().message()));
  const std::vector<InputEntry> entries = ExpandInputs({r.recording});
  // The partial output has a fixed name: a re-run after a kill replaces it.
  const fs::path partial = out_dir / ("." + r.output + ".jsonl.partial");
  std::ofstream out(partial, std::ios::trunc);
  if (!out) return fail(absl::StrCat("cannot write ", partial.string()));
  RecordingRun run(*config, *detector, workers, out);
  run.Run(entries);
  out.close();
  result.frames = run.frames();
  result.failed_frames = run.failed();
  result.lanes = run.lanes();
  std::error_code ec;
  if (!out) {
    fs::remove(partial, ec);
    return fail(absl::StrCat("error writing ", partial.string()));
  }
  if (result.frames == 0 || result.failed_frames == result.frames) {
    fs::remove(partial, ec);  // nothing usable: a re-run tries again
    return fail(result.frames == 0
                    ? std::string("the recording has no frames")
                    : absl::StrCat("all ", result.frames, " frames failed; the first: ",
                                   entries.empty() ? "" : entries.front().name));
  }
  fs::rename(partial, final_path, ec);
  if (ec) return fail(absl::StrCat("cannot rename ", partial.string(), ": ", ec.message()));
  result.status = "done";
  result.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  return result;
}

int RunBackfill(const CLI::App& app, const BackfillFlags& flags) {
  int shard = 0, shards = 1;
  const std::vector<std::string> parts = absl::StrSplit(flags.shard, '/');
  if (parts.size() != 2 || !absl::SimpleAtoi(parts[0], &shard) ||
      !absl::SimpleAtoi(parts[1], &shards) || shards < 1 || shard < 0 || shard >= shards) {
    return UsageError(app, absl::StrCat("--shard ", flags.shard, ": expected I/N, 0 <= I < N"));
  }
  absl::StatusOr<std::vector<Recording>> all = ReadManifest(flags.manifest);
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
  const std::vector<Recording> mine = ShareOf(*all, shard, shards);
  const auto start = Clock::now();
  Json summary = Json::object();
  summary["schema"] = 1;
  summary["shard"] = shard;
  summary["shards"] = shards;
  summary["manifest"] = flags.manifest;
  summary["jobs"] = jobs;
  Json list = Json::array();
  long frames = 0, failed_frames = 0, lanes = 0;
  int failed = 0, done = 0, skipped = 0;
  {
    Workers workers(jobs);
    for (const Recording& r : mine) {
      const RecordingResult res = ProcessRecording(r, flags.output_dir, workers);
      Json e = Json::object();
      e["output"] = r.output;
      e["recording"] = r.recording;
      e["status"] = res.status;
      if (!res.error.empty()) e["error"] = res.error;
      e["frames"] = res.frames;
      e["failed_frames"] = res.failed_frames;
      e["lanes_per_frame"] =
          res.frames > res.failed_frames
              ? static_cast<double>(res.lanes) / static_cast<double>(res.frames - res.failed_frames)
              : 0.0;
      e["wall_s"] = res.wall_s;
      e["bytes"] = r.bytes;
      list.push_back(e);
      frames += res.frames;
      failed_frames += res.failed_frames;
      lanes += res.lanes;
      failed += res.status == "failed" ? 1 : 0;
      done += res.status == "done" ? 1 : 0;
      skipped += res.status == "skipped" ? 1 : 0;
      if (!flags.quiet || res.status == "failed") {
        std::fprintf(stderr, "lane backfill: shard %d/%d: %s: %s%s%s (%ld frames, %ld failed)\n",
                     shard, shards, r.output.c_str(), res.status.c_str(),
                     res.error.empty() ? "" : ": ", res.error.c_str(), res.frames,
                     res.failed_frames);
      }
    }
  }
  const double wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  summary["recordings"] = list;
  summary["done"] = done;
  summary["skipped"] = skipped;
  summary["failed"] = failed;
  summary["frames"] = frames;
  summary["failed_frames"] = failed_frames;
  summary["lanes_per_frame"] =
      frames > failed_frames ? static_cast<double>(lanes) / (frames - failed_frames) : 0.0;
  summary["wall_s"] = wall_s;
  summary["frames_per_s"] = wall_s > 0 ? frames / wall_s : 0.0;
  const fs::path path =
      fs::path(flags.output_dir) / absl::StrCat("summary-shard-", shard, "-of-", shards, ".json");
  const fs::path tmp = path.string() + ".partial";
  {
    std::ofstream s(tmp, std::ios::trunc);
    s << summary.dump(2) << '\n';
    if (!s) return Failure("backfill", absl::StrCat("cannot write ", tmp.string()));
  }
  fs::rename(tmp, path, ec);
  if (ec) return Failure("backfill", absl::StrCat("cannot write ", path.string()));
  if (!flags.quiet) {
    std::fprintf(stderr,
                 "lane backfill: shard %d/%d: %zu recordings (%d done, %d skipped, %d failed), "
                 "%ld frames (%ld failed) in %.1f s; %s\n",
                 shard, shards, mine.size(), done, skipped, failed, frames, failed_frames, wall_s,
                 path.c_str());
  }
  return failed > 0 || failed_frames > 0 ? kExitFailure : kExitOk;
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
                  "this process's share: shard I of N (0-based; default 0/1, everything)")
      ->type_name("I/N");
  app->add_option("--jobs", flags->jobs,
                  "threads decoding and detecting a recording's frames (default: the cores, "
                  "at most 8)")
      ->type_name("J");
  app->add_flag("--quiet,-q", flags->quiet, "print only failures and errors on stderr");
  return {app, [app, flags] { return RunBackfill(*app, *flags); }};
}

}  // namespace lane_tools
