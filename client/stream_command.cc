// `lane-client stream`: a camera's recorded frames through the service, the
// lanes out as JSON Lines (docs/client.md), surviving server restarts.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "commands.h"
#include "common.h"
#include "frames.h"
#include "lane/detector.h"
#include "overlay.h"
#include "results.h"
#include "session_config.h"
#include "streamer.h"
#include "wire/config_proto.h"

namespace lane_client {
namespace {

namespace v1 = lane::v1;

constexpr char kUsage[] =
    "usage: lane-client stream [options] INPUT...\n"
    "\n"
    "Streams the frames of INPUT to the service as one camera and writes one\n"
    "JSON object per frame, in input order (JSON Lines, schema 1: docs/client.md).\n"
    "INPUT is a directory (its .jpg/.jpeg/.png files, sorted), a list file (.txt,\n"
    "one path a line), a video (.mp4/.avi/.mkv/.mov) or an image file. JPEG and\n"
    "PNG files are sent as they are; video frames are sent as raw BGR pixels.\n"
    "\n"
    "If the stream breaks (server restart, UNAVAILABLE, lost connection), the\n"
    "client reconnects with backoff, re-creates the session and resends every\n"
    "unanswered frame: each frame appears exactly once in the output.\n"
    "\n"
    "options:\n"
    "  --target T           server address (default 127.0.0.1:50051)\n"
    "  --camera ID          camera id of the session (default \"default\")\n"
    "%s"
    "  --replace            replace a session of the camera with a different config\n"
    "  --raw                decode image files here and send raw BGR pixels\n"
    "  --output FILE        write the results to FILE instead of stdout\n"
    "  --overlay DIR        also write DIR/STEM.png and DIR/STEM_ipm.png per frame\n"
    "  --inflight K         frames sent and not answered, at most (default 8)\n"
    "  --retry-timeout D    give up when no frame is answered for D (default 60s)\n"
    "  --stall-timeout D    reconnect when frames are in flight and nothing comes\n"
    "                       back for D (default 30s)\n"
    "  -h, --help           show this help\n"
    "\n"
    "Without --config the camera's session must exist on the server; its config\n"
    "is read once and used to re-create it after a restart.\n"
    "Exit status: 0 when every frame was answered OK, 1 otherwise, 2 for a bad\n"
    "command line.\n";

std::string Usage() {
  static const std::string usage = [] {
    char buffer[4096];
    std::snprintf(buffer, sizeof(buffer), kUsage, kSessionConfigUsage);
    return std::string(buffer);
  }();
  return usage;
}

std::string UniqueStem(const std::string& stem, std::set<std::string>& used) {
  std::string candidate = stem;
  for (int i = 2; !used.insert(candidate).second; ++i) candidate = absl::StrCat(stem, "-", i);
  return candidate;
}

// Draws the overlays of one answered frame with a detector built from the
// session's resolved config (the ROI, the horizon and the top view).
class OverlayWriter {
 public:
  explicit OverlayWriter(std::filesystem::path dir) : dir_(std::move(dir)) {}

  // An error message or "".
  std::string Write(const StreamItem& item, const v1::FrameResponse& response,
                    const std::optional<v1::Session>& session) {
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
    const lane::Detection detection = DetectionFromResponse(response);
    const std::string stem = UniqueStem(item.stem, used_);
    const std::string image_path = (dir_ / (stem + ".png")).string();
    const std::string ipm_path = (dir_ / (stem + "_ipm.png")).string();
    try {
      if (!cv::imwrite(image_path, lane_tools::DrawLanesOnImage(frame, detection, *detector_))) {
        return absl::StrCat("cannot write ", image_path);
      }
      if (!cv::imwrite(ipm_path, lane_tools::DrawIpmView(frame, detection, *detector_))) {
        return absl::StrCat("cannot write ", ipm_path);
      }
    } catch (const cv::Exception& e) {
      return absl::StrCat("cannot write overlay ", image_path, ": ", e.what());
    }
    return "";
  }

 private:
  const std::filesystem::path dir_;
  std::optional<lane::Detector> detector_;
  uint64_t version_ = 0;
  std::set<std::string> used_;
};

}  // namespace

int RunStream(const std::vector<std::string>& argv) {
  const std::string usage = Usage();
  std::vector<lane_tools::OptionSpec> specs = SessionConfigOptionSpecs();
  for (const char* name :
       {"target", "camera", "output", "overlay", "inflight", "retry-timeout", "stall-timeout"}) {
    specs.push_back({name});
  }
  specs.push_back({"replace", false});
  specs.push_back({"raw", false});
  const absl::StatusOr<lane_tools::Args> args = lane_tools::Args::Parse(argv, specs);
  if (!args.ok()) return UsageError("stream", std::string(args.status().message()), usage.c_str());
  if (args->help()) {
    std::fputs(usage.c_str(), stdout);
    return kExitOk;
  }
  if (args->positional().empty()) return UsageError("stream", "no INPUT given", usage.c_str());
  const auto inflight = args->GetInt("inflight", 1, 4096);
  const auto retry = GetDuration(*args, "retry-timeout");
  const auto stall = GetDuration(*args, "stall-timeout");
  for (const absl::Status& s : {inflight.status(), retry.status(), stall.status()}) {
    if (!s.ok()) return UsageError("stream", std::string(s.message()), usage.c_str());
  }
  const auto targets = SplitTargets(args->Get("target").value_or(kDefaultTarget));
  if (!targets.ok()) {
    return UsageError("stream", std::string(targets.status().message()), usage.c_str());
  }
  if (targets->size() != 1) {
    return UsageError("stream", "stream takes one --target (use a dns:/// name to balance)",
                      usage.c_str());
  }
  absl::StatusOr<std::optional<v1::SessionConfig>> session = SessionConfigFromArgs(*args, false);
  if (!session.ok()) return Failure("stream", std::string(session.status().message()));

  StreamerOptions options;
  options.camera_id = args->Get("camera").value_or("default");
  options.session = *session;
  options.replace = args->Has("replace");
  if (*inflight) options.window = static_cast<size_t>(**inflight);
  if (*retry) options.give_up_after = **retry;
  if (*stall) options.stall_timeout = **stall;
  const bool raw = args->Has("raw");

  std::ofstream file;
  if (const auto output = args->Get("output")) {
    if (!lane_tools::OpenOutputFile(*output, &file)) {
      return Failure("stream", absl::StrCat("cannot write ", *output));
    }
  }
  std::ostream& out = file.is_open() ? static_cast<std::ostream&>(file) : std::cout;

  std::unique_ptr<OverlayWriter> overlays;
  if (const auto overlay = args->Get("overlay")) {
    std::error_code ec;
    std::filesystem::create_directories(*overlay, ec);
    if (ec || !std::filesystem::is_directory(*overlay)) {
      return Failure("stream", absl::StrCat("cannot create overlay folder ", *overlay));
    }
    overlays = std::make_unique<OverlayWriter>(*overlay);
  }

  FrameSource frames(args->positional(), raw);
  const std::string camera_id = options.camera_id;
  const Streamer::Source source = [&frames, &camera_id](StreamItem* item) {
    ClientFrame frame;
    if (!frames.Next(&frame)) return false;
    item->name = frame.name;
    item->stem = frame.stem;
    if (!frame.error.empty()) {
      item->local_error = frame.error;
      return true;
    }
    auto request = std::make_shared<v1::FrameRequest>();
    request->set_camera_id(camera_id);
    request->set_frame_id(item->frame_id);
    // Recorded frames carry no capture time: the time they were read.
    request->set_capture_time_unix_ns(absl::GetCurrentTimeNanos());
    SetRequestImage(frame, request.get());
    item->request = std::move(request);
    return true;
  };

  Streamer streamer(MakeChannel(targets->front()), options,
                    [](const std::string& message) { Note("stream", message); });
  uint64_t ok = 0;
  uint64_t failed = 0;
  bool overlay_failed = false;
  const Streamer::Sink sink = [&](const StreamItem& item, const v1::FrameResponse* response,
                                  double latency_ms) {
    if (response == nullptr) {
      ++failed;
      Note("stream", absl::StrCat(item.name, ": ", item.local_error));
      out << ClientErrorJsonLine(item.name, camera_id, item.frame_id, item.local_error) << '\n';
    } else {
      out << ResponseJsonLine(item.name, *response, latency_ms, item.attempts) << '\n';
      if (response->status().code() == v1::FRAME_CODE_OK) {
        ++ok;
        if (overlays) {
          const std::string error = overlays->Write(item, *response, streamer.session());
          if (!error.empty()) {
            overlay_failed = true;
            Note("stream", absl::StrCat(item.name, ": ", error));
          }
        }
      } else {
        ++failed;
        Note("stream", absl::StrCat(item.name, ": ", FrameCodeName(response->status().code()), ": ",
                                    response->status().message()));
      }
    }
    out.flush();
  };

  const absl::Status status = streamer.Run(source, sink);
  const StreamerStats& stats = streamer.stats();
  Note("stream",
       absl::StrCat(stats.frames, " frames: ", ok, " ok, ", failed, " failed; ", stats.connections,
                    " connection(s), ", stats.resent, " frame(s) resent"));
  if (!status.ok()) return Failure("stream", std::string(status.message()));
  if (!out) return Failure("stream", "error writing the results");
  return failed > 0 || overlay_failed ? kExitFailure : kExitOk;
}

}  // namespace lane_client
