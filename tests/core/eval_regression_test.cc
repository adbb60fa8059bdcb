// Accuracy regression on real frames: when ../shared/data/culane-driver161-a
// is present, evaluate the detector on it as `lane eval` does (all-lanes
// mode, configs/culane-driver161.json) and fail when the CULane F1 drops
// more than 0.02 below tests/testdata/culane-driver161-a.baseline.json.
// docs/evaluation.md says how to update the baseline.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "lane/config.h"
#include "lane/detector.h"
#include "lane/eval/dataset.h"
#include "lane/eval/evaluate.h"
#include "lane/eval/report.h"

namespace lane::eval {
namespace {

namespace fs = std::filesystem;

constexpr char kClip[] = "culane-driver161-a";
constexpr double kTolerance = 0.02;

// ../shared/data beside the source tree, else $LANE_DATA_DIR; "" if neither
// holds the clip.
std::string FindClip() {
  std::vector<fs::path> roots = {fs::path(LANE_SOURCE_DIR) / ".." / "shared" / "data"};
  if (const char* env = std::getenv("LANE_DATA_DIR"); env != nullptr && *env != '\0') {
    roots.emplace_back(env);
  }
  for (const fs::path& root : roots) {
    std::error_code ec;
    if (fs::is_directory(root / kClip, ec)) return (root / kClip).lexically_normal().string();
  }
  return "";
}

TEST(EvalRegressionTest, CulaneDriver161AllLanesF1) {
  const std::string clip = FindClip();
  if (clip.empty()) {
    GTEST_SKIP() << kClip << " not found in " << LANE_SOURCE_DIR
                 << "/../shared/data or $LANE_DATA_DIR: skipping the accuracy regression";
  }
  const std::string config_path = std::string(LANE_SOURCE_DIR) + "/configs/culane-driver161.json";
  const absl::StatusOr<Config> config = LoadConfigFile(config_path);
  ASSERT_TRUE(config.ok()) << config.status();
  ASSERT_EQ(config->detector.mode, Mode::kAll) << config_path << " should be an all-lanes config";
  const absl::StatusOr<Detector> detector =
      Detector::Create(config->camera, config->ipm, config->detector);
  ASSERT_TRUE(detector.ok()) << detector.status();
  const absl::StatusOr<Dataset> dataset = LoadDataset(clip);
  ASSERT_TRUE(dataset.ok()) << dataset.status();
  ASSERT_EQ(dataset->format, DatasetFormat::kCulane);

  EvalOptions options;
  options.mode = Mode::kAll;
  options.ego_row = detector->ipm().roi().bottom;
  absl::StatusOr<EvalReport> report = EvaluateDetector(*dataset, *detector, options);
  ASSERT_TRUE(report.ok()) << report.status();
  report->source = "detector, config configs/culane-driver161.json";
  const ClipCounts& t = report->total;
  EXPECT_EQ(t.failed_frames, 0);

  const std::string baseline_path =
      std::string(LANE_SOURCE_DIR) + "/tests/testdata/culane-driver161-a.baseline.json";
  const absl::StatusOr<Baseline> baseline = ReadBaseline(baseline_path);
  ASSERT_TRUE(baseline.ok()) << baseline.status();
  EXPECT_EQ(baseline->mode, "all");
  EXPECT_EQ(baseline->frames, t.frames) << "the clip changed since the baseline was recorded";

  const double f1 = t.culane.F1();
  std::printf("%s: CULane F1 %.4f (P %.4f R %.4f), baseline %.4f; paper rule F1 %.4f\n", kClip, f1,
              t.culane.Precision(), t.culane.Recall(), baseline->culane_f1, t.paper.F1());
  RecordProperty("culane_f1", std::to_string(f1));
  RecordProperty("baseline_culane_f1", std::to_string(baseline->culane_f1));
  EXPECT_GE(f1, baseline->culane_f1 - kTolerance)
      << "all-lanes CULane F1 on " << kClip << " dropped from " << baseline->culane_f1 << " to "
      << f1 << ".\n"
      << ReportMarkdown(*report)
      << "\nIf the drop is intended, update the baseline (docs/evaluation.md).";
  if (f1 > baseline->culane_f1 + kTolerance) {
    std::printf("CULane F1 improved by more than %.2f: consider updating %s (docs/evaluation.md)\n",
                kTolerance, baseline_path.c_str());
  }
}

}  // namespace
}  // namespace lane::eval
