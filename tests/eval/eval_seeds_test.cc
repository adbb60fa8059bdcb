// Figures over several seeds (lane eval --seeds) and the paper's own rows.
#include <gtest/gtest.h>

#include <cmath>

#include "lane/eval/paper_results.h"
#include "lane/eval/report.h"
#include "lane/eval/seeds.h"

namespace lane::eval {
namespace {

TEST(SpreadTest, MeanSampleStdAndRange) {
  const Spread s = Spread::Of({1.0, 2.0, 3.0, 6.0});
  EXPECT_EQ(s.n, 4);
  EXPECT_DOUBLE_EQ(s.mean, 3.0);
  // Sample variance: (4 + 1 + 0 + 9) / 3.
  EXPECT_NEAR(s.std, std::sqrt(14.0 / 3.0), 1e-12);
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 6.0);
}

TEST(SpreadTest, UndefinedValuesAreSkipped) {
  const Spread one = Spread::Of({std::nan(""), 0.5});
  EXPECT_EQ(one.n, 1);
  EXPECT_DOUBLE_EQ(one.mean, 0.5);
  EXPECT_DOUBLE_EQ(one.std, 0.0);
  const Spread none = Spread::Of({std::nan("")});
  EXPECT_EQ(none.n, 0);
  EXPECT_TRUE(std::isnan(none.mean));
}

EvalReport ReportWith(int correct, int fp, int culane_tp) {
  EvalReport r;
  r.dataset = "data/cordova1";
  r.format = DatasetFormat::kCaltech;
  ClipCounts c;
  c.clip = "cordova1";
  c.frames = 10;
  c.paper.labels = 40;
  c.paper.correct = correct;
  c.paper.true_positives = correct;
  c.paper.false_positives = fp;
  c.paper.detections = correct + fp;
  c.culane.labels = 40;
  c.culane.detections = correct + fp;
  c.culane.true_positives = culane_tp;
  r.clips = {c};
  r.total = c;
  r.total.clip = "Total";
  return r;
}

TEST(SeedSummaryTest, SummarisesEachClipAndTheTotal) {
  const SeedSummary s = SummariseSeeds({ReportWith(30, 2, 20), ReportWith(34, 6, 24)}, {7, 8});
  ASSERT_EQ(s.clips.size(), 1u);
  EXPECT_EQ(s.clips[0].clip, "cordova1");
  EXPECT_EQ(s.total.clip, "Total");
  EXPECT_DOUBLE_EQ(s.total.correct_rate.mean, 0.8);  // (0.75 + 0.85) / 2
  EXPECT_DOUBLE_EQ(s.total.correct_rate.min, 0.75);
  EXPECT_DOUBLE_EQ(s.total.correct_rate.max, 0.85);
  EXPECT_DOUBLE_EQ(s.total.false_positive_rate.mean, 0.1);
  EXPECT_DOUBLE_EQ(s.total.fp_per_frame.max, 0.6);
  EXPECT_DOUBLE_EQ(s.total.detected.mean, 36);
  EXPECT_DOUBLE_EQ(s.total.culane_recall.mean, 0.55);

  const std::string md = ReportMarkdown(ReportWith(30, 2, 20), &s);
  EXPECT_NE(md.find("## Over 2 RANSAC seeds (7, 8)"), std::string::npos) << md;
  EXPECT_NE(md.find("80.00 ± 7.07 [75.00, 85.00]"), std::string::npos) << md;
  const std::string json = ReportJson(ReportWith(30, 2, 20), &s);
  EXPECT_NE(json.find("\"seeds\""), std::string::npos);
  const std::string baseline = BaselineJson(ReportWith(30, 2, 20), "cmd", &s);
  EXPECT_NE(baseline.find("\"culane_f1_min\""), std::string::npos) << baseline;
}

TEST(PaperResultsTest, TableThreeAndTwoRowsByClipName) {
  const auto all = PaperResultForClip("caltech-cordova1", Mode::kAll);
  ASSERT_TRUE(all.has_value());
  EXPECT_EQ(all->clip, "cordova1");
  EXPECT_EQ(all->total, 919);
  EXPECT_DOUBLE_EQ(all->correct_rate, 0.9162);
  EXPECT_DOUBLE_EQ(all->false_positive_rate, 0.0566);
  EXPECT_DOUBLE_EQ(all->fp_per_frame, 0.208);
  const auto two = PaperResultForClip("cordova1", Mode::kTwo);
  ASSERT_TRUE(two.has_value());
  EXPECT_EQ(two->total, 466);
  EXPECT_DOUBLE_EQ(two->correct_rate, 0.9721);
  const auto w2 = PaperResultForClip("caltech/washington2", Mode::kAll);
  ASSERT_TRUE(w2.has_value());
  EXPECT_DOUBLE_EQ(w2->correct_rate, 0.9366);
  EXPECT_FALSE(PaperResultForClip("culane-driver161-a", Mode::kAll).has_value());
  EXPECT_FALSE(PaperResultForClip("xcordova1", Mode::kAll).has_value());
  // Precision from the printed rates: 842 correct, 52 false positives.
  EXPECT_NEAR(all->Precision(), 0.9162 / (0.9162 + 0.0566), 1e-12);
}

TEST(PaperResultsTest, PrintedUnderACaltechClipOnly) {
  EvalReport caltech = ReportWith(30, 2, 20);
  const std::string md = ReportMarkdown(caltech);
  EXPECT_NE(md.find("*Aly 2008, Table III, cordova1* | 250 | 919 | 842 | 91.62% | 5.66% | 0.208"),
            std::string::npos)
      << md;
  EvalReport culane = caltech;
  culane.format = DatasetFormat::kCulane;
  EXPECT_EQ(ReportMarkdown(culane).find("Aly 2008, Table III"), std::string::npos);
  caltech.options.mode = Mode::kTwo;
  EXPECT_NE(ReportMarkdown(caltech).find("*Aly 2008, Table II, cordova1* | 250 | 466 | 467"),
            std::string::npos);
}

}  // namespace
}  // namespace lane::eval
