// `lane render`: synthetic road frames with exact ground truth.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "args.h"
#include "cli_config.h"
#include "commands.h"
#include "lane/config.h"
#include "lane/synthetic.h"

namespace lane_tools {
namespace {

constexpr char kUsage[] =
    "usage: lane render --config CONFIG --count N --out DIR [options]\n"
    "\n"
    "Renders N synthetic road frames through the config's camera, with exact\n"
    "ground truth. Writes DIR/000000.png ... (frame i uses seed S + i),\n"
    "DIR/labels.jsonl (one JSON object per frame: docs/results-format.md) and\n"
    "DIR/list.txt (the frame names, one a line: an INPUT for 'lane detect').\n"
    "\n"
    "options:\n"
    "  --config CONFIG     JSON config file whose camera is used, required\n"
    "  --count N           number of frames (1..1000000), required\n"
    "  --out DIR           output folder, created when missing, required\n"
    "  --seed S            seed of the first frame (default 1)\n"
    "  --num-lanes K       lanes on the road, 0 = random 1..5 per frame (default 0)\n"
    "  --jpeg-quality Q    simulated JPEG artefacts, quality 1..100, 0 = none\n"
    "                      (default 80). With --format jpg the file itself is\n"
    "                      written at quality Q (95 when Q is 0) instead.\n"
    "  --format png|jpg    image file format (default png)\n"
    "  -h, --help          show this help\n";

}  // namespace

int RunRender(const std::vector<std::string>& argv) {
  const absl::StatusOr<Args> args = Args::Parse(
      argv,
      {{"config"}, {"count"}, {"seed"}, {"out"}, {"num-lanes"}, {"jpeg-quality"}, {"format"}});
  if (!args.ok()) return UsageError("render", std::string(args.status().message()), kUsage);
  if (args->help()) {
    std::fputs(kUsage, stdout);
    return kExitOk;
  }
  if (!args->positional().empty()) {
    return UsageError("render", "unexpected argument " + args->positional()[0], kUsage);
  }
  for (const char* required : {"config", "count", "out"}) {
    if (!args->Has(required)) {
      return UsageError("render", absl::StrCat("--", required, " is required"), kUsage);
    }
  }
  const auto count = args->GetInt("count", 1, 1000000);
  const auto seed = args->GetUint64("seed");
  const auto num_lanes = args->GetInt("num-lanes", 0, 20);
  const auto quality = args->GetInt("jpeg-quality", 0, 100);
  const auto format = args->GetChoice("format", {"png", "jpg"});
  for (const absl::Status& s :
       {count.status(), seed.status(), num_lanes.status(), quality.status(), format.status()}) {
    if (!s.ok()) return UsageError("render", std::string(s.message()), kUsage);
  }

  const absl::StatusOr<lane::Config> config = LoadEffectiveConfig(args->Get("config"), {});
  if (!config.ok()) return Failure("render", std::string(config.status().message()));

  lane::SyntheticOptions options;
  if (*num_lanes) options.num_lanes = static_cast<int>(**num_lanes);
  if (*quality) options.jpeg_quality = static_cast<int>(**quality);
  const bool jpg = format->value_or("png") == "jpg";
  std::vector<int> write_params;
  if (jpg) {
    // One JPEG compression only: the file's.
    write_params = {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality > 0 ? options.jpeg_quality : 95};
    options.jpeg_quality = 0;
  }

  const std::filesystem::path dir = *args->Get("out");
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir)) {
    return Failure("render", absl::StrCat("cannot create ", dir.string(),
                                          ec ? ": " + ec.message() : std::string()));
  }
  std::ofstream labels(dir / "labels.jsonl", std::ios::binary | std::ios::trunc);
  std::ofstream list(dir / "list.txt", std::ios::binary | std::ios::trunc);
  if (!labels || !list) {
    return Failure("render", absl::StrCat("cannot write labels.jsonl/list.txt in ", dir.string()));
  }

  const uint64_t first_seed = seed->value_or(1);
  for (int64_t i = 0; i < **count; ++i) {
    absl::StatusOr<lane::SyntheticFrame> frame =
        lane::RenderSyntheticFrame(config->camera, options, first_seed + static_cast<uint64_t>(i));
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
    labels << lane::SyntheticLabelsJson(name, *frame) << '\n';
    list << name << '\n';
  }
  labels.close();
  list.close();
  if (!labels || !list) {
    return Failure("render", absl::StrCat("error writing labels.jsonl/list.txt in ", dir.string()));
  }
  std::fprintf(stderr, "lane render: %lld frames in %s\n", static_cast<long long>(**count),
               dir.string().c_str());
  return kExitOk;
}

}  // namespace lane_tools
