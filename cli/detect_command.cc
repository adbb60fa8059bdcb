// `lane detect`: lanes in images, directories, list files and videos, as
// JSON Lines (docs/results-format.md), with optional overlay pictures.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "commands.h"
#include "io/cli_config.h"
#include "io/inputs.h"
#include "io/overlay.h"
#include "io/overlay_video.h"
#include "io/progress_bar.h"
#include "io/results_json.h"
#include "lane/config/config.h"
#include "lane/detector/detector.h"
#include "lane/track/frame_tracker.h"

namespace lane::cli {
namespace {

constexpr char kDetectDescription[] =
    "Detects the lane markings of every frame and writes one JSON object per\n"
    "frame (JSON Lines, schema 1: docs/results-format.md).\n"
    "\n"
    "INPUT is an image file; a directory (its .jpg/.jpeg/.png files, sorted by\n"
    "name, not recursive); a list file (.txt: one path a line, relative paths\n"
    "resolved against the list's folder, blank lines and # comments skipped);\n"
    "or a video (.mp4/.avi/.mkv/.mov; frames are named VIDEO#000123).";

constexpr char kDetectFooter[] =
    "A frame that cannot be read or processed gets a record with \"error\" and\n"
    "a message on stderr; the other frames go on. Exit status: 0 when every\n"
    "frame was processed, 1 when some failed, 2 for a bad command line.";

struct DetectFlags {
  std::string config;
  std::optional<std::string> mode;
  std::optional<uint64_t> seed;
  std::optional<std::string> output;
  std::optional<std::string> overlay;
  std::optional<std::string> overlay_video;
  bool full_decode = false;
  bool track = false;
  bool quiet = false;
  bool no_progress = false;
  io::ReadFlags read;
  std::vector<std::string> inputs;
};

double Median(std::vector<double> values) {
  if (values.empty()) return 0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  const double upper = values[mid];
  if (values.size() % 2 == 1) return upper;
  return 0.5 * (upper + *std::max_element(values.begin(), values.begin() + mid));
}

// The effective config and its detector.
struct ConfiguredDetector {
  lane::Config config;
  lane::Detector detector;
};

// The detector of the effective config; prints the top view's scale, which
// users need to read the IPM coordinates.
absl::StatusOr<ConfiguredDetector> MakeDetector(const DetectFlags& flags) {
  absl::StatusOr<lane::Config> config = io::LoadEffectiveConfig(flags.config, flags.mode);
  if (!config.ok()) return config.status();
  if (flags.seed) config->detector.seed = *flags.seed;
  absl::StatusOr<lane::Detector> detector =
      lane::Detector::Create(config->camera, config->ipm, config->detector);
  if (!detector.ok()) {
    return absl::Status(detector.status().code(),
                        absl::StrCat("cannot build the detector: ", detector.status().message()));
  }
  const lane::IpmMapping& ipm = detector->ipm();
  if (!flags.quiet) {
    std::fprintf(stderr,
                 "lane detect: top view %dx%d px covering x %.2f..%.2f m, y %.2f..%.2f m ahead: "
                 "%.4f m/px across, %.4f m/px along; filter sigmas %.2f x %.2f px\n",
                 ipm.width(), ipm.height(), ipm.x_min(), ipm.x_max(), ipm.y_min(), ipm.y_max(),
                 ipm.metres_per_px_x(), ipm.metres_per_px_y(), detector->kernels().sigma_x_px,
                 detector->kernels().sigma_y_px);
  }
  return ConfiguredDetector{*std::move(config), *std::move(detector)};
}

// Creates the overlay folder; an error message or "".
std::string MakeOverlayDir(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir)) {
    return absl::StrCat("cannot create overlay folder ", dir,
                        ec ? ": " + ec.message() : std::string());
  }
  return "";
}

// The frames of one run through the detector, their results to `out`.
class DetectRun {
 public:
  DetectRun(const lane::Detector& detector, const lane::Config& config, std::ostream& out,
            std::filesystem::path overlay_dir, std::optional<std::string> overlay_video,
            double video_fps, bool quiet)
      : quiet_(quiet),
        overlay_video_path_(std::move(overlay_video)),
        video_fps_(video_fps),
        detector_(detector),
        mode_(detector.options().mode),
        expected_width_(config.camera.image_width),
        expected_height_(config.camera.image_height),
        out_(out),
        overlay_dir_(std::move(overlay_dir)) {}

  // Frames in the given order are one camera's: lanes get ids, colours and
  // the ego lane (lane/track/frame_tracker.h). `fps`: their rate (0: 30/s).
  void EnableTracking(const lane::CameraModel& camera, double fps) {
    lane::LaneTrackingOptions options;
    if (fps > 0) options.default_fps = fps;
    tracker_.emplace(camera, options);
  }

  void Process(const io::InputFrame& frame) {
    ++frames_;
    std::string error = frame.error;
    if (error.empty() &&
        (frame.bgr.cols != expected_width_ || frame.bgr.rows != expected_height_)) {
      error = absl::StrCat("frame is ", frame.bgr.cols, "x", frame.bgr.rows,
                           " but the camera expects ", expected_width_, "x", expected_height_,
                           " (camera.image_width/image_height)");
    }
    if (error.empty()) {
      try {
        // Tracked: the tracker's predicted lanes are searched too, and the
        // lanes' markings read and tracked in frame order.
        if (tracker_) {
          absl::StatusOr<lane::TrackedFrame> tracked =
              tracker_->Process(detector_, frame.bgr, std::nullopt);
          if (tracked.ok()) return Report(frame, *tracked, tracked->detection);
          error = std::string(tracked.status().message());
        } else {
          absl::StatusOr<lane::Detection> detection = detector_.Detect(frame.bgr);
          if (detection.ok()) return Report(frame, *detection, *detection);
          error = std::string(detection.status().message());
        }
      } catch (const std::exception& e) {  // e.g. a cv::Exception: this frame fails, not the run
        error = absl::StrCat("detector error: ", e.what());
      }
    }
    ++failures_;
    if (on_message_) on_message_();
    std::fprintf(stderr, "lane detect: %s: %s\n", frame.name.c_str(), error.c_str());
    if (!frame.bgr.empty()) {  // the video keeps its timing: the frame, captioned
      cv::Mat canvas = frame.bgr.channels() == 3 ? frame.bgr.clone() : cv::Mat();
      if (!canvas.empty()) {
        io::DrawCaption(canvas, frame.name, 4, 4);
        io::DrawCaption(canvas, "error: " + error, 4, 4 + canvas.rows / 20, {0, 0, 255});
        AddToVideo(frame, canvas);
      }
    }
    out_ << io::JsonLine(io::ErrorJson(ResultsOf(frame), error)) << '\n';
    out_.flush();
  }

  // Finishes the overlay video; false (after saying why) if it failed.
  bool CloseVideo() {
    if (!video_) return !video_failed_;
    const std::string error = video_->Close();
    if (!error.empty()) {
      std::fprintf(stderr, "lane detect: %s\n", error.c_str());
      return false;
    }
    if (!quiet_) {
      std::fprintf(stderr, "lane detect: %d frames in %s\n", video_->frames(),
                   overlay_video_path_->c_str());
    }
    return !video_failed_;
  }

  // Called before a message is printed (the progress bar clears its line).
  void OnMessage(std::function<void()> f) { on_message_ = std::move(f); }

  // The summary line on stderr (not with --quiet) and the exit status.
  int Finish() const {
    const int ok_frames = frames_ - failures_;
    if (!quiet_) {
      std::fprintf(stderr,
                   "lane detect: %d frames, %d failed, %.2f lanes/frame, median total %.2f ms\n",
                   frames_, failures_, ok_frames > 0 ? double(total_lanes_) / ok_frames : 0.0,
                   Median(total_ms_));
      if (tracker_) {
        // What tracking saved (docs/tracking.md, "Refitted lanes").
        const long found = refit_lanes_ + searched_lanes_;
        std::fprintf(stderr,
                     "lane detect: tracked lanes: %ld refitted in their windows (%.1f %%), %ld "
                     "searched; %ld refits fell back to the search\n",
                     refit_lanes_, found > 0 ? 100.0 * double(refit_lanes_) / double(found) : 0.0,
                     searched_lanes_, refits_failed_);
      }
    }
    if (frames_ == 0) return Failure("detect", "the inputs contain no frames");
    return failures_ > 0 || overlay_failed_ ? io::kExitFailure : io::kExitOk;
  }

 private:
  io::ResultsFrame ResultsOf(const io::InputFrame& frame) const {
    return {frame.name, frame.bgr.cols, frame.bgr.rows, mode_};
  }

  // A processed frame's record, counts and overlays: `result` is the
  // detection, or the tracked frame with `detection` its own.
  template <typename Result>
  void Report(const io::InputFrame& frame, const Result& result, const lane::Detection& detection) {
    out_ << io::JsonLine(io::DetectionJson(ResultsOf(frame), result, frame.decode_ms)) << '\n';
    out_.flush();
    total_lanes_ += static_cast<long>(LaneCount(result));
    const lane::LanePathCounts paths = lane::CountLanePaths(detection);
    refit_lanes_ += paths.refit;
    searched_lanes_ += paths.searched;
    refits_failed_ += detection.refit_failed;
    total_ms_.push_back(detection.timings.total_ms);
    const std::string details = absl::StrFormat("detect %.2f ms, decode %.2f ms",
                                                detection.timings.total_ms, frame.decode_ms);
    if (overlay_video_path_) {
      AddToVideo(frame, io::DrawLanesOnImage(frame.bgr, result, detector_, frame.name, details));
    }
    if (!overlay_dir_.empty()) {
      const std::string message =
          io::WriteOverlays(overlay_dir_, io::UniqueStem(frame.stem, used_stems_), frame.bgr,
                            result, detector_, frame.name, details);
      if (!message.empty()) {
        overlay_failed_ = true;
        if (on_message_) on_message_();
        std::fprintf(stderr, "lane detect: %s: %s\n", frame.name.c_str(), message.c_str());
      }
    }
  }
  static size_t LaneCount(const lane::Detection& detection) { return detection.lanes.size(); }
  static size_t LaneCount(const lane::TrackedFrame& tracked) { return tracked.lanes.size(); }

  void AddToVideo(const io::InputFrame& frame, const cv::Mat& drawn) {
    if (!overlay_video_path_ || video_failed_) return;
    if (!video_) {
      // --fps, else the video's own rate, else 10 frames/s.
      const double fps = video_fps_ > 0 ? video_fps_ : frame.source_fps > 0 ? frame.source_fps : 10;
      video_ = std::make_unique<io::OverlayVideo>(*overlay_video_path_, fps);
    }
    const std::string error = video_->Add(drawn);
    if (!error.empty()) {
      video_failed_ = true;
      if (on_message_) on_message_();
      std::fprintf(stderr, "lane detect: %s\n", error.c_str());
    }
  }

  const bool quiet_;
  const std::optional<std::string> overlay_video_path_;
  const double video_fps_;
  std::unique_ptr<io::OverlayVideo> video_;
  bool video_failed_ = false;
  std::function<void()> on_message_;
  const lane::Detector& detector_;
  const lane::Mode mode_;
  const int expected_width_;
  const int expected_height_;
  std::ostream& out_;
  const std::filesystem::path overlay_dir_;
  int frames_ = 0;
  int failures_ = 0;
  bool overlay_failed_ = false;
  long total_lanes_ = 0;
  long refit_lanes_ = 0;  // tracked: lanes refitted, and found by the search
  long searched_lanes_ = 0;
  long refits_failed_ = 0;
  std::vector<double> total_ms_;
  std::set<std::string> used_stems_;
  std::optional<lane::FrameTracker> tracker_;
};

int RunDetect(const DetectFlags& flags) {
  const absl::StatusOr<ConfiguredDetector> made = MakeDetector(flags);
  if (!made.ok()) return Failure("detect", std::string(made.status().message()));
  const lane::Config& config = made->config;
  const lane::Detector& detector = made->detector;

  std::ofstream file;
  if (flags.output && !io::OpenOutputFile(*flags.output, &file)) {
    return Failure("detect", absl::StrCat("cannot write ", *flags.output));
  }
  std::ostream& out = file.is_open() ? static_cast<std::ostream&>(file) : std::cout;
  if (flags.overlay) {
    if (const std::string e = MakeOverlayDir(*flags.overlay); !e.empty()) {
      return Failure("detect", e);
    }
  }

  if (flags.overlay_video) {
    if (const std::string e = io::OverlayVideo::CheckPath(*flags.overlay_video); !e.empty()) {
      return Failure("detect", e);
    }
  }
  DetectRun run(detector, config, out, flags.overlay.value_or(""), flags.overlay_video,
                flags.read.fps, flags.quiet);
  if (flags.track) run.EnableTracking(config.camera, flags.read.fps);
  io::FrameReader reader(flags.inputs, flags.read.Options());
  // JPEG frames are decoded only in the rows and channel the detector
  // reads (the same lanes), unless asked not to; overlays draw on the whole
  // frame.
  if (!flags.full_decode && !flags.overlay && !flags.overlay_video) {
    reader.DecodeOnly(detector.Needs(), config.camera.image_width, config.camera.image_height);
  }
  // A bar when the frame count is known (files), else a counter; only on a
  // terminal, never with --quiet or --no-progress.
  io::ProgressBar progress(!flags.quiet && !flags.no_progress);
  run.OnMessage([&progress] { progress.Clear(); });
  const int total = static_cast<int>(std::min<long long>(reader.KnownFrameCount(), 1 << 30));
  int done = 0;
  io::InputFrame frame;
  while (reader.Next(&frame)) {
    run.Process(frame);
    progress.Update(++done, total, frame.name);
  }
  progress.Clear();
  const bool video_ok = run.CloseVideo();
  if (!out) {
    return Failure("detect", flags.output ? absl::StrCat("error writing ", *flags.output)
                                          : std::string("error writing the results to stdout"));
  }
  const int status = run.Finish();
  return video_ok ? status : io::kExitFailure;
}

}  // namespace

io::Command AddDetectCommand(CLI::App& lane) {
  auto flags = std::make_shared<DetectFlags>();
  CLI::App* app =
      io::AddCommand(lane, "detect", "detect lanes in images, directories, list files or videos",
                     kDetectDescription, kDetectFooter);
  app->add_option("--config", flags->config, "JSON config file (docs/config.md)")
      ->type_name("CONFIG")
      ->required();
  io::OneOf(io::AddOptional(app, "--mode", &flags->mode,
                            "detector mode instead of the config's: the mode's defaults, then the "
                            "config's other detector keys"),
            {"all", "two"});
  io::AddOptional(app, "--seed", &flags->seed, "RANSAC seed instead of the config's detector.seed")
      ->type_name("N");
  io::AddOptional(app, "--output", &flags->output, "write the results to FILE instead of stdout")
      ->type_name("FILE");
  io::AddOptional(app, "--overlay", &flags->overlay,
                  "also write DIR/STEM.png (lanes on the frame) and DIR/STEM_ipm.png (lanes in the "
                  "top view)")
      ->type_name("DIR");
  io::AddOptional(
      app, "--overlay-video", &flags->overlay_video,
      "also write the frames with their lanes and a caption as one video (.mp4, .mov, "
      ".mkv: MPEG-4; .avi: Motion JPEG), at --fps or the input video's rate (else 10/s)")
      ->type_name("FILE");
  app->add_flag("--full-decode", flags->full_decode,
                "decode whole frames with OpenCV (by default JPEG frames are decoded only in "
                "the rows and channel the detector reads, which gives the same lanes)");
  io::AddReadFlags(app, &flags->read);
  app->add_flag("--track", flags->track,
                "the frames, in the given order, are one camera's: lanes get a stable id, "
                "confirmed and colour, frames the ego lane (docs/tracking.md)");
  app->add_flag("--quiet,-q", flags->quiet,
                "print only errors on stderr: no top-view line, progress or summary");
  app->add_flag("--no-progress", flags->no_progress,
                "no progress bar (it is drawn only when stderr is a terminal)");
  app->add_option("INPUT", flags->inputs,
                  "image files, directories, list files, videos, or live sources (rtsp:// or "
                  "http:// URLs, /dev/videoN, GStreamer pipelines)")
      ->required();
  return {app, [flags] { return RunDetect(*flags); }};
}

}  // namespace lane::cli
