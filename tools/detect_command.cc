// `lane detect`: lanes in images, directories, list files and videos, as
// JSON Lines (docs/results-format.md), with optional overlay pictures.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "args.h"
#include "cli_config.h"
#include "commands.h"
#include "inputs.h"
#include "lane/config.h"
#include "lane/detector.h"
#include "overlay.h"
#include "results_json.h"

namespace lane_tools {
namespace {

constexpr char kUsage[] =
    "usage: lane detect --config CONFIG [options] INPUT...\n"
    "\n"
    "Detects the lane markings of every frame and writes one JSON object per\n"
    "frame (JSON Lines, schema 1: docs/results-format.md).\n"
    "\n"
    "INPUT is an image file; a directory (its .jpg/.jpeg/.png files, sorted by\n"
    "name, not recursive); a list file (.txt: one path a line, relative paths\n"
    "resolved against the list's folder, blank lines and # comments skipped);\n"
    "or a video (.mp4/.avi/.mkv/.mov; frames are named VIDEO#000123).\n"
    "\n"
    "options:\n"
    "  --config CONFIG   JSON config file (docs/config.md), required\n"
    "  --mode all|two    detector mode instead of the config's: the mode's\n"
    "                    defaults, then the config's other detector keys\n"
    "  --seed N          RANSAC seed instead of the config's detector.seed\n"
    "  --output FILE     write the results to FILE instead of stdout\n"
    "  --overlay DIR     also write DIR/STEM.png (lanes on the frame) and\n"
    "                    DIR/STEM_ipm.png (lanes in the top view)\n"
    "  -h, --help        show this help\n"
    "\n"
    "A frame that cannot be read or processed gets a record with \"error\" and\n"
    "a message on stderr; the other frames go on. Exit status: 0 when every\n"
    "frame was processed, 1 when some failed, 2 for a bad command line.\n";

// A stem not used yet in this run: "name", "name-2", "name-3", ...
std::string UniqueStem(const std::string& stem, std::set<std::string>& used) {
  std::string candidate = stem;
  for (int i = 2; !used.insert(candidate).second; ++i) candidate = absl::StrCat(stem, "-", i);
  return candidate;
}

// Writes both overlay pictures; an error message or "".
std::string WriteOverlays(const std::filesystem::path& dir, const std::string& stem,
                          const cv::Mat& frame, const lane::Detection& detection,
                          const lane::Detector& detector, const std::string& frame_name) {
  const std::string image_path = (dir / (stem + ".png")).string();
  const std::string ipm_path = (dir / (stem + "_ipm.png")).string();
  try {
    if (!cv::imwrite(image_path, DrawLanesOnImage(frame, detection, detector, frame_name))) {
      return absl::StrCat("cannot write ", image_path);
    }
    if (!cv::imwrite(ipm_path, DrawIpmView(frame, detection, detector))) {
      return absl::StrCat("cannot write ", ipm_path);
    }
  } catch (const cv::Exception& e) {
    return absl::StrCat("cannot write overlay ", image_path, ": ", e.what());
  }
  return "";
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  const double upper = values[mid];
  if (values.size() % 2 == 1) return upper;
  return 0.5 * (upper + *std::max_element(values.begin(), values.begin() + mid));
}

}  // namespace

int RunDetect(const std::vector<std::string>& argv) {
  const absl::StatusOr<Args> args =
      Args::Parse(argv, {{"config"}, {"mode"}, {"seed"}, {"output"}, {"overlay"}});
  if (!args.ok()) return UsageError("detect", std::string(args.status().message()), kUsage);
  if (args->help()) {
    std::fputs(kUsage, stdout);
    return kExitOk;
  }
  if (!args->Has("config")) return UsageError("detect", "--config is required", kUsage);
  if (args->positional().empty()) return UsageError("detect", "no INPUT given", kUsage);
  const auto mode = args->GetChoice("mode", {"all", "two"});
  if (!mode.ok()) return UsageError("detect", std::string(mode.status().message()), kUsage);
  const auto seed = args->GetUint64("seed");
  if (!seed.ok()) return UsageError("detect", std::string(seed.status().message()), kUsage);

  absl::StatusOr<lane::Config> config = LoadEffectiveConfig(args->Get("config"), *mode);
  if (!config.ok()) return Failure("detect", std::string(config.status().message()));
  if (*seed) config->detector.seed = **seed;
  const absl::StatusOr<lane::Detector> detector =
      lane::Detector::Create(config->camera, config->ipm, config->detector);
  if (!detector.ok()) {
    return Failure("detect",
                   absl::StrCat("cannot build the detector: ", detector.status().message()));
  }
  const lane::Mode detector_mode = detector->options().mode;
  {
    // The top view's scale: users need it to read the IPM coordinates.
    const lane::IpmMapping& ipm = detector->ipm();
    std::fprintf(stderr,
                 "lane detect: top view %dx%d px covering x %.2f..%.2f m, y %.2f..%.2f m ahead: "
                 "%.4f m/px across, %.4f m/px along; filter sigmas %.2f x %.2f px\n",
                 ipm.width(), ipm.height(), ipm.x_min(), ipm.x_max(), ipm.y_min(), ipm.y_max(),
                 ipm.metres_per_px_x(), ipm.metres_per_px_y(), detector->kernels().sigma_x_px,
                 detector->kernels().sigma_y_px);
  }
  const int expected_width = config->camera.image_width;
  const int expected_height = config->camera.image_height;

  std::ofstream file;
  if (const auto output = args->Get("output")) {
    if (!OpenOutputFile(*output, &file)) {
      return Failure("detect", absl::StrCat("cannot write ", *output));
    }
  }
  std::ostream& out = file.is_open() ? static_cast<std::ostream&>(file) : std::cout;

  std::filesystem::path overlay_dir;
  if (const auto overlay = args->Get("overlay")) {
    overlay_dir = *overlay;
    std::error_code ec;
    std::filesystem::create_directories(overlay_dir, ec);
    if (ec || !std::filesystem::is_directory(overlay_dir)) {
      return Failure("detect", absl::StrCat("cannot create overlay folder ", *overlay,
                                            ec ? ": " + ec.message() : std::string()));
    }
  }

  int frames = 0;
  int failures = 0;
  bool overlay_failed = false;
  long total_lanes = 0;
  std::vector<double> total_ms;
  std::set<std::string> used_stems;
  FrameReader reader(args->positional());
  InputFrame frame;
  while (reader.Next(&frame)) {
    ++frames;
    std::string error = frame.error;
    absl::StatusOr<lane::Detection> detection = lane::Detection();
    if (error.empty() && (frame.bgr.cols != expected_width || frame.bgr.rows != expected_height)) {
      error =
          absl::StrCat("frame is ", frame.bgr.cols, "x", frame.bgr.rows, " but the camera expects ",
                       expected_width, "x", expected_height, " (camera.image_width/image_height)");
    }
    if (error.empty()) {
      try {
        detection = detector->Detect(frame.bgr);
        if (!detection.ok()) error = std::string(detection.status().message());
      } catch (const std::exception& e) {  // e.g. a cv::Exception: this frame fails, not the run
        error = absl::StrCat("detector error: ", e.what());
      }
    }
    if (!error.empty()) {
      ++failures;
      std::fprintf(stderr, "lane detect: %s: %s\n", frame.name.c_str(), error.c_str());
      out << ErrorJsonLine(frame.name, frame.bgr.cols, frame.bgr.rows, detector_mode, error)
          << '\n';
      out.flush();
      continue;
    }
    out << DetectionJsonLine(frame.name, frame.bgr.cols, frame.bgr.rows, detector_mode, *detection,
                             frame.decode_ms)
        << '\n';
    out.flush();
    total_lanes += static_cast<long>(detection->lanes.size());
    total_ms.push_back(detection->timings.total_ms);

    if (!overlay_dir.empty()) {
      const std::string message = WriteOverlays(overlay_dir, UniqueStem(frame.stem, used_stems),
                                                frame.bgr, *detection, *detector, frame.name);
      if (!message.empty()) {
        overlay_failed = true;
        std::fprintf(stderr, "lane detect: %s: %s\n", frame.name.c_str(), message.c_str());
      }
    }
  }
  if (!out) {
    return Failure("detect", args->Has("output")
                                 ? absl::StrCat("error writing ", *args->Get("output"))
                                 : std::string("error writing the results to stdout"));
  }

  const int ok_frames = frames - failures;
  std::fprintf(
      stderr, "lane detect: %d frames, %d failed, %.2f lanes/frame, median total %.2f ms\n", frames,
      failures, ok_frames > 0 ? double(total_lanes) / ok_frames : 0.0, Median(total_ms));
  if (frames == 0) return Failure("detect", "the inputs contain no frames");
  return failures > 0 || overlay_failed ? kExitFailure : kExitOk;
}

}  // namespace lane_tools
