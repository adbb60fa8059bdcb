// Accuracy regression on real frames: when ../shared/data holds the clips,
// evaluate the detector on them as `lane eval --seeds` does (all-lanes mode,
// the shipped config, the baseline's seeds) and fail when the mean CULane F1
// drops more than 0.02 below the baseline in tests/testdata, or the paper
// rule's mean correct rate drops (false-positive rate rises) by more than
// one point. docs/evaluation.md says how to update the baselines.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "lane/config/config.h"
#include "lane/detector/detector.h"
#include "lane/eval/dataset.h"
#include "lane/eval/evaluate.h"
#include "lane/eval/report.h"
#include "lane/eval/seeds.h"
#include "shared_data.h"

namespace lane::eval {
namespace {

constexpr double kF1Tolerance = 0.02;
constexpr double kRateTolerance = 0.01;

using lane::testing::FindSharedClip;

// Evaluates `config` (configs/...) on `clip` over the baseline's seeds and
// checks the means against tests/testdata/<clip>.baseline.json.
void CheckAgainstBaseline(const std::string& clip, const std::string& config_name,
                          DatasetFormat format) {
  const std::string folder = FindSharedClip(clip);
  if (folder.empty()) {
    GTEST_SKIP() << clip << " not found in " << LANE_SOURCE_DIR
                 << "/../shared/data or $LANE_DATA_DIR: skipping the accuracy regression on it";
  }
  const std::string baseline_path =
      std::string(LANE_SOURCE_DIR) + "/tests/testdata/" + clip + ".baseline.json";
  const absl::StatusOr<Baseline> baseline = ReadBaseline(baseline_path);
  ASSERT_TRUE(baseline.ok()) << baseline.status();
  EXPECT_EQ(baseline->mode, "all");
  ASSERT_FALSE(baseline->seeds.empty()) << baseline_path << " should record its seeds";

  const std::string config_path = std::string(LANE_SOURCE_DIR) + "/configs/" + config_name;
  const absl::StatusOr<Config> config = LoadConfigFile(config_path);
  ASSERT_TRUE(config.ok()) << config.status();
  ASSERT_EQ(config->detector.mode, Mode::kAll) << config_path << " should be an all-lanes config";
  std::vector<Detector> detectors;
  for (uint64_t seed : baseline->seeds) {
    DetectorOptions o = config->detector;
    o.seed = seed;
    absl::StatusOr<Detector> d = Detector::Create(config->camera, config->ipm, o);
    ASSERT_TRUE(d.ok()) << d.status();
    detectors.push_back(std::move(*d));
  }
  std::vector<const Detector*> all;
  for (const Detector& d : detectors) all.push_back(&d);
  const absl::StatusOr<Dataset> dataset = LoadDataset(folder);
  ASSERT_TRUE(dataset.ok()) << dataset.status();
  ASSERT_EQ(dataset->format, format);

  EvalOptions options;
  options.mode = Mode::kAll;
  options.ego_row = detectors.front().ipm().roi().bottom;
  absl::StatusOr<std::vector<EvalReport>> reports = EvaluateDetectors(*dataset, all, options);
  ASSERT_TRUE(reports.ok()) << reports.status();
  for (EvalReport& r : *reports) {
    r.source = "detector, config configs/" + config_name;
    EXPECT_EQ(r.total.failed_frames, 0);
  }
  EXPECT_EQ(baseline->frames, reports->front().total.frames)
      << "the clip changed since the baseline was recorded";
  const SeedSummary summary = SummariseSeeds(*reports, baseline->seeds);
  const ClipSpread& m = summary.total;

  std::printf(
      "%s over %zu seeds: CULane F1 %.4f (baseline %.4f), correct %.2f%% (baseline %.2f%%), "
      "FP rate %.2f%% (baseline %.2f%%)\n",
      clip.c_str(), summary.seeds.size(), m.culane_f1.mean, baseline->culane_f1,
      100 * m.correct_rate.mean, 100 * baseline->paper_correct_rate,
      100 * m.false_positive_rate.mean, 100 * baseline->paper_false_positive_rate);
  ::testing::Test::RecordProperty("culane_f1", std::to_string(m.culane_f1.mean));
  ::testing::Test::RecordProperty("baseline_culane_f1", std::to_string(baseline->culane_f1));
  const std::string tables = ReportMarkdown(reports->front(), &summary);
  const std::string update = "\nIf the change is intended, update " + baseline_path +
                             " (docs/evaluation.md, \"Regression baseline\").";
  EXPECT_GE(m.culane_f1.mean, baseline->culane_f1 - kF1Tolerance)
      << "all-lanes CULane F1 on " << clip << " dropped from " << baseline->culane_f1 << " to "
      << m.culane_f1.mean << ".\n"
      << tables << update;
  if (std::isfinite(baseline->paper_correct_rate)) {
    EXPECT_GE(m.correct_rate.mean, baseline->paper_correct_rate - kRateTolerance)
        << "paper-rule correct rate on " << clip << " dropped.\n"
        << tables << update;
  }
  if (std::isfinite(baseline->paper_false_positive_rate)) {
    EXPECT_LE(m.false_positive_rate.mean, baseline->paper_false_positive_rate + kRateTolerance)
        << "paper-rule false-positive rate on " << clip << " rose.\n"
        << tables << update;
  }
  if (m.culane_f1.mean > baseline->culane_f1 + kF1Tolerance) {
    std::printf("CULane F1 improved by more than %.2f: consider updating %s\n", kF1Tolerance,
                baseline_path.c_str());
  }
}

TEST(EvalRegressionTest, CulaneDriver161AllLanes) {
  CheckAgainstBaseline("culane-driver161-a", "culane-driver161.json", DatasetFormat::kCulane);
}

TEST(EvalRegressionTest, CaltechCordova1AllLanes) {
  CheckAgainstBaseline("caltech-cordova1", "caltech.json", DatasetFormat::kCaltech);
}

}  // namespace
}  // namespace lane::eval
