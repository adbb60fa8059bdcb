// `lane-client stream`: a camera's recorded frames through the service, the
// lanes out as JSON Lines (docs/client.md), surviving server restarts.
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "commands.h"
#include "common.h"
#include "frames.h"
#include "io/inputs.h"
#include "io/overlay.h"
#include "io/overlay_video.h"
#include "io/progress_bar.h"
#include "lane/detector/detector.h"
#include "results.h"
#include "session_config.h"
#include "streamer.h"
#include "wire/camera_id.h"
#include "wire/config_proto.h"
#include "wire/detection_proto.h"

namespace lane::client {
namespace {

namespace v1 = lane::v1;

constexpr char kStreamDescription[] =
    "Streams the frames of INPUT to the service as one camera and writes one\n"
    "JSON object per frame, in input order (JSON Lines, schema 1: docs/client.md).\n"
    "INPUT is a directory (its .jpg/.jpeg/.png files, sorted), a list file (.txt,\n"
    "one path a line), a video (.mp4/.avi/.mkv/.mov) or an image file. JPEG and\n"
    "PNG files are sent as they are; video frames are sent as raw BGR pixels.\n"
    "\n"
    "If the stream breaks (server restart, UNAVAILABLE, lost connection), the\n"
    "client reconnects with backoff, re-creates the session and resends every\n"
    "unanswered frame: each frame appears exactly once in the output. It gives\n"
    "up, with the failure's own status, when the same status code repeats past\n"
    "--max-reconnects reconnections or no frame is answered for --retry-timeout.";

constexpr char kStreamFooter[] =
    "Without --config the camera's session must exist on the server; its config\n"
    "is read once and used to re-create it after a restart.\n"
    "Exit status: 0 when every frame was answered OK, 1 otherwise (also when the\n"
    "client gave up reconnecting), 2 for a bad command line (also a --camera id\n"
    "the server would refuse).";

struct StreamFlags {
  std::string target;
  std::string camera = "default";
  SessionConfigFlags session;
  bool replace = false;
  bool raw = false;
  std::optional<std::string> output;
  std::optional<std::string> overlay;
  std::optional<std::string> overlay_video;
  size_t window = StreamerOptions().window;
  std::optional<absl::Duration> retry_timeout;
  int max_reconnects = kDefaultMaxReconnects;
  std::optional<absl::Duration> stall_timeout;
  io::ReadFlags read;
  bool quiet = false;
  bool no_progress = false;
  std::vector<std::string> inputs;
};

// Draws the overlays of one answered frame with a detector built from the
// session's resolved config (the ROI, the horizon and the top view): PNGs in
// `dir` (when not empty) and frames of `video` (when not null).
class OverlayWriter {
 public:
  OverlayWriter(std::filesystem::path dir, io::OverlayVideo* video)
      : dir_(std::move(dir)), video_(video) {}

  // An error message or "".
  std::string Write(const StreamItem& item, const v1::FrameResponse& response,
                    const std::optional<v1::Session>& session, double latency_ms) {
    if (!detector_ || version_ != response.calibration_version()) {
      if (!session) return "no session to draw with";
      absl::StatusOr<lane::Config> config = lane::wire::ConfigFromProto(session->config());
      if (!config.ok()) return std::string(config.status().message());
      absl::StatusOr<lane::Detector> detector =
          lane::Detector::Create(config->camera, config->ipm, config->detector);
      if (!detector.ok()) return std::string(detector.status().message());
      detector_.emplace(*std::move(detector));
      version_ = response.calibration_version();
    }
    const cv::Mat frame = DecodeRequestImage(*item.request);
    if (frame.empty()) return "cannot decode the frame for the overlay";
    // The round trip as the client measured it; the server's own time.
    const std::string details =
        absl::StrFormat("round trip %.1f ms, server %.1f ms", latency_ms,
                        static_cast<double>(response.server_send_time_unix_ns() -
                                            response.server_receive_time_unix_ns()) *
                            1e-6);
    // A tracked session's lanes are drawn with their ids and the ego lane,
    // as by lane detect --track.
    if (!session->config().tracking().disabled()) {
      return Draw(item, frame, lane::wire::TrackedFrameFromProto(response), details);
    }
    return Draw(item, frame, lane::wire::DetectionFromProto(response), details);
  }

 private:
  // `drawn`: a lane::Detection or a lane::TrackedFrame.
  template <typename Drawn>
  std::string Draw(const StreamItem& item, const cv::Mat& frame, const Drawn& drawn,
                   const std::string& details) {
    if (video_ != nullptr) {
      const std::string error =
          video_->Add(io::DrawLanesOnImage(frame, drawn, *detector_, item.name, details));
      if (!error.empty()) return error;
    }
    if (dir_.empty()) return "";
    return io::WriteOverlays(dir_, io::UniqueStem(item.stem, used_), frame, drawn, *detector_,
                             item.name, details);
  }

  const std::filesystem::path dir_;
  io::OverlayVideo* const video_;
  std::optional<lane::Detector> detector_;
  uint64_t version_ = 0;
  std::set<std::string> used_;
};

// The streamer's frames: read from the inputs, as requests of the camera.
// `fps`: the --fps pace, or 0.
Streamer::Source MakeSource(FrameSource* frames, const std::string& camera_id, double fps) {
  return [frames, camera_id, fps, first_ns = int64_t{-1},
          count = int64_t{0}](uint64_t frame_id) mutable -> std::optional<StreamItem> {
    ClientFrame frame;
    if (!frames->Next(&frame)) return std::nullopt;
    StreamItem item;
    item.frame_id = frame_id;
    item.name = frame.name;
    item.stem = frame.stem;
    if (!frame.error.empty()) {
      item.local_error = frame.error;
      return item;
    }
    auto request = std::make_shared<v1::FrameRequest>();
    request->set_camera_id(camera_id);
    request->set_frame_id(frame_id);
    // Recorded frames carry no capture time: the time they were read, or
    // paced at --fps, the first frame's plus i / fps (the recording's own
    // clock, which a reconnection's pause does not stretch: the tracker then
    // sees a gap no longer than the camera's, docs/tracking.md).
    const int64_t now_ns = absl::GetCurrentTimeNanos();
    if (first_ns < 0) first_ns = now_ns;
    request->set_capture_time_unix_ns(
        fps > 0 ? first_ns + static_cast<int64_t>(static_cast<double>(count) * 1e9 / fps) : now_ns);
    ++count;
    SetRequestImage(frame, request.get());
    item.request = std::move(request);
    return item;
  };
}

// Draws overlays on a thread of its own, so that drawing and writing PNGs
// does not hold up reading the answers: the latency of a frame is measured
// when its answer is read, and a reader busy drawing would add its drawing
// time to the frames behind it. Up to kMaxQueued frames wait; past that the
// reader waits for the drawer (and the latencies show it).
class OverlayDrawer {
 public:
  explicit OverlayDrawer(OverlayWriter* writer) : writer_(writer) {
    thread_ = std::thread([this] { Loop(); });
  }
  ~OverlayDrawer() { Finish(); }

  void Submit(const StreamItem& item, const v1::FrameResponse& response,
              const std::optional<v1::Session>& session, double latency_ms) {
    absl::MutexLock lock(&mu_);
    while (jobs_.size() >= kMaxQueued) space_.Wait(&mu_);
    jobs_.push_back(Job{item, response, session, latency_ms});
    ready_.Signal();
  }
  // Draws what is queued and stops. True if every overlay was written.
  bool Finish() {
    {
      absl::MutexLock lock(&mu_);
      done_ = true;
    }
    ready_.Signal();
    if (thread_.joinable()) thread_.join();
    return !failed_;
  }

 private:
  static constexpr size_t kMaxQueued = 64;
  struct Job {
    StreamItem item;
    v1::FrameResponse response;
    std::optional<v1::Session> session;
    double latency_ms = 0;
  };

  void Loop() {
    for (;;) {
      Job job;
      {
        absl::MutexLock lock(&mu_);
        while (!done_ && jobs_.empty()) ready_.Wait(&mu_);
        if (jobs_.empty()) return;
        job = std::move(jobs_.front());
        jobs_.pop_front();
      }
      space_.Signal();
      const std::string error = writer_->Write(job.item, job.response, job.session, job.latency_ms);
      if (!error.empty()) {
        failed_ = true;
        Note("stream", absl::StrCat(job.item.name, ": ", error));
      }
    }
  }

  OverlayWriter* const writer_;
  absl::Mutex mu_;
  absl::CondVar ready_;  // a job is queued, or done_
  absl::CondVar space_;  // jobs_ has room
  std::deque<Job> jobs_ ABSL_GUARDED_BY(mu_);
  bool done_ ABSL_GUARDED_BY(mu_) = false;
  bool failed_ = false;  // the drawer thread's until joined
  std::thread thread_;
};

// Where the answers go: the results, the overlays, the counts.
class StreamSink {
 public:
  StreamSink(std::ostream& out, const std::string& camera_id, OverlayDrawer* overlays,
             const Streamer& streamer, io::ProgressBar& progress, int total)
      : out_(out),
        camera_id_(camera_id),
        overlays_(overlays),
        streamer_(streamer),
        progress_(progress),
        total_(total) {}

  void operator()(const StreamItem& item, const v1::FrameResponse* response, double latency_ms) {
    if (response == nullptr) {
      ++failed_;
      progress_.Clear();
      Note("stream", absl::StrCat(item.name, ": ", item.local_error));
      out_ << ClientErrorJsonLine(item.name, camera_id_, item.frame_id, item.local_error) << '\n';
    } else {
      out_ << ResponseJsonLine(item.name, *response, SessionFor(*response), latency_ms,
                               item.attempts, item.connection)
           << '\n';
      if (response->status().code() == v1::FRAME_CODE_OK) {
        ++ok_;
        if (overlays_ != nullptr) {
          overlays_->Submit(item, *response, streamer_.session(), latency_ms);
        }
      } else {
        ++failed_;
        progress_.Clear();
        Note("stream", absl::StrCat(item.name, ": ", FrameCodeName(response->status().code()), ": ",
                                    response->status().message()));
      }
    }
    out_.flush();
    progress_.Update(++answered_, total_, item.name);
  }

  uint64_t ok() const { return ok_; }
  uint64_t failed() const { return failed_; }

 private:
  // What the records say of the session that answered `response` (its
  // frame size, mode and tracking), worked out once per session version.
  const StreamSession& SessionFor(const v1::FrameResponse& response) {
    if (!session_ || session_version_ != response.calibration_version()) {
      session_version_ = response.calibration_version();
      absl::StatusOr<StreamSession> session = streamer_.session()
                                                  ? StreamSessionOf(*streamer_.session())
                                                  : absl::FailedPreconditionError("no session");
      if (!session.ok()) {
        // Never expected (the server's own resolved config): the records
        // then lack the frame size, and the lanes' tracking fields.
        progress_.Clear();
        Note("stream",
             absl::StrCat("cannot read the session's config: ", session.status().message()));
        session = StreamSession{0, 0, lane::Mode::kAll, false};
      }
      session_ = *session;
    }
    return *session_;
  }

  std::ostream& out_;
  const std::string camera_id_;
  OverlayDrawer* const overlays_;
  const Streamer& streamer_;
  io::ProgressBar& progress_;
  const int total_;
  int answered_ = 0;
  std::optional<StreamSession> session_;
  uint64_t session_version_ = 0;
  uint64_t ok_ = 0;
  uint64_t failed_ = 0;
};

// The streamer's options from the flags and the session config.
StreamerOptions StreamerOptionsFrom(const StreamFlags& flags,
                                    const std::optional<v1::SessionConfig>& session) {
  StreamerOptions options;
  options.camera_id = flags.camera;
  options.session = session;
  options.replace = flags.replace;
  options.window = flags.window;
  if (flags.retry_timeout) options.give_up_after = *flags.retry_timeout;
  options.max_reconnects = flags.max_reconnects;
  if (flags.stall_timeout) options.stall_timeout = *flags.stall_timeout;
  return options;
}

// --overlay and --overlay-video: video, writer and drawer (destroyed drawer first).
struct StreamOverlays {
  std::unique_ptr<io::OverlayVideo> video;
  std::unique_ptr<OverlayWriter> writer;
  std::unique_ptr<OverlayDrawer> drawer;
};

// The overlay video and folder when asked, or the exit status of a failure
// (reported).
struct OpenedOverlays {
  StreamOverlays overlays;
  std::optional<int> exit;
};

OpenedOverlays OpenOverlays(const CLI::App& app, const StreamFlags& flags) {
  OpenedOverlays opened;
  if (flags.overlay_video) {
    if (const std::string e = io::OverlayVideo::CheckPath(*flags.overlay_video); !e.empty()) {
      opened.exit = io::UsageError(app, e);
      return opened;
    }
    opened.overlays.video = std::make_unique<io::OverlayVideo>(
        *flags.overlay_video, flags.read.fps > 0 ? flags.read.fps : 10.0);
  }
  std::string overlay_dir;
  if (const auto& overlay = flags.overlay) {
    std::error_code ec;
    std::filesystem::create_directories(*overlay, ec);
    if (ec || !std::filesystem::is_directory(*overlay)) {
      opened.exit = Failure("stream", absl::StrCat("cannot create overlay folder ", *overlay));
      return opened;
    }
    overlay_dir = *overlay;
  }
  if (flags.overlay || flags.overlay_video) {
    opened.overlays.writer =
        std::make_unique<OverlayWriter>(overlay_dir, opened.overlays.video.get());
    opened.overlays.drawer = std::make_unique<OverlayDrawer>(opened.overlays.writer.get());
  }
  return opened;
}

// Draws the queued overlays and closes the video; true if every overlay was written.
bool FinishOverlays(const StreamFlags& flags, StreamOverlays& overlays) {
  bool overlays_ok = overlays.drawer == nullptr || overlays.drawer->Finish();
  if (overlays.video) {
    if (const std::string e = overlays.video->Close(); !e.empty()) {
      Note("stream", e);
      overlays_ok = false;
    } else if (!flags.quiet) {
      Note("stream", absl::StrCat(overlays.video->frames(), " frames in ", *flags.overlay_video));
    }
  }
  return overlays_ok;
}

int RunStream(const CLI::App& app, const StreamFlags& flags) {
  if (flags.inputs.empty()) return io::UsageError(app, "no INPUT given");
  const auto targets = SplitTargets(flags.target);
  if (!targets.ok()) return io::UsageError(app, std::string(targets.status().message()));
  if (targets->size() != 1) {
    return io::UsageError(app, "stream takes one --target (use a dns:/// name to balance)");
  }
  // Checked here, not by the server: an id it refuses, or a header a proxy
  // refuses (UNAVAILABLE), must not become a retry loop.
  if (const absl::Status id = lane::wire::ValidateCameraId(flags.camera); !id.ok()) {
    return io::UsageError(app, absl::StrCat("--camera: ", id.message()));
  }
  absl::StatusOr<std::optional<v1::SessionConfig>> session =
      SessionConfigFromFlags(flags.session, false);
  if (!session.ok()) return Failure("stream", std::string(session.status().message()));
  const StreamerOptions options = StreamerOptionsFrom(flags, *session);

  std::ofstream file;
  if (flags.output && !io::OpenOutputFile(*flags.output, &file)) {
    return Failure("stream", absl::StrCat("cannot write ", *flags.output));
  }
  std::ostream& out = file.is_open() ? static_cast<std::ostream&>(file) : std::cout;
  OpenedOverlays opened = OpenOverlays(app, flags);
  if (opened.exit) return *opened.exit;
  StreamOverlays overlays = std::move(opened.overlays);

  FrameSource frames(flags.inputs, flags.raw, flags.read.Options());
  Streamer streamer(MakeChannel(targets->front()), options,
                    [](const std::string& message) { Note("stream", message); });
  // A bar when the frame count is known (files), else a counter; only on a
  // terminal, never with --quiet or --no-progress.
  io::ProgressBar progress(!flags.quiet && !flags.no_progress);
  const int total = static_cast<int>(std::min<long long>(frames.KnownFrameCount(), 1 << 30));
  StreamSink sink(out, options.camera_id, overlays.drawer.get(), streamer, progress, total);
  const absl::Status status =
      streamer.Run(MakeSource(&frames, options.camera_id, flags.read.fps),
                   [&sink](const StreamItem& item, const v1::FrameResponse* response,
                           double latency_ms) { sink(item, response, latency_ms); });
  const bool overlays_ok = FinishOverlays(flags, overlays);
  progress.Clear();
  const StreamerStats& stats = streamer.stats();
  if (!flags.quiet) {
    Note("stream",
         absl::StrCat(stats.frames, " frames: ", sink.ok(), " ok, ", sink.failed(), " failed; ",
                      stats.connections, " connection(s), ", stats.resent, " frame(s) resent"));
    if (stats.resumes > 0 || stats.resume_states > 0) {
      Note("stream",
           absl::StrCat(
               "tracking resumed on ", stats.resumes, " reconnection(s) (", stats.resumes_refused,
               " refused); ", stats.resume_states, " resume state(s) received, ",
               stats.resume_states > 0 ? stats.resume_state_bytes / stats.resume_states : 0,
               " bytes on average"));
    }
  }
  if (!status.ok()) return Failure("stream", std::string(status.message()));
  if (!out) return Failure("stream", "error writing the results");
  return sink.failed() > 0 || !overlays_ok ? kExitFailure : kExitOk;
}

}  // namespace

Command AddStreamCommand(CLI::App& client) {
  auto flags = std::make_shared<StreamFlags>();
  CLI::App* app = io::AddCommand(client, "stream", "frames of files or videos in, JSON Lines out",
                                 kStreamDescription, kStreamFooter);
  AddTargetOption(app, &flags->target, "server address");
  app->add_option("--camera", flags->camera, "camera id of the session")->type_name("ID");
  AddSessionConfigOptions(app, &flags->session);
  app->add_flag("--replace", flags->replace,
                "replace a session of the camera with a different config");
  app->add_flag("--raw", flags->raw, "decode image files here and send raw BGR pixels");
  io::AddOptional(app, "--output", &flags->output, "write the results to FILE instead of stdout")
      ->type_name("FILE");
  io::AddOptional(app, "--overlay", &flags->overlay,
                  "also write DIR/STEM.png and DIR/STEM_ipm.png per frame")
      ->type_name("DIR");
  io::AddOptional(app, "--overlay-video", &flags->overlay_video,
                  "also write the answered frames with their lanes and a caption (round "
                  "trip and server time) as one video (.mp4/.mov/.mkv/.avi), at --fps "
                  "(else 10/s)")
      ->type_name("FILE");
  app->add_option("--window,--inflight", flags->window,
                  "frames sent and not answered, at most (the client's window; the server's "
                  "bound is --max-inflight-frames)")
      ->type_name("K")
      ->check(io::Between(1, 4096));
  io::AddDuration(app, "--retry-timeout", &flags->retry_timeout,
                  "give up when no frame is answered for D", "60s");
  app->add_option("--max-reconnects", flags->max_reconnects,
                  "give up when the same status code comes back after N reconnections in a row "
                  "with no frame answered (the server's own 'starting' and 'draining' never "
                  "count); 0: at the first failure. 10 is about 13 s of backoff: longer than a "
                  "restart of lane-server or a proxy's failover, much shorter than "
                  "--retry-timeout for a failure that repeats (a proxy refusing the call)")
      ->type_name("N")
      ->check(io::Between(0, 1000000));
  io::AddDuration(app, "--stall-timeout", &flags->stall_timeout,
                  "reconnect when frames are in flight and nothing comes back for D", "30s");
  io::AddReadFlags(app, &flags->read);
  app->add_flag("--quiet,-q", flags->quiet, "print only errors on stderr: no progress or summary");
  app->add_flag("--no-progress", flags->no_progress,
                "no progress bar (it is drawn only when stderr is a terminal)");
  app->add_option("INPUT", flags->inputs,
                  "image files, directories, list files, videos, or live sources (rtsp:// or "
                  "http:// URLs, /dev/videoN, GStreamer pipelines)");
  return {app, [app, flags] { return RunStream(*app, *flags); }};
}

}  // namespace lane::client
