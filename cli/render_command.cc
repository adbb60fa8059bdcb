// `lane render`: synthetic road frames with exact ground truth.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "commands.h"
#include "io/cli_config.h"
#include "lane/config/config.h"
#include "lane/eval/render_labels.h"
#include "lane/synthetic.h"

namespace lane::cli {
namespace {

constexpr char kRenderDescription[] =
    "Renders N synthetic road frames through the config's camera, with exact\n"
    "ground truth. Writes DIR/000000.png ... (frame i uses seed S + i),\n"
    "DIR/labels.jsonl (one JSON object per frame: docs/results-format.md) and\n"
    "DIR/list.txt (the frame names, one a line: an INPUT for 'lane detect').\n"
    "With --sequence the frames are one continuous drive instead (seed S for\n"
    "the whole drive, frame i at i / fps seconds): a lane change, bends,\n"
    "occluding traffic, a dashed line turning solid and changing light; the\n"
    "labels add stable boundary ids, the time and the true ego lane\n"
    "(docs/results-format.md). Replay it with 'lane detect --track'.";

struct RenderFlags {
  std::string config;
  int64_t count = 0;
  std::string output;
  uint64_t seed = 1;
  int num_lanes = lane::SyntheticOptions().num_lanes;
  int jpeg_quality = lane::SyntheticOptions().jpeg_quality;
  std::string format = "png";
  bool sequence = false;
  bool clutter = false;
  bool straight = false;
  bool night = false;
  bool static_overlay = false;
  double hood_m = 0;
  double truth_far_m = lane::SyntheticOptions().truth_far_m;
  double double_lines = 0;
  double botts_dots = 0;
  bool concrete = false;
  double dashed = lane::SyntheticOptions().dashed_probability;
  double hood_top_row = 0;
  double hood_side_row = 0;
  bool labels_through_hood = false;
  double fps = lane::SyntheticDriveOptions().fps;
  double speed_mps = lane::SyntheticDriveOptions().speed_mps;
};

// Creates `dir` and opens its labels.jsonl and list.txt; an error message or "".
std::string OpenOutputs(const std::filesystem::path& dir, std::ofstream* labels,
                        std::ofstream* list) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir)) {
    return absl::StrCat("cannot create ", dir.string(), ec ? ": " + ec.message() : std::string());
  }
  labels->open(dir / "labels.jsonl", std::ios::binary | std::ios::trunc);
  list->open(dir / "list.txt", std::ios::binary | std::ios::trunc);
  if (!*labels || !*list) {
    return absl::StrCat("cannot write labels.jsonl/list.txt in ", dir.string());
  }
  return "";
}

int RunRender(const RenderFlags& flags) {
  const absl::StatusOr<lane::Config> config = io::LoadEffectiveConfig(flags.config, {});
  if (!config.ok()) return Failure("render", std::string(config.status().message()));

  lane::SyntheticOptions options;
  options.num_lanes = flags.num_lanes;
  options.jpeg_quality = flags.jpeg_quality;
  if (flags.clutter) lane::SetRoadsideClutter(&options);
  options.night = flags.night;
  options.static_overlay = flags.static_overlay;
  options.truth_far_m = flags.truth_far_m;
  options.double_line_probability = flags.double_lines;
  options.botts_dots_probability = flags.botts_dots;
  options.concrete = flags.concrete || flags.botts_dots > 0;
  options.dashed_probability = flags.dashed;
  options.hood_top_row = flags.hood_top_row;
  options.hood_side_row = flags.hood_side_row;
  options.labels_through_hood = flags.labels_through_hood;
  if (flags.hood_m > 0) {
    // --hood M is the same hood by rows, from the camera, labelled through.
    const absl::StatusOr<lane::HoodRows> rows =
        lane::HoodRowsAtDistance(config->camera, flags.hood_m);
    if (!rows.ok()) return Failure("render", std::string(rows.status().message()));
    options.hood_top_row = rows->top_row;
    options.hood_side_row = rows->side_row;
    options.labels_through_hood = true;
    std::fprintf(stderr,
                 "lane render: --hood %g is --hood-top-row %.2f --hood-side-row %.2f "
                 "--labels-through-hood on this camera\n",
                 flags.hood_m, rows->top_row, rows->side_row);
  }
  if (flags.straight) {
    options.straight_probability = 1.0;
    options.max_heading_rad = 0.005;
  }
  const bool jpg = flags.format == "jpg";
  std::vector<int> write_params;
  if (jpg) {
    // One JPEG compression only: the file's.
    write_params = {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality > 0 ? options.jpeg_quality : 95};
    options.jpeg_quality = 0;
  }

  const std::filesystem::path dir = flags.output;
  std::ofstream labels;
  std::ofstream list;
  if (const std::string e = OpenOutputs(dir, &labels, &list); !e.empty()) {
    return Failure("render", e);
  }
  lane::SyntheticDriveOptions drive;
  drive.count = static_cast<int>(flags.count);
  drive.fps = flags.fps;
  drive.speed_mps = flags.speed_mps;
  drive.frame = options;
  if (flags.sequence) {
    if (absl::Status s = drive.Validate(); !s.ok())
      return Failure("render", std::string(s.message()));
  }
  for (int64_t i = 0; i < flags.count; ++i) {
    absl::StatusOr<lane::SyntheticFrame> frame =
        flags.sequence ? lane::RenderSyntheticDriveFrame(config->camera, drive, flags.seed,
                                                         static_cast<int>(i))
                       : lane::RenderSyntheticFrame(config->camera, options,
                                                    flags.seed + static_cast<uint64_t>(i));
    if (!frame.ok()) {
      return Failure("render", absl::StrCat("frame ", i, ": ", frame.status().message()));
    }
    char name[32];
    std::snprintf(name, sizeof(name), "%06lld.%s", static_cast<long long>(i), jpg ? "jpg" : "png");
    const std::string path = (dir / name).string();
    bool written = false;
    try {
      written = cv::imwrite(path, frame->bgr, write_params);
    } catch (const cv::Exception& e) {
      return Failure("render", absl::StrCat("cannot write ", path, ": ", e.what()));
    }
    if (!written) return Failure("render", absl::StrCat("cannot write ", path));
    labels << lane::eval::RenderLabelsJson(name, *frame) << '\n';
    list << name << '\n';
  }
  labels.close();
  list.close();
  if (!labels || !list) {
    return Failure("render", absl::StrCat("error writing labels.jsonl/list.txt in ", dir.string()));
  }
  std::fprintf(stderr, "lane render: %lld %s in %s\n", static_cast<long long>(flags.count),
               flags.sequence ? "frames of one drive" : "frames", dir.string().c_str());
  return io::kExitOk;
}

// The markings' options of independent frames (not a --sequence drive).
void AddMarkingOptions(CLI::App* app, RenderFlags* flags, CLI::Option* sequence) {
  app->add_option("--double-lines", flags->double_lines,
                  "the share of inner boundaries drawn as solid double lines, 0.10-0.20 m "
                  "apart; each is labelled once, along its centre (independent frames)")
      ->type_name("P")
      ->check(CLI::Range(0.0, 1.0))
      ->excludes(sequence);
  app->add_option("--botts-dots", flags->botts_dots,
                  "the share of inner boundaries drawn as raised pavement markers (Botts' "
                  "dots: 0.09 m, in groups of 4 about 0.95 m apart, a group every 12-13 m), "
                  "on a concrete road (--concrete); labelled through the dots, type `dots` "
                  "(independent frames)")
      ->type_name("P")
      ->check(CLI::Range(0.0, 1.0))
      ->excludes(sequence);
  app->add_flag("--concrete", flags->concrete,
                "a concrete road (grey 140-160, slab seams, tyre polish) instead of asphalt "
                "(independent frames)")
      ->excludes(sequence);
  app->add_option("--dashed", flags->dashed, "the share of boundaries that are dashed")
      ->type_name("P")
      ->check(CLI::Range(0.0, 1.0))
      ->excludes(sequence);
}

}  // namespace

io::Command AddRenderCommand(CLI::App& lane) {
  auto flags = std::make_shared<RenderFlags>();
  CLI::App* app = io::AddCommand(
      lane, "render", "render synthetic road frames with ground-truth labels", kRenderDescription);
  app->add_option("--config", flags->config, "JSON config file whose camera is used")
      ->type_name("CONFIG")
      ->required();
  app->add_option("--count", flags->count, "number of frames")
      ->type_name("N")
      ->required()
      ->check(io::Between(1, 1000000));
  app->add_option("--output,--out", flags->output, "output folder, created when missing")
      ->type_name("DIR")
      ->required();
  app->add_option("--seed", flags->seed, "seed of the first frame")
      ->type_name("S")
      ->check(io::NonNegativeInteger());
  app->add_option("--num-lanes", flags->num_lanes, "lanes on the road, 0 = random 1..5 per frame")
      ->type_name("K")
      ->check(io::Between(0, 20));
  app->add_option("--jpeg-quality", flags->jpeg_quality,
                  "simulated JPEG artefacts: quality, 0 = none. With --format jpg the "
                  "file itself is written at quality Q (95 when Q is 0) instead.")
      ->type_name("Q")
      ->check(io::Between(0, 100));
  io::OneOf(app->add_option("--format", flags->format, "image file format"), {"png", "jpg"});
  CLI::Option* sequence =
      app->add_flag("--sequence", flags->sequence,
                    "one continuous drive (lane change, bends, traffic, a dashed line turning "
                    "solid, changing light) instead of independent frames");
  app->add_flag("--clutter", flags->clutter,
                "roadside clutter that competes with the markings: tree rows (white trunks half "
                "the time), signs, guardrails, more buildings, poles and vehicles, worn paint "
                "(independent frames)")
      ->excludes(sequence);
  app->add_flag("--night", flags->night,
                "night, as measured on a CULane night clip: the road lit by the car's low "
                "beams and street lamps over an unlit grey of 17, glare above the horizon, "
                "oncoming headlights (independent frames)")
      ->excludes(sequence);
  CLI::Option* hood_m =
      app->add_option("--hood", flags->hood_m,
                      "the car's hood covering the road nearer than M metres ahead (CULane's "
                      "cameras), labelled through: the same as --hood-top-row/--hood-side-row "
                      "(converted from the camera, printed) with --labels-through-hood")
          ->type_name("M")
          ->check(CLI::Range(0.0, 100.0));
  app->add_option("--truth-far", flags->truth_far_m,
                  "the labels run this far ahead, metres (CULane's night labels: about 72)")
      ->type_name("M")
      ->check(CLI::Range(1.0, 1000.0));
  AddMarkingOptions(app, flags.get(), sequence);
  app->add_flag("--straight", flags->straight,
                "straight roads only, nearly aligned with the car (independent frames): "
                "calibration footage")
      ->excludes(sequence);
  CLI::Option* hood =
      app->add_option("--hood-top-row", flags->hood_top_row,
                      "the car's hood: a dark, glossy, still region below a parabola through this "
                      "row at the principal point's column and --hood-side-row at the image's "
                      "edges. The labels stop at it (--labels-through-hood: they run on to the "
                      "image's bottom, CULane's convention)")
          ->type_name("V")
          ->check(CLI::Range(1.0, 16384.0))
          ->excludes(hood_m);
  app->add_option("--hood-side-row", flags->hood_side_row,
                  "--hood-top-row: the hood's edge at the image's left and right edges "
                  "(default: the image's bottom)")
      ->type_name("V")
      ->check(CLI::Range(1.0, 16384.0))
      ->needs(hood);
  app->add_flag("--labels-through-hood", flags->labels_through_hood,
                "--hood-top-row: label the lanes on through the hood to the image's bottom "
                "(CULane's convention) instead of stopping at it")
      ->needs(hood);
  app->add_flag("--static-overlay", flags->static_overlay,
                "a card on the dashboard reflected in the windscreen, at the same image position "
                "in every frame (structure fixed to the camera; not labelled)");
  app->add_option("--fps", flags->fps, "--sequence: frames per second")
      ->type_name("F")
      ->check(CLI::Range(1.0, 240.0));
  app->add_option("--speed", flags->speed_mps, "--sequence: the car's speed, m/s")
      ->type_name("V")
      ->check(CLI::Range(1.0, 40.0));
  return {app, [flags] { return RunRender(*flags); }};
}

}  // namespace lane::cli
