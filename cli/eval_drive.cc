#include "eval_drive.h"

#include <cstdio>
#include <filesystem>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "commands.h"
#include "io/cli_config.h"
#include "lane/detector/detector.h"
#include "lane/eval/drive.h"
#include "lane/eval/drive_io.h"

namespace lane::cli {
namespace {

namespace fs = std::filesystem;

struct Column {
  std::string name;
  lane::eval::DriveScore score;
  // Colour, type, ids and the ego lane were reported (untracked `lane
  // detect` results have none of them).
  bool attributes = true;
};

std::string Leads(const lane::eval::DriveScore& s) {
  if (s.departure_leads_s.empty()) return "no lane change";
  std::string out;
  for (const auto& lead : s.departure_leads_s) {
    if (!out.empty()) out += ", ";
    out += lead ? absl::StrFormat("%.2f s", *lead) : std::string("none");
  }
  return out;
}

std::string Report(const std::string& source, const std::vector<Column>& columns) {
  std::string md = absl::StrCat("# Drive: ", source, "\n\n| |");
  std::string rule = "|---|";
  for (const Column& c : columns) {
    absl::StrAppend(&md, " ", c.name, " |");
    rule += "---|";
  }
  md += "\n" + rule + "\n";
  // A row; `attribute` rows read "-" for a column without the attributes.
  const auto row = [&](const std::string& name, auto cell, bool attribute = true) {
    absl::StrAppend(&md, "| ", name, " |");
    for (const Column& c : columns) {
      absl::StrAppend(&md, " ", attribute && !c.attributes ? "-" : cell(c.score), " |");
    }
    md += "\n";
  };
  using Score = lane::eval::DriveScore;
  row(
      "frames", [](const Score& s) { return absl::StrCat(s.frames); }, false);
  row(
      "recall", [](const Score& s) { return absl::StrFormat("%.3f", s.Recall()); }, false);
  row(
      "false positives per frame",
      [](const Score& s) { return absl::StrFormat("%.3f", s.FalsePositivesPerFrame()); }, false);
  row(
      "lanes on asphalt edges", [](const Score& s) { return absl::StrCat(s.on_road_edges); },
      false);
  row("colour right", [](const Score& s) {
    return absl::StrFormat("%.3f (%d/%d)", s.ColourAccuracy(), s.colour_right, s.colour_scored);
  });
  row("type right (solid/dashed)", [](const Score& s) {
    return absl::StrFormat("%.3f (%d/%d)", s.TypeAccuracy(), s.type_right, s.type_scored);
  });
  row("id switches per 100 boundary-frames",
      [](const Score& s) { return absl::StrFormat("%.2f", s.IdSwitchesPer100BoundaryFrames()); });
  row("ego frames bounded by the true lanes",
      [](const Score& s) { return absl::StrFormat("%d/%d", s.ego_matched, s.ego_frames); });
  row("ego offset RMS, m", [](const Score& s) { return absl::StrFormat("%.3f", s.offset_rms_m); });
  row("ego heading RMS, deg",
      [](const Score& s) { return absl::StrFormat("%.3f", s.heading_rms_deg); });
  row("ego width RMS, m", [](const Score& s) { return absl::StrFormat("%.3f", s.width_rms_m); });
  row("departure warned before each lane change", [](const Score& s) { return Leads(s); });
  row("departing frames away from lane changes",
      [](const Score& s) { return absl::StrCat(s.false_departure_frames); });
  for (const Column& c : columns) {
    if (c.attributes) {
      absl::StrAppend(&md, "\n## ", c.name, "\n\n```\n", c.score.Summary(), "```\n");
    }
  }
  return md;
}

// Runs the config's detector over the frames in order: alone (untracked)
// and with a tracker fed as `lane detect --track` feeds it (the prior of
// the predicted lanes, colour and type read from the frame), the frame's
// time from its labels.
absl::Status RunDetector(const DriveEvalArgs& args, const lane::eval::DriveLabels& labels,
                         std::vector<lane::eval::DriveOutput>* untracked,
                         std::vector<lane::eval::DriveOutput>* tracked, std::string* source) {
  absl::StatusOr<lane::Config> config = io::LoadEffectiveConfig(args.config, args.mode);
  if (!config.ok()) return config.status();
  if (args.seed) config->detector.seed = *args.seed;
  absl::StatusOr<lane::Detector> detector =
      lane::Detector::Create(config->camera, config->ipm, config->detector);
  if (!detector.ok()) return detector.status();
  *source = absl::StrCat("detector, config ", *args.config, ", seed ", config->detector.seed);
  lane::eval::DriveRunner runner(*detector);
  for (size_t i = 0; i < labels.frames.size(); ++i) {
    const std::string path = (fs::path(args.dataset) / labels.frames[i]).string();
    const cv::Mat frame = cv::imread(path, cv::IMREAD_COLOR);
    if (frame.empty()) return absl::NotFoundError(absl::StrCat("cannot read the frame ", path));
    if (absl::Status s = runner.Add(frame, labels.truth[i].time_s); !s.ok()) return s;
  }
  *untracked = runner.untracked();
  *tracked = runner.tracked();
  return absl::OkStatus();
}

// The results' records in the labels' frame order, matched by file name.
absl::StatusOr<std::vector<lane::eval::DriveOutput>> InLabelOrder(
    const lane::eval::DriveLabels& labels, const lane::eval::DriveResults& results) {
  std::map<std::string, size_t> by_name;
  for (size_t k = 0; k < results.frames.size(); ++k) {
    by_name[fs::path(results.frames[k]).filename().string()] = k;
  }
  std::vector<lane::eval::DriveOutput> out;
  int missing = 0;
  for (const std::string& name : labels.frames) {
    const auto it = by_name.find(fs::path(name).filename().string());
    if (it == by_name.end()) {
      ++missing;
      continue;
    }
    out.push_back(results.outputs[it->second]);
  }
  if (missing > 0) {
    return absl::InvalidArgumentError(absl::StrCat("the results have no record for ", missing,
                                                   " of the drive's ", labels.frames.size(),
                                                   " frames (a drive is scored whole, in order)"));
  }
  return out;
}

}  // namespace

int RunDriveEval(const DriveEvalArgs& args) {
  const std::string labels_path = (fs::path(args.dataset) / "labels.jsonl").string();
  if (!fs::is_regular_file(labels_path)) {
    return Failure("eval", absl::StrCat("--drive: no ", labels_path,
                                        " (make a drive with lane render --sequence)"));
  }
  absl::StatusOr<lane::eval::DriveLabels> labels = lane::eval::ReadDriveLabels(labels_path);
  if (!labels.ok()) return Failure("eval", std::string(labels.status().message()));
  lane::eval::DriveScoreOptions options;
  options.rule = args.rule;
  std::vector<Column> columns;
  std::string source;
  if (args.results) {
    absl::StatusOr<lane::eval::DriveResults> results = lane::eval::ReadDriveResults(*args.results);
    if (!results.ok()) return Failure("eval", std::string(results.status().message()));
    absl::StatusOr<std::vector<lane::eval::DriveOutput>> outputs = InLabelOrder(*labels, *results);
    if (!outputs.ok()) return Failure("eval", std::string(outputs.status().message()));
    // A tracker's output as a user reads it: its confirmed lanes.
    options.confirmed_only = results->tracked;
    columns.push_back({results->tracked ? "results (confirmed lanes)" : "results",
                       lane::eval::ScoreDrive(labels->truth, *outputs, options), results->tracked});
    source = absl::StrCat("results ", *args.results);
  } else {
    std::vector<lane::eval::DriveOutput> untracked, tracked;
    if (const absl::Status s = RunDetector(args, *labels, &untracked, &tracked, &source); !s.ok()) {
      return Failure("eval", std::string(s.message()));
    }
    columns.push_back({"untracked", lane::eval::ScoreDrive(labels->truth, untracked, options)});
    options.confirmed_only = true;
    columns.push_back(
        {"tracked (confirmed lanes)", lane::eval::ScoreDrive(labels->truth, tracked, options)});
  }
  const std::string md = Report(source, columns);
  std::fputs(md.c_str(), stdout);
  std::fflush(stdout);
  const lane::eval::DriveScore& last = columns.back().score;
  std::fprintf(stderr,
               "lane eval: drive of %d frames, %s: recall %.3f, %.3f false positives per frame, "
               "%.2f id switches per 100 boundary-frames, ego heading RMS %.3f deg\n",
               last.frames, columns.back().name.c_str(), last.Recall(),
               last.FalsePositivesPerFrame(), last.IdSwitchesPer100BoundaryFrames(),
               last.heading_rms_deg);
  return io::kExitOk;
}

}  // namespace lane::cli
