#include "lane/eval/report.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "lane/eval/paper_results.h"
#include "lane/eval/text_file.h"

namespace lane::eval {
namespace {

using OrderedJson = nlohmann::ordered_json;

std::string Fixed(double v, int decimals) {
  if (std::isnan(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

std::string Percent(double v) { return std::isnan(v) ? "n/a" : Fixed(100 * v, 2) + "%"; }

OrderedJson Number(double v, double scale = 1e4) {
  if (std::isnan(v)) return nullptr;
  return std::round(v * scale) / scale;
}

std::string DatasetName(const std::string& root) {
  std::filesystem::path p = std::filesystem::absolute(root).lexically_normal();
  if (p.filename().empty()) p = p.parent_path();
  return p.filename().string();
}

std::string PaperRow(const ClipCounts& c) {
  const PaperCounts& p = c.paper;
  return absl::StrCat("| ", c.clip, " | ", c.frames, " | ", p.labels, " | ", p.detections, " | ",
                      Percent(p.CorrectRate()), " | ", Percent(p.FalsePositiveRate()), " | ",
                      Fixed(p.FalsePositivesPerFrame(c.frames), 3), " | ", Fixed(p.Precision(), 3),
                      " | ", Fixed(p.Recall(), 3), " | ", Fixed(p.F1(), 3), " |\n");
}

std::string CulaneRow(const ClipCounts& c) {
  const CulaneCounts& k = c.culane;
  return absl::StrCat("| ", c.clip, " | ", c.frames, " | ", k.labels, " | ", k.detections, " | ",
                      k.true_positives, " | ", k.FalsePositives(), " | ", k.FalseNegatives(), " | ",
                      Fixed(k.Precision(), 3), " | ", Fixed(k.Recall(), 3), " | ", Fixed(k.F1(), 3),
                      " |\n");
}

// The paper's own row for a Caltech clip, in the layout of PaperRow.
std::string PaperOwnRow(const EvalReport& report, const ClipCounts& c) {
  if (report.format != DatasetFormat::kCaltech) return "";
  const std::optional<PaperResult> r = PaperResultForClip(c.clip, report.options.mode);
  if (!r) return "";
  return absl::StrCat("| *Aly 2008, Table ", report.options.mode == Mode::kTwo ? "II" : "III", ", ",
                      r->clip, "* | ", r->frames, " | ", r->total, " | ", r->detected, " | ",
                      Percent(r->correct_rate), " | ", Percent(r->false_positive_rate), " | ",
                      Fixed(r->fp_per_frame, 3), " | ", Fixed(r->Precision(), 3), " | ",
                      Fixed(r->correct_rate, 3), " | ", Fixed(r->F1(), 3), " |\n");
}

// "88.79 ± 0.21 [88.50, 89.10]" (scale 100 for percentages).
std::string SpreadText(const Spread& s, int decimals, double scale = 1) {
  if (s.n == 0) return "n/a";
  return absl::StrCat(Fixed(scale * s.mean, decimals), " ± ", Fixed(scale * s.std, decimals), " [",
                      Fixed(scale * s.min, decimals), ", ", Fixed(scale * s.max, decimals), "]");
}

std::string SpreadRow(const ClipSpread& c) {
  return absl::StrCat(
      "| ", c.clip, " | ", SpreadText(c.detected, 1), " | ", SpreadText(c.correct_rate, 2, 100),
      " | ", SpreadText(c.false_positive_rate, 2, 100), " | ", SpreadText(c.fp_per_frame, 3), " | ",
      SpreadText(c.paper_f1, 3), " | ", SpreadText(c.culane_precision, 3), " | ",
      SpreadText(c.culane_recall, 3), " | ", SpreadText(c.culane_f1, 3), " |\n");
}

std::string PaperOwnSpreadRow(const EvalReport& report, const ClipSpread& c) {
  if (report.format != DatasetFormat::kCaltech) return "";
  const std::optional<PaperResult> r = PaperResultForClip(c.clip, report.options.mode);
  if (!r) return "";
  return absl::StrCat("| *Aly 2008, Table ", report.options.mode == Mode::kTwo ? "II" : "III", ", ",
                      r->clip, "* | ", r->detected, " | ", Fixed(100 * r->correct_rate, 2), " | ",
                      Fixed(100 * r->false_positive_rate, 2), " | ", Fixed(r->fp_per_frame, 3),
                      " | ", Fixed(r->F1(), 3), " | | | |\n");
}

OrderedJson SpreadJson(const Spread& s) {
  OrderedJson out = OrderedJson::object();
  out["mean"] = Number(s.mean);
  out["std"] = Number(s.std);
  out["min"] = Number(s.min);
  out["max"] = Number(s.max);
  return out;
}

OrderedJson ClipSpreadJson(const ClipSpread& c) {
  OrderedJson out = OrderedJson::object();
  out["clip"] = c.clip;
  out["detected"] = SpreadJson(c.detected);
  out["correct_rate"] = SpreadJson(c.correct_rate);
  out["false_positive_rate"] = SpreadJson(c.false_positive_rate);
  out["fp_per_frame"] = SpreadJson(c.fp_per_frame);
  out["paper_precision"] = SpreadJson(c.paper_precision);
  out["paper_f1"] = SpreadJson(c.paper_f1);
  out["culane_precision"] = SpreadJson(c.culane_precision);
  out["culane_recall"] = SpreadJson(c.culane_recall);
  out["culane_f1"] = SpreadJson(c.culane_f1);
  return out;
}

OrderedJson CountsJson(const ClipCounts& c) {
  OrderedJson out = OrderedJson::object();
  out["clip"] = c.clip;
  out["frames"] = c.frames;
  out["unlabelled_frames"] = c.unlabelled_frames;
  out["failed_frames"] = c.failed_frames;
  out["missing_results"] = c.missing_results;
  const PaperCounts& p = c.paper;
  OrderedJson paper = OrderedJson::object();
  paper["labels"] = p.labels;
  paper["detected"] = p.detections;
  paper["correct"] = p.correct;
  paper["true_positives"] = p.true_positives;
  paper["false_positives"] = p.false_positives;
  paper["correct_rate"] = Number(p.CorrectRate());
  paper["false_positive_rate"] = Number(p.FalsePositiveRate());
  paper["fp_per_frame"] = Number(p.FalsePositivesPerFrame(c.frames));
  paper["precision"] = Number(p.Precision());
  paper["recall"] = Number(p.Recall());
  paper["f1"] = Number(p.F1());
  out["paper"] = std::move(paper);
  const CulaneCounts& k = c.culane;
  OrderedJson culane = OrderedJson::object();
  culane["labels"] = k.labels;
  culane["detected"] = k.detections;
  culane["true_positives"] = k.true_positives;
  culane["false_positives"] = k.FalsePositives();
  culane["false_negatives"] = k.FalseNegatives();
  culane["precision"] = Number(k.Precision());
  culane["recall"] = Number(k.Recall());
  culane["f1"] = Number(k.F1());
  out["culane"] = std::move(culane);
  return out;
}

std::string EgoRowText(const EvalOptions& o) {
  return o.ego_row >= 0 ? absl::StrCat("row ", Fixed(o.ego_row, 0), ", the bottom of the ROI")
                        : std::string("the last image row");
}

}  // namespace

std::string ReportMarkdown(const EvalReport& report, const SeedSummary* seeds) {
  const EvalOptions& o = report.options;
  const PaperRuleOptions& pr = o.paper;
  const ClipCounts& t = report.total;
  std::string md =
      absl::StrCat("# Evaluation: ", DatasetName(report.dataset), " (",
                   DatasetFormatName(report.format), "), mode ", ModeName(o.mode), "\n\n");
  if (!report.source.empty()) absl::StrAppend(&md, "Scored: ", report.source, ".\n");
  absl::StrAppend(
      &md, "Frames: ", t.frames, " scored, ", t.unlabelled_frames, " unlabelled (not scored), ",
      t.failed_frames, " failed (scored as no detections)",
      t.missing_results > 0 ? absl::StrCat(", ", t.missing_results, " without a results record")
                            : std::string(),
      ".\n");
  if (o.mode == Mode::kTwo) {
    absl::StrAppend(&md,
                    "Labels scored: the ego lane's two boundaries only (the nearest labelled "
                    "boundary on each side of the image centre at ",
                    EgoRowText(o), ").\n");
  }
  if (seeds != nullptr && !seeds->seeds.empty()) {
    absl::StrAppend(
        &md, "\n## Over ", seeds->seeds.size(), " RANSAC seeds (",
        absl::StrJoin(seeds->seeds, ", "), "): mean ± standard deviation [min, max]\n\n",
        "Paper rule as below (rates in %); CULane metric as below. The tables after "
        "this one are those of seed ",
        seeds->seeds.front(), ".\n\n",
        "| Clip | #detected | correct rate % | false pos. rate % | fp/frame | paper F1 | "
        "CULane precision | CULane recall | CULane F1 |\n",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (size_t k = 0; k < seeds->clips.size(); ++k) {
      md += SpreadRow(seeds->clips[k]);
      if (k < report.clips.size()) md += PaperOwnSpreadRow(report, seeds->clips[k]);
    }
    md += SpreadRow(seeds->total);
  }
  absl::StrAppend(
      &md, "\n## Paper rule (Aly 2008, Tables II/III)\n\n",
      "A detection matches a label when d^ <= ", Fixed(pr.median_px, 0), " px ",
      pr.rule == PaperRuleOptions::Rule::kAnd ? "AND" : "OR", " d- <= ", Fixed(pr.mean_px, 0),
      " px at ", Fixed(pr.reference_width, 0), " px width (scaled by width / ",
      Fixed(pr.reference_width, 0), "); ",
      pr.assignment == PaperRuleOptions::Assignment::kOneToOne
          ? "one-to-one, best pairs first"
          : "many-to-one (any detection on a label is correct)",
      ". correct rate = correct / #total, false pos. rate = false positives / #total.\n\n",
      "| Clip | #frames | #total | #detected | correct rate | false pos. rate | fp/frame | "
      "precision | recall | F1 |\n",
      "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const ClipCounts& c : report.clips) md += PaperRow(c) + PaperOwnRow(report, c);
  md += PaperRow(t);
  absl::StrAppend(&md, "\n## CULane metric\n\n", "A detection matches a label when their ",
                  Fixed(o.culane.line_width_px, 0), " px wide drawings at ",
                  o.culane.reference_width,
                  " px width overlap with IoU >= ", Fixed(o.culane.iou_threshold, 2),
                  "; one-to-one (Hungarian).\n\n",
                  "| Clip | #frames | #labels | #detected | TP | FP | FN | precision | recall | "
                  "F1 |\n",
                  "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const ClipCounts& c : report.clips) md += CulaneRow(c);
  md += CulaneRow(t);
  if (!report.warnings.empty()) {
    md += "\n## Warnings\n\n";
    for (const std::string& w : report.warnings) absl::StrAppend(&md, "* ", w, "\n");
  }
  return md;
}

std::string ReportJson(const EvalReport& report, const SeedSummary* seeds) {
  const EvalOptions& o = report.options;
  OrderedJson out = OrderedJson::object();
  out["schema"] = 1;
  out["dataset"] = report.dataset;
  out["format"] = DatasetFormatName(report.format);
  out["mode"] = ModeName(o.mode);
  out["source"] = report.source;
  OrderedJson paper = OrderedJson::object();
  paper["median_px"] = o.paper.median_px;
  paper["mean_px"] = o.paper.mean_px;
  paper["reference_width"] = o.paper.reference_width;
  paper["rule"] = RuleName(o.paper.rule);
  paper["assignment"] = AssignmentName(o.paper.assignment);
  paper["samples"] = o.paper.samples;
  out["paper_rule"] = std::move(paper);
  OrderedJson culane = OrderedJson::object();
  culane["line_width_px"] = o.culane.line_width_px;
  culane["reference_width"] = o.culane.reference_width;
  culane["iou_threshold"] = o.culane.iou_threshold;
  out["culane_metric"] = std::move(culane);
  if (o.mode == Mode::kTwo) {
    out["ego_row"] = o.ego_row >= 0 ? OrderedJson(o.ego_row) : OrderedJson(nullptr);
  }
  OrderedJson clips = OrderedJson::array();
  for (const ClipCounts& c : report.clips) clips.push_back(CountsJson(c));
  out["clips"] = std::move(clips);
  out["total"] = CountsJson(report.total);
  out["warnings"] = report.warnings;
  if (seeds != nullptr && !seeds->seeds.empty()) {
    OrderedJson s = OrderedJson::object();
    s["seeds"] = seeds->seeds;
    OrderedJson clips_spread = OrderedJson::array();
    for (const ClipSpread& c : seeds->clips) clips_spread.push_back(ClipSpreadJson(c));
    s["clips"] = std::move(clips_spread);
    s["total"] = ClipSpreadJson(seeds->total);
    out["seeds"] = std::move(s);
  }
  return out.dump(2, ' ', false, OrderedJson::error_handler_t::replace) + "\n";
}

std::string BaselineJson(const EvalReport& report, const std::string& command,
                         const SeedSummary* seeds) {
  const ClipCounts& t = report.total;
  const bool over_seeds = seeds != nullptr && !seeds->seeds.empty();
  OrderedJson out = OrderedJson::object();
  out["about"] =
      "Regression baseline of lane eval (tests/eval/eval_regression_test.cc fails when the "
      "CULane F1, the mean over `seeds`, drops more than 0.02 below culane_f1, or the paper "
      "rule's correct rate drops / false-positive rate rises by more than one point). "
      "Regenerate with `command`; see docs/evaluation.md.";
  out["dataset"] = DatasetName(report.dataset);
  out["mode"] = ModeName(report.options.mode);
  out["frames"] = t.frames;
  if (over_seeds) {
    const ClipSpread& m = seeds->total;
    out["seeds"] = seeds->seeds;
    out["culane_f1"] = Number(m.culane_f1.mean);
    out["culane_f1_min"] = Number(m.culane_f1.min);
    out["culane_f1_max"] = Number(m.culane_f1.max);
    out["culane_precision"] = Number(m.culane_precision.mean);
    out["culane_recall"] = Number(m.culane_recall.mean);
    out["paper_f1"] = Number(m.paper_f1.mean);
    out["paper_correct_rate"] = Number(m.correct_rate.mean);
    out["paper_false_positive_rate"] = Number(m.false_positive_rate.mean);
    out["paper_fp_per_frame"] = Number(m.fp_per_frame.mean);
  } else {
    out["culane_f1"] = Number(t.culane.F1());
    out["culane_precision"] = Number(t.culane.Precision());
    out["culane_recall"] = Number(t.culane.Recall());
    out["paper_f1"] = Number(t.paper.F1());
    out["paper_correct_rate"] = Number(t.paper.CorrectRate());
    out["paper_false_positive_rate"] = Number(t.paper.FalsePositiveRate());
    out["paper_fp_per_frame"] = Number(t.paper.FalsePositivesPerFrame(t.frames));
  }
  out["source"] = report.source;
  out["command"] = command;
  return out.dump(2, ' ', false, OrderedJson::error_handler_t::replace) + "\n";
}

absl::StatusOr<Baseline> ReadBaseline(const std::string& path) {
  absl::StatusOr<std::string> text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  const OrderedJson j = OrderedJson::parse(*text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": not a JSON object"));
  }
  Baseline b;
  if (!j.contains("culane_f1") || !j["culane_f1"].is_number()) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": \"culane_f1\" must be a number"));
  }
  b.culane_f1 = j["culane_f1"].get<double>();
  const auto number_or_nan = [&j](const char* key) {
    return j.contains(key) && j[key].is_number() ? j[key].get<double>() : std::nan("");
  };
  b.paper_correct_rate = number_or_nan("paper_correct_rate");
  b.paper_false_positive_rate = number_or_nan("paper_false_positive_rate");
  if (j.contains("dataset") && j["dataset"].is_string())
    b.dataset = j["dataset"].get<std::string>();
  if (j.contains("mode") && j["mode"].is_string()) b.mode = j["mode"].get<std::string>();
  if (j.contains("frames") && j["frames"].is_number_integer()) b.frames = j["frames"].get<int>();
  if (j.contains("seeds")) {
    if (!j["seeds"].is_array()) {
      return absl::InvalidArgumentError(absl::StrCat(path, ": \"seeds\" must be an array"));
    }
    for (const OrderedJson& s : j["seeds"]) {
      if (!s.is_number_unsigned()) {
        return absl::InvalidArgumentError(
            absl::StrCat(path, ": \"seeds\" must hold non-negative integers"));
      }
      b.seeds.push_back(s.get<uint64_t>());
    }
  }
  return b;
}

}  // namespace lane::eval
