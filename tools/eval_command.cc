// `lane eval`: scores lane detections against a labelled data set (the
// paper's rule and the CULane metric) and writes the tables, the results and
// Fig. 12-style overlays. docs/evaluation.md describes it.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "args.h"
#include "cli_config.h"
#include "commands.h"
#include "eval_overlay.h"
#include "lane/config.h"
#include "lane/detector.h"
#include "lane/eval/dataset.h"
#include "lane/eval/evaluate.h"
#include "lane/eval/report.h"
#include "lane/eval/results_jsonl.h"
#include "lane/eval/results_txt.h"
#include "lane/eval/seeds.h"
#include "lane/ipm.h"
#include "progress_bar.h"
#include "results_json.h"

namespace lane_tools {
namespace {

namespace fs = std::filesystem;

constexpr char kUsage[] =
    "usage: lane eval (--config CONFIG | --results FILE) [options] DATASET\n"
    "\n"
    "Scores lane detections against the hand-drawn labels of a data set, under\n"
    "the paper's rule (Aly 2008, Tables II/III) and the CULane metric, and\n"
    "prints the tables (Markdown) on stdout. With --config it runs the detector\n"
    "on every frame; with --results it scores an existing results file.\n"
    "\n"
    "DATASET is a folder holding Caltech Lanes clips (labels.ccvl + list.txt),\n"
    "CULane frames (NNNNN.jpg + NNNNN.lines.txt), TuSimple label files (.json)\n"
    "or `lane render` output (labels.jsonl); the format is detected.\n"
    "\n"
    "options:\n"
    "  --config CONFIG   detector config (docs/config.md). With --results it\n"
    "                    only gives the frame size and the ROI (2-lanes scoring)\n"
    "  --mode all|two    detector mode and what is scored: two = only the ego\n"
    "                    lane's two labelled boundaries. Default: the config's\n"
    "                    mode, or with --results the results' mode\n"
    "  --seed N          RANSAC seed instead of the config's detector.seed\n"
    "  --seeds K         run the detector with K seeds (N, N+1, ..., N+K-1, N the\n"
    "                    --seed or the config's) and report the mean, standard\n"
    "                    deviation and range of every figure; results, overlays\n"
    "                    and the full tables are those of the first seed, the\n"
    "                    baseline (--write-baseline) holds the means\n"
    "  --results FILE    score FILE instead of running the detector: lane detect\n"
    "                    JSON Lines, or the original tool's results (.txt)\n"
    "  --out DIR         write DIR/table.md, DIR/table.json, DIR/results.txt\n"
    "                    (original format) and, when the detector ran,\n"
    "                    DIR/results.jsonl\n"
    "  --overlays DIR    write DIR/STEM.png per frame like the paper's Fig. 12:\n"
    "                    labels green, correct detections green, false positives\n"
    "                    red, misses blue (paper rule)\n"
    "  --format F        caltech, culane, tusimple or render instead of detecting it\n"
    "  --clip NAME       score only this clip of the data set\n"
    "  --rule and|or     paper rule: d^ and/or d- within bounds (default and, the\n"
    "                    paper's; or = the released Matlab code)\n"
    "  --count one-to-one|many-to-one\n"
    "                    paper rule: each label matches at most one detection,\n"
    "                    best pairs first (default), or the released code's\n"
    "                    many-to-one counting\n"
    "  --write-baseline FILE  also write the regression baseline (CULane F1 and\n"
    "                    paper figures of the total) to FILE\n"
    "  --no-progress     no progress bar (it is only drawn when stderr is a\n"
    "                    terminal anyway)\n"
    "  -h, --help        show this help\n"
    "\n"
    "Exit status: 0 when every frame was scored, 1 when the data set, config or\n"
    "results could not be read or frames failed, 2 for a bad command line.\n";

// A file name stem for a frame name: extension dropped, '/', '#', ':' and
// spaces replaced by '_'; "-2", "-3", ... appended on a clash.
std::string OverlayStem(const std::string& name, std::set<std::string>& used) {
  std::string stem = name;
  const size_t slash = stem.find_last_of('/');
  const size_t dot = stem.find_last_of('.');
  if (dot != std::string::npos && (slash == std::string::npos || dot > slash) && dot > 0) {
    stem.resize(dot);
  }
  for (char& c : stem) {
    if (c == '/' || c == '\\' || c == '#' || c == ':' || c == ' ') c = '_';
  }
  if (stem.empty()) stem = "frame";
  std::string candidate = stem;
  for (int i = 2; !used.insert(candidate).second; ++i) candidate = absl::StrCat(stem, "-", i);
  return candidate;
}

bool WriteFile(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  return static_cast<bool>(out);
}

// Creates `dir` (and its parents); an error message or "".
std::string MakeDir(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    return absl::StrCat("cannot create folder ", dir.string(), ec ? ": " + ec.message() : "");
  }
  return "";
}

std::string ShellWord(const std::string& word) {
  if (!word.empty() && word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                              "0123456789-_./=:,+") == std::string::npos) {
    return word;
  }
  std::string quoted = "'";
  for (char c : word) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

}  // namespace

int RunEval(const std::vector<std::string>& argv) {
  const absl::StatusOr<Args> args = Args::Parse(argv, {{"config"},
                                                       {"mode"},
                                                       {"seed"},
                                                       {"seeds"},
                                                       {"results"},
                                                       {"out"},
                                                       {"overlays"},
                                                       {"format"},
                                                       {"clip"},
                                                       {"rule"},
                                                       {"count"},
                                                       {"write-baseline"},
                                                       {"no-progress", false}});
  if (!args.ok()) return UsageError("eval", std::string(args.status().message()), kUsage);
  if (args->help()) {
    std::fputs(kUsage, stdout);
    return kExitOk;
  }
  if (args->positional().size() != 1) {
    return UsageError(
        "eval", args->positional().empty() ? "no DATASET given" : "give exactly one DATASET folder",
        kUsage);
  }
  const std::string dataset_dir = args->positional().front();
  const std::optional<std::string> results_path = args->Get("results");
  if (!results_path && !args->Has("config")) {
    return UsageError("eval", "give --config (run the detector) or --results (score a file)",
                      kUsage);
  }
  const auto mode = args->GetChoice("mode", {"all", "two"});
  if (!mode.ok()) return UsageError("eval", std::string(mode.status().message()), kUsage);
  const auto seed = args->GetUint64("seed");
  if (!seed.ok()) return UsageError("eval", std::string(seed.status().message()), kUsage);
  const auto format_name = args->GetChoice("format", {"caltech", "culane", "tusimple", "render"});
  if (!format_name.ok()) {
    return UsageError("eval", std::string(format_name.status().message()), kUsage);
  }
  const auto rule = args->GetChoice("rule", {"and", "or"});
  if (!rule.ok()) return UsageError("eval", std::string(rule.status().message()), kUsage);
  const auto count = args->GetChoice("count", {"one-to-one", "many-to-one"});
  if (!count.ok()) return UsageError("eval", std::string(count.status().message()), kUsage);
  if (results_path && *seed) {
    return UsageError("eval", "--seed has no effect with --results", kUsage);
  }
  const auto seed_count = args->GetUint64("seeds");
  if (!seed_count.ok()) {
    return UsageError("eval", std::string(seed_count.status().message()), kUsage);
  }
  if (*seed_count && (**seed_count < 1 || **seed_count > 1000)) {
    return UsageError("eval", "--seeds must lie in 1..1000", kUsage);
  }
  if (results_path && *seed_count) {
    return UsageError("eval", "--seeds has no effect with --results", kUsage);
  }

  // The data set.
  std::optional<lane::eval::DatasetFormat> format;
  if (*format_name) format = lane::eval::ParseDatasetFormat(**format_name);
  absl::StatusOr<lane::eval::Dataset> dataset = lane::eval::LoadDataset(dataset_dir, format);
  if (!dataset.ok()) return Failure("eval", std::string(dataset.status().message()));
  if (const auto clip = args->Get("clip")) {
    std::vector<std::string> names;
    for (const auto& c : dataset->clips) names.push_back(c.name);
    dataset->clips.erase(std::remove_if(dataset->clips.begin(), dataset->clips.end(),
                                        [&](const lane::eval::Clip& c) { return c.name != *clip; }),
                         dataset->clips.end());
    if (dataset->clips.empty()) {
      return Failure("eval", absl::StrCat("no clip \"", *clip, "\" in ", dataset_dir,
                                          " (clips: ", absl::StrJoin(names, ", "), ")"));
    }
  }
  if (dataset->FrameCount() == 0) {
    return Failure("eval", absl::StrCat(dataset_dir, " holds no frames"));
  }

  lane::eval::EvalOptions options;
  if (*rule) {
    options.paper.rule = **rule == "or" ? lane::eval::PaperRuleOptions::Rule::kOr
                                        : lane::eval::PaperRuleOptions::Rule::kAnd;
  }
  if (*count) {
    options.paper.assignment = **count == "many-to-one"
                                   ? lane::eval::PaperRuleOptions::Assignment::kManyToOne
                                   : lane::eval::PaperRuleOptions::Assignment::kOneToOne;
  }

  // The config, the detector (when it runs) and the ROI.
  std::optional<lane::Config> config;
  std::optional<lane::Roi> roi;
  if (const auto config_path = args->Get("config")) {
    absl::StatusOr<lane::Config> loaded = LoadEffectiveConfig(config_path, *mode);
    if (!loaded.ok()) return Failure("eval", std::string(loaded.status().message()));
    if (*seed) loaded->detector.seed = **seed;
    config = *loaded;
    const absl::StatusOr<lane::IpmMapping> ipm =
        lane::IpmMapping::Create(config->camera, config->ipm);
    if (!ipm.ok()) return Failure("eval", std::string(ipm.status().message()));
    roi = ipm->roi();
    options.ego_row = roi->bottom;
    options.default_width = config->camera.image_width;
    options.default_height = config->camera.image_height;
  }
  std::optional<lane::Detector> detector;
  std::vector<lane::Detector> more_seeds;  // --seeds: the second seed's detector onwards
  std::vector<uint64_t> seeds;
  std::vector<lane::eval::FrameResult> records;
  if (results_path) {
    const bool txt = absl::AsciiStrToLower(fs::path(*results_path).extension().string()) == ".txt";
    absl::StatusOr<std::vector<lane::eval::FrameResult>> read =
        txt ? lane::eval::ReadResultsTxt(*results_path)
            : lane::eval::ReadResultsJsonl(*results_path);
    if (!read.ok()) return Failure("eval", std::string(read.status().message()));
    records = std::move(*read);
    // The mode: --mode, else the records' (when they agree), else all.
    std::set<std::string> modes;
    for (const auto& r : records) {
      if (!r.mode.empty()) modes.insert(r.mode);
    }
    std::string chosen = *mode ? **mode : (modes.size() == 1 ? *modes.begin() : "all");
    if (*mode && !modes.empty() && (modes.size() > 1 || *modes.begin() != **mode)) {
      std::fprintf(stderr, "lane eval: warning: --mode %s, but the results were made in mode %s\n",
                   (*mode)->c_str(), absl::StrJoin(modes, ", ").c_str());
    }
    const std::optional<lane::Mode> parsed = lane::ParseMode(chosen);
    if (!parsed) {
      return Failure("eval", absl::StrCat("the results' mode \"", chosen,
                                          "\" is neither all nor two: give --mode"));
    }
    options.mode = *parsed;
  } else {
    absl::StatusOr<lane::Detector> created =
        lane::Detector::Create(config->camera, config->ipm, config->detector);
    if (!created.ok()) {
      return Failure("eval",
                     absl::StrCat("cannot build the detector: ", created.status().message()));
    }
    detector = std::move(*created);
    options.mode = detector->options().mode;
    if (*seed_count) {
      const uint64_t first = config->detector.seed;
      seeds.push_back(first);
      for (uint64_t k = 1; k < **seed_count; ++k) {
        lane::DetectorOptions o = config->detector;
        o.seed = first + k;
        absl::StatusOr<lane::Detector> d = lane::Detector::Create(config->camera, config->ipm, o);
        if (!d.ok()) return Failure("eval", std::string(d.status().message()));
        more_seeds.push_back(std::move(*d));
        seeds.push_back(o.seed);
      }
    }
  }

  // Output files.
  std::ofstream jsonl, txt;
  fs::path out_dir;
  if (const auto out = args->Get("out")) {
    out_dir = *out;
    if (const std::string e = MakeDir(out_dir); !e.empty()) return Failure("eval", e);
    if (detector) {
      jsonl.open(out_dir / "results.jsonl", std::ios::binary | std::ios::trunc);
      if (!jsonl)
        return Failure("eval", absl::StrCat("cannot write ", (out_dir / "results.jsonl").string()));
    }
    txt.open(out_dir / "results.txt", std::ios::binary | std::ios::trunc);
    if (!txt)
      return Failure("eval", absl::StrCat("cannot write ", (out_dir / "results.txt").string()));
  }
  fs::path overlay_dir;
  if (const auto overlays = args->Get("overlays")) {
    overlay_dir = *overlays;
    if (const std::string e = MakeDir(overlay_dir); !e.empty()) return Failure("eval", e);
  }

  ProgressBar progress(!args->Has("no-progress"));
  std::set<std::string> used_stems;
  int run_failures = 0;
  bool output_failed = false;
  const auto report_problem = [&](const std::string& message) {
    progress.Clear();
    std::fprintf(stderr, "lane eval: %s\n", message.c_str());
  };
  const lane::eval::FrameCallback on_frame = [&](const lane::eval::FrameOutcome& o) {
    if (!o.error.empty() && detector) {
      ++run_failures;
      report_problem(absl::StrCat(o.frame->name, ": ", o.error));
    }
    if (jsonl.is_open()) {
      jsonl << (o.detection != nullptr ? DetectionJsonLine(o.frame->name, o.width, o.height,
                                                           options.mode, *o.detection, o.decode_ms)
                                       : ErrorJsonLine(o.frame->name, o.image.cols, o.image.rows,
                                                       options.mode, o.error))
            << '\n';
    }
    if (txt.is_open()) txt << lane::eval::ResultsTxtFrame(o.index, o.lanes);
    if (!overlay_dir.empty()) {
      cv::Mat image = o.image;
      if (image.empty()) {
        try {
          image = cv::imread(o.frame->image_path, cv::IMREAD_COLOR);
        } catch (const cv::Exception&) {
        }
      }
      if (image.empty()) {
        report_problem(
            absl::StrCat(o.frame->name, ": no overlay: cannot read ", o.frame->image_path));
      } else {
        const fs::path path = overlay_dir / (OverlayStem(o.frame->name, used_stems) + ".png");
        bool written = false;
        try {
          written = cv::imwrite(path.string(), DrawEvaluation(image, o, options, roi));
        } catch (const cv::Exception&) {
        }
        if (!written) {
          output_failed = true;
          report_problem(absl::StrCat("cannot write ", path.string()));
        }
      }
    }
    progress.Update(o.index + 1, o.total, o.frame->name);
  };

  absl::StatusOr<lane::eval::EvalReport> report;
  std::optional<lane::eval::SeedSummary> summary;
  if (detector) {
    std::vector<const lane::Detector*> all = {&*detector};
    for (const lane::Detector& d : more_seeds) all.push_back(&d);
    absl::StatusOr<std::vector<lane::eval::EvalReport>> reports =
        lane::eval::EvaluateDetectors(*dataset, all, options, on_frame);
    if (reports.ok()) {
      if (!seeds.empty()) summary = lane::eval::SummariseSeeds(*reports, seeds);
      report = std::move(reports->front());
    } else {
      report = reports.status();
    }
  } else {
    report = lane::eval::EvaluateResults(*dataset, records, options, on_frame);
  }
  progress.Clear();
  if (!report.ok()) return Failure("eval", std::string(report.status().message()));
  const lane::eval::SeedSummary* seeds_summary = summary ? &*summary : nullptr;
  report->source = detector ? absl::StrCat("detector, config ", *args->Get("config"), ", seed ",
                                           config->detector.seed)
                            : absl::StrCat("results ", *results_path);

  const std::string markdown = lane::eval::ReportMarkdown(*report, seeds_summary);
  std::fputs(markdown.c_str(), stdout);
  std::fflush(stdout);
  for (const std::string& w : report->warnings) {
    std::fprintf(stderr, "lane eval: warning: %s\n", w.c_str());
  }
  if (!out_dir.empty()) {
    // Only streams that were opened are closed and checked: close() on a
    // stream that never opened (results.jsonl when scoring --results) sets
    // its failbit, which used to fail every --results --out run.
    bool streams_ok = true;
    for (std::ofstream* stream : {&jsonl, &txt}) {
      if (!stream->is_open()) continue;
      stream->close();
      streams_ok = streams_ok && !stream->fail();
    }
    if (!streams_ok || !WriteFile(out_dir / "table.md", markdown) ||
        !WriteFile(out_dir / "table.json", lane::eval::ReportJson(*report, seeds_summary))) {
      output_failed = true;
      std::fprintf(stderr, "lane eval: error writing to %s\n", out_dir.string().c_str());
    }
  }
  if (const auto baseline = args->Get("write-baseline")) {
    std::vector<std::string> words = {"lane", "eval"};
    for (const std::string& a : argv) words.push_back(ShellWord(a));
    const fs::path parent = fs::path(*baseline).parent_path();
    if (!parent.empty()) MakeDir(parent);
    if (!WriteFile(*baseline,
                   lane::eval::BaselineJson(*report, absl::StrJoin(words, " "), seeds_summary))) {
      output_failed = true;
      std::fprintf(stderr, "lane eval: cannot write %s\n", baseline->c_str());
    }
  }
  const lane::eval::ClipCounts& t = report->total;
  std::fprintf(stderr,
               "lane eval: %d frames scored, paper rule F1 %.3f (correct %.2f%%, %.3f fp/frame), "
               "CULane F1 %.3f\n",
               t.frames, t.paper.F1(), 100 * t.paper.CorrectRate(),
               t.paper.FalsePositivesPerFrame(t.frames), t.culane.F1());
  if (summary) {
    const lane::eval::ClipSpread& m = summary->total;
    std::fprintf(stderr,
                 "lane eval: over %zu seeds: correct %.2f%% [%.2f, %.2f], FP rate %.2f%% [%.2f, "
                 "%.2f], CULane F1 %.3f ± %.3f [%.3f, %.3f]\n",
                 summary->seeds.size(), 100 * m.correct_rate.mean, 100 * m.correct_rate.min,
                 100 * m.correct_rate.max, 100 * m.false_positive_rate.mean,
                 100 * m.false_positive_rate.min, 100 * m.false_positive_rate.max, m.culane_f1.mean,
                 m.culane_f1.std, m.culane_f1.min, m.culane_f1.max);
  }
  return run_failures > 0 || output_failed ? kExitFailure : kExitOk;
}

}  // namespace lane_tools
