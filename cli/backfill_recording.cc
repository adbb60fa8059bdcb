#include "backfill_recording.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "backfill_output.h"
#include "commands.h"
#include "io/input_file.h"
#include "io/results_json.h"
#include "io/video_input.h"
#include "lane/config/config.h"
#include "lane/detector/detector.h"
#include "lane/track/frame_tracker.h"

namespace lane::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// A camera's config file: refused over 1 MiB before it is read (a config is
// a few KiB; lane::ParseConfig bounds its size and depth again).
constexpr int64_t kMaxBackfillConfigBytes = int64_t{1} << 20;

// One frame on its way: read (and decoded) on a worker or by the video
// reader, detected on a worker, then tracked and written in order. `frame`
// and `measured` belong to the worker until Finish and to the committer
// after Wait.
struct Slot {
  io::InputFrame frame;
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

class RecordingRun {
 public:
  RecordingRun(const lane::Config& config, const lane::Detector& detector, BackfillWorkers& workers,
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
  void Run(const std::vector<io::InputEntry>& entries) {
    for (const io::InputEntry& entry : entries) {
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
  void RunEntry(const io::InputEntry& entry) {
    if (entry.kind == io::InputEntry::kVideo) {
      // A video decodes in order, here; its frames are detected on the workers.
      io::FrameReader reader({entry.path}, read_options_);
      auto slot = std::make_shared<Slot>();
      while (reader.Next(&slot->frame)) {
        slot->frame.name = io::VideoFrameName(entry.name, video_index_++);
        Submit(slot, /*decode=*/nullptr);
        slot = std::make_shared<Slot>();
      }
      video_index_ = 0;
      return;
    }
    if (entry.kind == io::InputEntry::kError) {
      SubmitError(entry.name, entry.error);
      return;
    }
    // An image: read and decoded on a worker (only the detector's rows and
    // channel, as lane detect does).
    auto slot = std::make_shared<Slot>();
    slot->frame.name = entry.name;
    const std::string path = entry.path;
    const std::string name = entry.name;
    Submit(slot, [this, path, name](io::InputFrame* frame) {
      io::FrameReader reader({path}, read_options_);
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

  // Frame i's prior is taken after frame i - kBackfillWindow is committed: the
  // window is full, the oldest is committed first.
  void Submit(const std::shared_ptr<Slot>& slot, std::function<void(io::InputFrame*)> decode) {
    if (static_cast<int>(window_.size()) >= kBackfillWindow) CommitOldest();
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
  absl::StatusOr<lane::MeasuredFrame> Measure(const io::InputFrame& f,
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
    const io::InputFrame& f = slot->frame;
    const io::ResultsFrame record{f.name, config_.camera.image_width, config_.camera.image_height,
                                  detector_.options().mode};
    if (!f.error.empty()) {
      ++failed_;
      if (first_error_.empty()) first_error_ = absl::StrCat(f.name, ": ", f.error);
      out_.WriteLine(io::JsonLine(io::ErrorJson(record, f.error)));
      return;
    }
    const lane::TrackedFrame tracked =
        tracker_.Commit(detector_, *std::move(slot->measured), std::nullopt);
    lanes_ += static_cast<long>(tracked.lanes.size());
    out_.WriteLine(io::JsonLine(io::DetectionJson(record, tracked, f.decode_ms)));
  }

  const lane::Config& config_;
  const lane::Detector& detector_;
  lane::FrameTracker tracker_;
  BackfillWorkers& workers_;
  PartialOutput& out_;
  io::ReadOptions read_options_;
  std::deque<std::shared_ptr<Slot>> window_;
  int video_index_ = 0;
  long frames_ = 0, failed_ = 0, lanes_ = 0;
  std::string first_error_;
};

// The recording's path, before anything reads it: a folder, or a regular
// file (a video or a list, or one image), on a real file system; never a
// live source, a FIFO, a socket, a device or a /proc file.
absl::Status CheckRecordingPath(const std::string& path) {
  if (const std::optional<io::LiveSource> live = io::ClassifyLiveSource(path)) {
    return absl::FailedPreconditionError(
        absl::StrCat(path, ": a live source (", live->kind, ") is not a recording"));
  }
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) {
    return absl::NotFoundError(absl::StrCat(path, ": ", std::strerror(errno)));
  }
  if (S_ISDIR(st.st_mode)) return io::CheckDirectory(path);
  return io::OpenRegularFile(path).status();
}

// A recording's camera config, read within bounds (io/input_file.h).
absl::StatusOr<lane::Config> LoadRecordingConfig(const std::string& path) {
  absl::StatusOr<std::string> text = io::ReadRegularFile(path, kMaxBackfillConfigBytes);
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

double RecordingSecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

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
    result.wall_s = RecordingSecondsSince(start);
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
  const std::vector<io::InputEntry> entries = io::ExpandInputs({r.recording});
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
  if (absl::Status s = (*out)->Finish(result.failed_frames, io::VersionString()); !s.ok()) {
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
  result.wall_s = RecordingSecondsSince(start);
  return result;
}

}  // namespace lane::cli
