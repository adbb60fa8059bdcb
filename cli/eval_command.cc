// `lane eval`: scores lane detections against a labelled data set (the
// paper's rule and the CULane metric) and writes the tables, the results and
// Fig. 12-style overlays. docs/evaluation.md describes it.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "commands.h"
#include "eval_drive.h"
#include "eval_files.h"
#include "eval_overlay.h"
#include "io/cli_config.h"
#include "io/progress_bar.h"
#include "io/results_json.h"
#include "lane/config/config.h"
#include "lane/detector/detector.h"
#include "lane/eval/dataset.h"
#include "lane/eval/evaluate.h"
#include "lane/eval/report.h"
#include "lane/eval/results_jsonl.h"
#include "lane/eval/results_txt.h"
#include "lane/eval/seeds.h"
#include "lane/geometry/ipm.h"

namespace lane::cli {
namespace {

namespace fs = std::filesystem;

constexpr char kEvalDescription[] =
    "Scores lane detections against the hand-drawn labels of a data set, under\n"
    "the paper's rule (Aly 2008, Tables II/III) and the CULane metric, and\n"
    "prints the tables (Markdown) on stdout. With --config it runs the detector\n"
    "on every frame; with --results it scores an existing results file.\n"
    "\n"
    "DATASET is a folder holding Caltech Lanes clips (labels.ccvl + list.txt),\n"
    "CULane frames (NNNNN.jpg + NNNNN.lines.txt), TuSimple label files (.json)\n"
    "or `lane render` output (labels.jsonl); the format is detected.";

constexpr char kEvalFooter[] =
    "Exit status: 0 when every frame was scored, 1 when the data set, config or\n"
    "results could not be read or frames failed, 2 for a bad command line.";

struct EvalFlags {
  std::string dataset;
  std::optional<std::string> config;
  std::optional<std::string> mode;
  std::optional<uint64_t> seed;
  std::optional<uint64_t> seeds;
  std::optional<std::string> results;
  std::optional<std::string> out;
  std::optional<std::string> overlays;
  std::optional<std::string> format;
  std::optional<std::string> clip;
  std::optional<std::string> rule;
  std::optional<std::string> count;
  std::optional<std::string> write_baseline;
  bool no_progress = false;
  bool drive = false;
  bool skip_repeated_labels = false;
};

// A usage error in flags CLI11 cannot check by itself, or "".
std::string FlagsError(const EvalFlags& flags) {
  if (flags.dataset.empty()) return "no DATASET given";
  if (!flags.results && !flags.config) {
    return "give --config (run the detector) or --results (score a file)";
  }
  if (flags.results && flags.seed) return "--seed has no effect with --results";
  if (flags.seeds && (*flags.seeds < 1 || *flags.seeds > 1000))
    return "--seeds must lie in 1..1000";
  if (flags.results && flags.seeds) return "--seeds has no effect with --results";
  if (flags.drive && (flags.seeds || flags.out || flags.overlays || flags.clip ||
                      flags.write_baseline || flags.format || flags.skip_repeated_labels)) {
    return "--drive takes --config or --results, --mode, --seed, --rule and --count only";
  }
  return "";
}

// The data set, only the --clip clip when given.
absl::StatusOr<lane::eval::Dataset> LoadSelectedDataset(const EvalFlags& flags) {
  const std::string& dataset_dir = flags.dataset;
  std::optional<lane::eval::DatasetFormat> format;
  if (flags.format) format = lane::eval::ParseDatasetFormat(*flags.format);
  absl::StatusOr<lane::eval::Dataset> dataset = lane::eval::LoadDataset(dataset_dir, format);
  if (!dataset.ok()) return dataset.status();
  if (const auto& clip = flags.clip) {
    std::vector<std::string> names;
    for (const auto& c : dataset->clips) names.push_back(c.name);
    dataset->clips.erase(std::remove_if(dataset->clips.begin(), dataset->clips.end(),
                                        [&](const lane::eval::Clip& c) { return c.name != *clip; }),
                         dataset->clips.end());
    if (dataset->clips.empty()) {
      return absl::NotFoundError(absl::StrCat("no clip \"", *clip, "\" in ", dataset_dir,
                                              " (clips: ", absl::StrJoin(names, ", "), ")"));
    }
  }
  if (dataset->FrameCount() == 0) {
    return absl::NotFoundError(absl::StrCat(dataset_dir, " holds no frames"));
  }
  if (flags.skip_repeated_labels) {
    // Still run (the results keep their frame numbering), no longer scored.
    for (lane::eval::Clip& clip : dataset->clips) {
      for (size_t i : lane::eval::FindRepeatedLabels(clip).indices) {
        clip.frames[i].labelled = false;
      }
    }
  }
  return dataset;
}

// --rule and --count.
lane::eval::EvalOptions ScoringOptions(const EvalFlags& flags) {
  lane::eval::EvalOptions options;
  if (flags.rule) {
    options.paper.rule = *flags.rule == "or" ? lane::eval::PaperRuleOptions::Rule::kOr
                                             : lane::eval::PaperRuleOptions::Rule::kAnd;
  }
  if (flags.count) {
    options.paper.assignment = *flags.count == "many-to-one"
                                   ? lane::eval::PaperRuleOptions::Assignment::kManyToOne
                                   : lane::eval::PaperRuleOptions::Assignment::kOneToOne;
  }
  return options;
}

// What is scored: the detectors' output (with --config and no --results) or
// a results file; the config (when given) and its ROI; the mode.
struct EvalSource {
  std::optional<lane::Config> config;
  std::optional<lane::Roi> roi;
  // The config's detector, and with --seeds one per seed (the first: the
  // config's or --seed's seed); empty with --results.
  std::vector<lane::Detector> detectors;
  std::vector<uint64_t> seeds;  // --seeds: every detector's seed
  std::vector<lane::eval::FrameResult> records;
  lane::Mode mode = lane::Mode::kAll;  // the detectors', or the records'
};

// The config, when --config is given, and its ROI.
struct LoadedConfig {
  lane::Config config;
  lane::Roi roi;
};

absl::StatusOr<std::optional<LoadedConfig>> LoadConfig(const EvalFlags& flags) {
  const auto& config_path = flags.config;
  if (!config_path) return std::nullopt;
  absl::StatusOr<lane::Config> config = io::LoadEffectiveConfig(config_path, flags.mode);
  if (!config.ok()) return config.status();
  if (flags.seed) config->detector.seed = *flags.seed;
  const absl::StatusOr<lane::IpmMapping> ipm =
      lane::IpmMapping::Create(config->camera, config->ipm);
  if (!ipm.ok()) return ipm.status();
  return LoadedConfig{*std::move(config), ipm->roi()};
}

// --results: the records and the mode they are scored in: --mode, else the
// records' (when they agree), else all.
struct ResultsRecords {
  std::vector<lane::eval::FrameResult> records;
  lane::Mode mode = lane::Mode::kAll;
};

absl::StatusOr<ResultsRecords> ReadResults(const EvalFlags& flags) {
  const std::string& results_path = *flags.results;
  const bool txt = absl::AsciiStrToLower(fs::path(results_path).extension().string()) == ".txt";
  absl::StatusOr<std::vector<lane::eval::FrameResult>> read =
      txt ? lane::eval::ReadResultsTxt(results_path) : lane::eval::ReadResultsJsonl(results_path);
  if (!read.ok()) return read.status();
  std::set<std::string> modes;
  for (const auto& r : *read) {
    if (!r.mode.empty()) modes.insert(r.mode);
  }
  const std::optional<std::string>& mode = flags.mode;
  std::string chosen = mode ? *mode : (modes.size() == 1 ? *modes.begin() : "all");
  if (mode && !modes.empty() && (modes.size() > 1 || *modes.begin() != *mode)) {
    std::fprintf(stderr, "lane eval: warning: --mode %s, but the results were made in mode %s\n",
                 mode->c_str(), absl::StrJoin(modes, ", ").c_str());
  }
  const std::optional<lane::Mode> parsed = lane::ParseMode(chosen);
  if (!parsed) {
    return absl::InvalidArgumentError(
        absl::StrCat("the results' mode \"", chosen, "\" is neither all nor two: give --mode"));
  }
  return ResultsRecords{*std::move(read), *parsed};
}

// Without --results: the detector of the config, and with --seeds K one per
// seed (N, N+1, ..., N+K-1; N the config's or --seed's).
struct SeedDetectors {
  std::vector<lane::Detector> detectors;
  std::vector<uint64_t> seeds;  // with --seeds
};

absl::StatusOr<SeedDetectors> MakeDetectors(const EvalFlags& flags, const lane::Config& config) {
  const uint64_t count = flags.seeds ? *flags.seeds : 0;
  SeedDetectors out;
  for (uint64_t k = 0; k < std::max<uint64_t>(count, 1); ++k) {
    lane::DetectorOptions detector_options = config.detector;
    detector_options.seed = config.detector.seed + k;
    absl::StatusOr<lane::Detector> created =
        lane::Detector::Create(config.camera, config.ipm, detector_options);
    if (!created.ok()) {
      return absl::Status(created.status().code(),
                          absl::StrCat("cannot build the detector: ", created.status().message()));
    }
    if (count > 0) out.seeds.push_back(detector_options.seed);
    out.detectors.push_back(*std::move(created));
  }
  return out;
}

// The config (when given) and what is scored: the records of --results, or
// the detectors of the config.
absl::StatusOr<EvalSource> LoadSource(const EvalFlags& flags) {
  EvalSource source;
  absl::StatusOr<std::optional<LoadedConfig>> loaded = LoadConfig(flags);
  if (!loaded.ok()) return loaded.status();
  if (*loaded) {
    source.config = std::move((*loaded)->config);
    source.roi = (*loaded)->roi;
  }
  if (flags.results) {
    absl::StatusOr<ResultsRecords> read = ReadResults(flags);
    if (!read.ok()) return read.status();
    source.records = std::move(read->records);
    source.mode = read->mode;
  } else {
    absl::StatusOr<SeedDetectors> made = MakeDetectors(flags, *source.config);
    if (!made.ok()) return made.status();
    source.detectors = std::move(made->detectors);
    source.seeds = std::move(made->seeds);
    source.mode = source.detectors.front().options().mode;
  }
  return source;
}

// The scoring options: --rule and --count, the mode, and with a config its
// ROI's bottom (the 2-lanes ego row) and frame size.
lane::eval::EvalOptions OptionsFor(const EvalFlags& flags, const EvalSource& source) {
  lane::eval::EvalOptions options = ScoringOptions(flags);
  if (source.roi) {
    options.ego_row = source.roi->bottom;
    options.default_width = source.config->camera.image_width;
    options.default_height = source.config->camera.image_height;
  }
  options.mode = source.mode;
  return options;
}

// The files written while frames are scored (--output, --overlay), the
// progress bar and the problems met on the way.
class EvalOutputs {
 public:
  explicit EvalOutputs(const EvalFlags& flags) : progress_(!flags.no_progress) {}

  // Creates the folders and opens the results files; an error message or "".
  std::string Open(const EvalFlags& flags, bool detector) {
    if (const auto& out = flags.out) {
      out_dir_ = *out;
      if (const std::string e = MakeDir(out_dir_); !e.empty()) return e;
      if (detector) {
        jsonl_.open(out_dir_ / "results.jsonl", std::ios::binary | std::ios::trunc);
        if (!jsonl_) return absl::StrCat("cannot write ", (out_dir_ / "results.jsonl").string());
      }
      txt_.open(out_dir_ / "results.txt", std::ios::binary | std::ios::trunc);
      if (!txt_) return absl::StrCat("cannot write ", (out_dir_ / "results.txt").string());
      frames_.open(out_dir_ / "frames.jsonl", std::ios::binary | std::ios::trunc);
      if (!frames_) return absl::StrCat("cannot write ", (out_dir_ / "frames.jsonl").string());
    }
    if (const auto& overlays = flags.overlays) {
      overlay_dir_ = *overlays;
      if (const std::string e = MakeDir(overlay_dir_); !e.empty()) return e;
    }
    return "";
  }

  void OnFrame(const lane::eval::FrameOutcome& o, const lane::eval::EvalOptions& options,
               const std::optional<lane::Roi>& roi, bool detector) {
    if (!o.error.empty() && detector) {
      ++run_failures_;
      ReportProblem(absl::StrCat(o.frame->name, ": ", o.error));
    }
    if (jsonl_.is_open()) {
      jsonl_ << io::JsonLine(
                    o.detection != nullptr
                        ? io::DetectionJson({o.frame->name, o.width, o.height, options.mode},
                                            *o.detection, o.decode_ms)
                        : io::ErrorJson({o.frame->name, o.image.cols, o.image.rows, options.mode},
                                        o.error))
             << '\n';
    }
    if (txt_.is_open()) txt_ << lane::eval::ResultsTxtFrame(o.index, o.lanes);
    if (frames_.is_open() && o.score)
      frames_ << FrameMatchJsonLine(o.frame->name, *o.score) << '\n';
    if (!overlay_dir_.empty()) WriteOverlay(o, options, roi);
    progress_.Update(o.index + 1, o.total, o.frame->name);
  }

  void ClearProgress() { progress_.Clear(); }

  // Closes the results files and writes the tables to --output.
  void Finish(const lane::eval::EvalReport& report, const std::string& markdown,
              const lane::eval::SeedSummary* seeds) {
    if (out_dir_.empty()) return;
    // Only streams that were opened are closed and checked: close() on a
    // stream that never opened (results.jsonl when scoring --results) sets
    // its failbit, which used to fail every --results --output run.
    bool streams_ok = true;
    for (std::ofstream* stream : {&jsonl_, &txt_, &frames_}) {
      if (!stream->is_open()) continue;
      stream->close();
      streams_ok = streams_ok && !stream->fail();
    }
    if (!streams_ok || !WriteFile(out_dir_ / "table.md", markdown) ||
        !WriteFile(out_dir_ / "table.json", lane::eval::ReportJson(report, seeds))) {
      output_failed_ = true;
      std::fprintf(stderr, "lane eval: error writing to %s\n", out_dir_.string().c_str());
    }
  }

  int run_failures() const { return run_failures_; }
  bool output_failed() const { return output_failed_; }
  void set_output_failed() { output_failed_ = true; }

 private:
  void ReportProblem(const std::string& message) {
    progress_.Clear();
    std::fprintf(stderr, "lane eval: %s\n", message.c_str());
  }

  void WriteOverlay(const lane::eval::FrameOutcome& o, const lane::eval::EvalOptions& options,
                    const std::optional<lane::Roi>& roi) {
    cv::Mat image = o.image;
    if (image.empty()) {
      try {
        image = cv::imread(o.frame->image_path, cv::IMREAD_COLOR);
      } catch (const cv::Exception&) {
      }
    }
    if (image.empty()) {
      ReportProblem(absl::StrCat(o.frame->name, ": no overlay: cannot read ", o.frame->image_path));
      return;
    }
    const fs::path path = overlay_dir_ / (OverlayStem(o.frame->name, used_stems_) + ".png");
    bool written = false;
    try {
      written = cv::imwrite(path.string(), DrawEvaluation(image, o, options, roi));
    } catch (const cv::Exception&) {
    }
    if (!written) {
      output_failed_ = true;
      ReportProblem(absl::StrCat("cannot write ", path.string()));
    }
  }

  io::ProgressBar progress_;
  std::ofstream jsonl_, txt_, frames_;
  fs::path out_dir_;
  fs::path overlay_dir_;
  std::set<std::string> used_stems_;
  int run_failures_ = 0;
  bool output_failed_ = false;
};

// --write-baseline: the regression baseline with the command that made it;
// false when it cannot be written.
bool WriteBaseline(const std::string& baseline, const lane::eval::EvalReport& report,
                   const lane::eval::SeedSummary* seeds, const std::vector<std::string>& argv) {
  std::vector<std::string> words = {"lane", "eval"};
  for (const std::string& a : argv) words.push_back(ShellWord(a));
  const fs::path parent = fs::path(baseline).parent_path();
  if (!parent.empty()) MakeDir(parent);
  if (!WriteFile(baseline, lane::eval::BaselineJson(report, absl::StrJoin(words, " "), seeds))) {
    std::fprintf(stderr, "lane eval: cannot write %s\n", baseline.c_str());
    return false;
  }
  return true;
}

// --drive: scores the data set as one drive (eval_drive.h).
int RunDriveFlags(const EvalFlags& flags) {
  DriveEvalArgs args;
  args.dataset = flags.dataset;
  args.config = flags.config;
  args.mode = flags.mode;
  args.seed = flags.seed;
  args.results = flags.results;
  args.rule = ScoringOptions(flags).paper;
  return RunDriveEval(args);
}

// What Score reports: the first seed's report, and with --seeds the summary
// over the seeds.
struct Scored {
  lane::eval::EvalReport report;
  std::optional<lane::eval::SeedSummary> summary;
};

// Scores the detectors or the results records.
absl::StatusOr<Scored> Score(const lane::eval::Dataset& dataset,
                             const lane::eval::EvalOptions& options, const EvalSource& source,
                             const lane::eval::FrameCallback& on_frame) {
  if (source.detectors.empty()) {
    absl::StatusOr<lane::eval::EvalReport> report =
        lane::eval::EvaluateResults(dataset, source.records, options, on_frame);
    if (!report.ok()) return report.status();
    return Scored{*std::move(report), std::nullopt};
  }
  std::vector<const lane::Detector*> all;
  for (const lane::Detector& d : source.detectors) all.push_back(&d);
  absl::StatusOr<std::vector<lane::eval::EvalReport>> reports =
      lane::eval::EvaluateDetectors(dataset, all, options, on_frame);
  if (!reports.ok()) return reports.status();
  std::optional<lane::eval::SeedSummary> summary;
  if (!source.seeds.empty()) summary = lane::eval::SummariseSeeds(*reports, source.seeds);
  return Scored{std::move(reports->front()), std::move(summary)};
}

// The one-line totals on stderr, and with --seeds their spread.
void PrintTotals(const lane::eval::EvalReport& report,
                 const std::optional<lane::eval::SeedSummary>& summary) {
  const lane::eval::ClipCounts& t = report.total;
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
}

int RunEval(const CLI::App& app, const EvalFlags& flags, const std::vector<std::string>& argv) {
  if (const std::string e = FlagsError(flags); !e.empty()) return io::UsageError(app, e);
  if (flags.drive) return RunDriveFlags(flags);

  const absl::StatusOr<lane::eval::Dataset> dataset = LoadSelectedDataset(flags);
  if (!dataset.ok()) return Failure("eval", std::string(dataset.status().message()));
  const absl::StatusOr<EvalSource> source = LoadSource(flags);
  if (!source.ok()) return Failure("eval", std::string(source.status().message()));
  const lane::eval::EvalOptions options = OptionsFor(flags, *source);
  const bool detector = !source->detectors.empty();

  EvalOutputs outputs(flags);
  if (const std::string e = outputs.Open(flags, detector); !e.empty()) return Failure("eval", e);
  const lane::eval::FrameCallback on_frame = [&](const lane::eval::FrameOutcome& o) {
    outputs.OnFrame(o, options, source->roi, detector);
  };
  absl::StatusOr<Scored> scored = Score(*dataset, options, *source, on_frame);
  outputs.ClearProgress();
  if (!scored.ok()) return Failure("eval", std::string(scored.status().message()));
  lane::eval::EvalReport* report = &scored->report;
  const std::optional<lane::eval::SeedSummary>& summary = scored->summary;
  const lane::eval::SeedSummary* seeds_summary = summary ? &*summary : nullptr;
  report->source = detector ? absl::StrCat("detector, config ", *flags.config, ", seed ",
                                           source->config->detector.seed)
                            : absl::StrCat("results ", *flags.results);

  const std::string markdown = lane::eval::ReportMarkdown(*report, seeds_summary);
  std::fputs(markdown.c_str(), stdout);
  std::fflush(stdout);
  for (const std::string& w : report->warnings) {
    std::fprintf(stderr, "lane eval: warning: %s\n", w.c_str());
  }
  outputs.Finish(*report, markdown, seeds_summary);
  if (flags.write_baseline && !WriteBaseline(*flags.write_baseline, *report, seeds_summary, argv)) {
    outputs.set_output_failed();
  }
  PrintTotals(*report, summary);
  return outputs.run_failures() > 0 || outputs.output_failed() ? io::kExitFailure : io::kExitOk;
}

}  // namespace

io::Command AddEvalCommand(CLI::App& lane, const std::vector<std::string>& args) {
  auto flags = std::make_shared<EvalFlags>();
  CLI::App* app = io::AddCommand(
      lane, "eval", "score detections against a labelled data set (paper rule, CULane F1)",
      kEvalDescription, kEvalFooter);
  io::AddOptional(app, "--config", &flags->config,
                  "detector config (docs/config.md). With --results it only gives the frame size "
                  "and the ROI (2-lanes scoring)")
      ->type_name("CONFIG");
  io::OneOf(io::AddOptional(
                app, "--mode", &flags->mode,
                "detector mode and what is scored: two = only the ego lane's two labelled "
                "boundaries. Default: the config's mode, or with --results the results' mode"),
            {"all", "two"});
  io::AddOptional(app, "--seed", &flags->seed, "RANSAC seed instead of the config's detector.seed")
      ->type_name("N");
  io::AddOptional(
      app, "--seeds", &flags->seeds,
      "run the detector with K seeds (N, N+1, ..., N+K-1, N the --seed or the config's) "
      "and report the mean, standard deviation and range of every figure; results, "
      "overlays and the full tables are those of the first seed, the baseline "
      "(--write-baseline) holds the means")
      ->type_name("K");
  io::AddOptional(app, "--results", &flags->results,
                  "score FILE instead of running the detector: lane detect JSON Lines, or the "
                  "original tool's results (.txt)")
      ->type_name("FILE");
  io::AddOptional(
      app, "--output,--out", &flags->out,
      "write DIR/table.md, DIR/table.json, DIR/results.txt (original format), DIR/frames.jsonl "
      "(per frame: the label each detection matched, -1 = false positive) and, when "
      "the detector ran, DIR/results.jsonl")
      ->type_name("DIR");
  io::AddOptional(app, "--overlay,--overlays", &flags->overlays,
                  "write DIR/STEM.png per frame like the paper's Fig. 12: labels green, correct "
                  "detections green, false positives red, misses blue (paper rule)")
      ->type_name("DIR");
  io::OneOf(io::AddOptional(app, "--format", &flags->format,
                            "the data set's format instead of detecting it"),
            {"caltech", "culane", "tusimple", "render"});
  io::AddOptional(app, "--clip", &flags->clip, "score only this clip of the data set")
      ->type_name("NAME");
  io::OneOf(
      io::AddOptional(app, "--rule", &flags->rule,
                      "paper rule: d^ and/or d- within bounds (or = the released Matlab code)"),
      {"and", "or"})
      ->default_str("and, the paper's");
  io::OneOf(
      io::AddOptional(app, "--count", &flags->count,
                      "paper rule: each label matches at most one detection, best pairs first, or "
                      "the released code's many-to-one counting"),
      {"one-to-one", "many-to-one"})
      ->default_str("one-to-one");
  io::AddOptional(
      app, "--write-baseline", &flags->write_baseline,
      "also write the regression baseline (CULane F1 and paper figures of the total) to "
      "FILE")
      ->type_name("FILE");
  app->add_flag("--drive", flags->drive,
                "DATASET is one drive (lane render --sequence): score it as one camera's "
                "sequence, with --config untracked and tracked (the frames in order, the labels' "
                "times) or the --results of lane detect --track: recall, false positives, colour, "
                "type, id switches, the ego lane and departure warnings (docs/tracking.md)");
  app->add_flag("--skip-repeated-labels", flags->skip_repeated_labels,
                "do not score frames whose labels repeat the frame before's to the last digit "
                "(one annotation copied over a run of frames; they are still run)");
  app->add_flag("--no-progress", flags->no_progress,
                "no progress bar (it is only drawn when stderr is a terminal anyway)");
  app->add_option("DATASET", flags->dataset, "the data set's folder");
  return {app, [app, flags, args] { return RunEval(*app, *flags, args); }};
}

}  // namespace lane::cli
