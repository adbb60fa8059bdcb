// Data set folders (format detection, clips, frame names) and the
// evaluation runs: detector on synthetic frames, and results files scored
// by frame number and by name.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <utility>
#include <vector>

#include "lane/detector/detector.h"
#include "lane/eval/dataset.h"
#include "lane/eval/evaluate.h"
#include "lane/eval/render_labels.h"
#include "lane/eval/report.h"
#include "lane/eval/results_txt.h"
#include "lane/synthetic.h"

namespace lane::eval {
namespace {

namespace fs = std::filesystem;

fs::path DatasetTempDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("lane_eval_dataset_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void WriteImage(const fs::path& path, int width, int height) {
  ASSERT_TRUE(cv::imwrite(path.string(), cv::Mat(height, width, CV_8UC3, cv::Scalar(90, 90, 90))));
}

TEST(DatasetTest, CulaneFolderTree) {
  // driver_161_90frame/06030819_0755.MP4/{00000,00090}.jpg + .lines.txt, and
  // a second clip with an image whose labels are missing.
  const fs::path root = DatasetTempDir("culane");
  const fs::path a = root / "driver_161_90frame" / "06030819_0755.MP4";
  const fs::path b = root / "driver_161_90frame" / "06030822_0756.MP4";
  fs::create_directories(a);
  fs::create_directories(b);
  for (const char* stem : {"00000", "00090"}) WriteImage(a / (std::string(stem) + ".jpg"), 64, 24);
  std::ofstream(a / "00000.lines.txt") << "10 23 20 13\n40 23 30 13\n";
  std::ofstream(a / "00090.lines.txt") << "";
  WriteImage(b / "00000.jpg", 64, 24);
  WriteImage(b / "00090.jpg", 64, 24);
  std::ofstream(b / "00090.lines.txt") << "1 23 2 13\n";
  std::ofstream(b / "00180.lines.txt") << "1 23 2 13\n";  // no image

  const auto dataset = LoadDataset(root.string());
  ASSERT_TRUE(dataset.ok()) << dataset.status();
  EXPECT_EQ(dataset->format, DatasetFormat::kCulane);
  ASSERT_EQ(dataset->clips.size(), 2u);
  EXPECT_EQ(dataset->clips[0].name, "driver_161_90frame/06030819_0755.MP4");
  const Clip& c = dataset->clips[0];
  ASSERT_EQ(c.frames.size(), 2u);
  EXPECT_EQ(c.frames[0].name, "driver_161_90frame/06030819_0755.MP4/00000.jpg");
  EXPECT_EQ(c.frames[0].boundaries.size(), 2u);
  EXPECT_TRUE(c.frames[1].labelled);  // an empty file: labelled, no lanes
  EXPECT_TRUE(c.frames[1].boundaries.empty());
  const Clip& d = dataset->clips[1];
  ASSERT_EQ(d.frames.size(), 2u);
  EXPECT_FALSE(d.frames[0].labelled);
  EXPECT_TRUE(d.frames[1].labelled);
  ASSERT_EQ(dataset->warnings.size(), 1u);
  EXPECT_NE(dataset->warnings[0].find("00180.lines.txt"), std::string::npos);
  EXPECT_EQ(dataset->FrameCount(), 4);
}

TEST(DatasetTest, LabelsCopiedFromFrameToFrameAreCountedAndWarned) {
  // 00000 and 00090 differ; 00180 and 00270 repeat 00090 to the last digit;
  // 00360 has no lanes (does not count, and does not break the run's
  // comparison: 00450 repeats 00270); 00540 moves by a hundredth of a pixel.
  const fs::path root = DatasetTempDir("culane_copies");
  const std::string moving = "10 23 20 13\n40 23 30 13\n";
  const std::string copied = "11 23 21 13\n41 23 31 13\n";
  const std::vector<std::pair<std::string, std::string>> frames = {
      {"00000", moving},
      {"00090", copied},
      {"00180", copied},
      {"00270", copied},
      {"00360", ""},
      {"00450", copied},
      {"00540", "11.01 23 21 13\n41 23 31 13\n"}};
  for (const auto& [stem, labels] : frames) {
    WriteImage(root / (stem + ".jpg"), 64, 24);
    std::ofstream(root / (stem + ".lines.txt")) << labels;
  }
  const auto dataset = LoadDataset(root.string());
  ASSERT_TRUE(dataset.ok()) << dataset.status();
  ASSERT_EQ(dataset->clips.size(), 1u);
  const RepeatedLabels repeated = FindRepeatedLabels(dataset->clips[0]);
  EXPECT_EQ(repeated.indices, (std::vector<size_t>{2, 3, 5}));  // 00180, 00270, 00450
  EXPECT_EQ(repeated.labelled, 6);                              // all but the empty 00360
  ASSERT_EQ(dataset->warnings.size(), 1u);
  EXPECT_NE(dataset->warnings[0].find("3 of 6 labelled frames repeat"), std::string::npos)
      << dataset->warnings[0];
  EXPECT_NE(dataset->warnings[0].find("00180.jpg"), std::string::npos);

  // A clip whose labels all differ gets no warning.
  const fs::path moving_root = DatasetTempDir("culane_moving");
  for (int i = 0; i < 3; ++i) {
    const std::string stem = "0000" + std::to_string(i);
    WriteImage(moving_root / (stem + ".jpg"), 64, 24);
    std::ofstream(moving_root / (stem + ".lines.txt")) << (10 + i) << " 23 20 13\n";
  }
  const auto clean = LoadDataset(moving_root.string());
  ASSERT_TRUE(clean.ok()) << clean.status();
  EXPECT_TRUE(FindRepeatedLabels(clean->clips[0]).indices.empty());
  EXPECT_TRUE(clean->warnings.empty());
}

TEST(DatasetTest, MalformedCulaneLabelNamesTheFile) {
  const fs::path root = DatasetTempDir("culane_bad");
  WriteImage(root / "00000.jpg", 64, 24);
  std::ofstream(root / "00000.lines.txt") << "10 23 20 13\n40 23 30\n";
  const auto dataset = LoadDataset(root.string());
  ASSERT_FALSE(dataset.ok());
  EXPECT_NE(std::string(dataset.status().message()).find("00000.lines.txt:2:"), std::string::npos)
      << dataset.status();
}

TEST(DatasetTest, TusimpleLabelFiles) {
  const fs::path root = DatasetTempDir("tusimple");
  std::ofstream(root / "label_data_0313.json")
      << R"({"lanes": [[-2, 600, 610]], "h_samples": [240, 250, 260], )"
      << R"("raw_file": "clips/0313-1/6040/20.jpg"})"
      << "\n";
  std::ofstream(root / "notes.json") << R"({"something": "else"})"
                                     << "\n";
  const auto dataset = LoadDataset(root.string());
  ASSERT_TRUE(dataset.ok()) << dataset.status();
  EXPECT_EQ(dataset->format, DatasetFormat::kTusimple);
  ASSERT_EQ(dataset->clips.size(), 1u);
  EXPECT_EQ(dataset->clips[0].name, "label_data_0313");
  ASSERT_EQ(dataset->clips[0].frames.size(), 1u);
  EXPECT_EQ(dataset->clips[0].frames[0].name, "clips/0313-1/6040/20.jpg");
  EXPECT_EQ(fs::path(dataset->clips[0].frames[0].image_path),
            root / "clips" / "0313-1" / "6040" / "20.jpg");
}

TEST(DatasetTest, UnknownFolder) {
  const fs::path root = DatasetTempDir("unknown");
  std::ofstream(root / "readme.txt") << "hello\n";
  const auto format = DetectDatasetFormat(root.string());
  ASSERT_FALSE(format.ok());
  EXPECT_NE(std::string(format.status().message()).find("cannot tell the format"),
            std::string::npos);
  EXPECT_EQ(DetectDatasetFormat((root / "missing").string()).status().code(),
            absl::StatusCode::kNotFound);
  EXPECT_EQ(ParseDatasetFormat("culane"), DatasetFormat::kCulane);
  EXPECT_FALSE(ParseDatasetFormat("kitti").has_value());
}

// Synthetic frames as `lane render` writes them: PNGs, list.txt, labels.jsonl.
fs::path RenderClip(const std::string& name, int frames) {
  const fs::path dir = DatasetTempDir(name);
  std::ofstream labels(dir / "labels.jsonl");
  std::ofstream list(dir / "list.txt");
  const CameraModel camera;
  SyntheticOptions options;
  options.num_lanes = 2;
  for (int i = 0; i < frames; ++i) {
    const auto frame = RenderSyntheticFrame(camera, options, 100 + i);
    EXPECT_TRUE(frame.ok()) << frame.status();
    if (!frame.ok()) continue;
    char file[32];
    std::snprintf(file, sizeof(file), "%06d.png", i);
    EXPECT_TRUE(cv::imwrite((dir / file).string(), frame->bgr));
    labels << RenderLabelsJson(file, *frame) << "\n";
    list << file << "\n";
  }
  return dir;
}

TEST(EvaluateTest, DetectorOnRenderedFramesThenTheSameAsResults) {
  const fs::path dir = RenderClip("render", 4);
  const auto dataset = LoadDataset(dir.string());
  ASSERT_TRUE(dataset.ok()) << dataset.status();
  EXPECT_EQ(dataset->format, DatasetFormat::kRender);
  ASSERT_EQ(dataset->FrameCount(), 4);
  EXPECT_EQ(dataset->clips[0].frames[0].width, 640);

  const auto detector = Detector::Create(CameraModel(), IpmOptions(), DetectorOptions());
  ASSERT_TRUE(detector.ok()) << detector.status();
  EvalOptions options;
  options.ego_row = detector->ipm().roi().bottom;
  std::string txt;
  int callbacks = 0;
  const auto report = EvaluateDetector(*dataset, *detector, options, [&](const FrameOutcome& o) {
    EXPECT_EQ(o.index, callbacks++);
    EXPECT_EQ(o.total, 4);
    EXPECT_TRUE(o.error.empty()) << o.error;
    EXPECT_NE(o.detection, nullptr);
    EXPECT_FALSE(o.image.empty());
    ASSERT_TRUE(o.score.has_value());
    txt += ResultsTxtFrame(o.index, o.lanes);
  });
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_EQ(callbacks, 4);
  const ClipCounts& t = report->total;
  EXPECT_EQ(t.frames, 4);
  EXPECT_EQ(t.failed_frames, 0);
  int boundaries = 0;
  for (const auto& f : dataset->clips[0].frames) boundaries += f.boundaries.size();
  EXPECT_EQ(t.paper.labels, boundaries);
  EXPECT_EQ(t.culane.labels, boundaries);
  EXPECT_EQ(t.paper.detections, t.culane.detections);
  // Two-lane roads seen from the lane's centre: the detector finds most.
  EXPECT_GT(t.paper.Recall(), 0.5);

  // The same detections through the original results format score the same.
  const auto records = ParseResultsTxt(txt, "results.txt");
  ASSERT_TRUE(records.ok()) << records.status();
  const auto rescored = EvaluateResults(*dataset, *records, options);
  ASSERT_TRUE(rescored.ok()) << rescored.status();
  EXPECT_EQ(rescored->total.paper.correct, t.paper.correct);
  EXPECT_EQ(rescored->total.paper.false_positives, t.paper.false_positives);
  EXPECT_EQ(rescored->total.culane.true_positives, t.culane.true_positives);
  EXPECT_EQ(rescored->total.missing_results, 0);

  // The tables name the clip and hold a Total row.
  const std::string md = ReportMarkdown(*report);
  EXPECT_NE(md.find("| Total | 4 |"), std::string::npos) << md;
  EXPECT_NE(md.find("correct rate"), std::string::npos);
  EXPECT_NE(ReportJson(*report).find("\"culane\""), std::string::npos);
}

TEST(EvaluateTest, ResultsMatchedByNameIndexAndSize) {
  const fs::path dir = RenderClip("by_name", 2);
  const auto dataset = LoadDataset(dir.string());
  ASSERT_TRUE(dataset.ok()) << dataset.status();
  const LabelledFrame& f0 = dataset->clips[0].frames[0];
  // A perfect detection of every boundary of frame 0, named as lane detect
  // names a frame given through a list or a directory; frame 1 has no
  // record.
  FrameResult r;
  r.frame = "./000000.png";
  for (const auto& b : f0.boundaries) r.lanes.push_back({b.curve, 1.0});
  const auto report = EvaluateResults(*dataset, {r}, EvalOptions());
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_EQ(report->total.paper.correct, static_cast<int>(f0.boundaries.size()));
  EXPECT_EQ(report->total.paper.false_positives, 0);
  EXPECT_EQ(report->total.culane.true_positives, static_cast<int>(f0.boundaries.size()));
  EXPECT_EQ(report->total.missing_results, 1);
  ASSERT_FALSE(report->warnings.empty());

  FrameResult stranger;
  stranger.frame = "elsewhere.png";
  const auto none = EvaluateResults(*dataset, {stranger}, EvalOptions());
  ASSERT_FALSE(none.ok());
  EXPECT_NE(std::string(none.status().message()).find("no results record names a frame"),
            std::string::npos);

  FrameResult beyond;
  beyond.index = 2;
  beyond.frame = "#2";
  EXPECT_FALSE(EvaluateResults(*dataset, {beyond}, EvalOptions()).ok());
}

TEST(EvaluateTest, AmbiguousNamesAcrossClips) {
  const fs::path root = DatasetTempDir("ambiguous");
  for (const char* clip : {"a", "b"}) {
    fs::create_directories(root / clip);
    WriteImage(root / clip / "00000.jpg", 64, 24);
    std::ofstream(root / clip / "00000.lines.txt") << "10 23 20 13\n";
  }
  const auto dataset = LoadDataset(root.string());
  ASSERT_TRUE(dataset.ok()) << dataset.status();
  FrameResult r;
  r.frame = "00000.jpg";
  const auto report = EvaluateResults(*dataset, {r}, EvalOptions());
  ASSERT_FALSE(report.ok());
  EXPECT_NE(std::string(report.status().message()).find("could be a/00000.jpg or b/00000.jpg"),
            std::string::npos)
      << report.status();
  // Frame sizes come from the images when nothing else gives them.
  r.frame = "b/00000.jpg";
  int width = 0;
  const auto ok = EvaluateResults(*dataset, {r}, EvalOptions(),
                                  [&](const FrameOutcome& o) { width = o.width; });
  ASSERT_TRUE(ok.ok()) << ok.status();
  EXPECT_EQ(width, 64);
  EXPECT_EQ(ok->clips.size(), 2u);
  EXPECT_EQ(ok->total.missing_results, 1);
}

}  // namespace
}  // namespace lane::eval
