// Label and results file parsers: CULane .lines.txt, TuSimple JSON lines,
// `lane render` labels, `lane detect` JSON Lines and the original tool's
// results file. Malformed input gives an error naming the file and line.
#include <gtest/gtest.h>

#include <string>

#include "lane/eval/caltech.h"
#include "lane/eval/culane.h"
#include "lane/eval/render_labels.h"
#include "lane/eval/results_jsonl.h"
#include "lane/eval/results_txt.h"
#include "lane/eval/tusimple.h"

namespace lane::eval {
namespace {

// The status is an error whose message contains `part`.
::testing::AssertionResult ErrorContains(const absl::Status& status, const std::string& part) {
  if (status.ok()) return ::testing::AssertionFailure() << "no error, expected \"" << part << "\"";
  const std::string message(status.message());
  if (message.find(part) == std::string::npos) {
    return ::testing::AssertionFailure() << "\"" << message << "\" lacks \"" << part << "\"";
  }
  return ::testing::AssertionSuccess();
}

TEST(CulaneReaderTest, ParsesLanes) {
  const auto lanes = ParseCulaneLines(
      "362.966 590 380.01 580 398.561 570 \n"
      "\n"
      "774.238 590 774.238 580\r\n",
      "00000.lines.txt");
  ASSERT_TRUE(lanes.ok()) << lanes.status();
  ASSERT_EQ(lanes->size(), 2u);
  EXPECT_EQ((*lanes)[0].kind, Curve::Kind::kPolyline);
  ASSERT_EQ((*lanes)[0].points.size(), 3u);
  EXPECT_TRUE((*lanes)[0].points[2].isApprox(Eigen::Vector2d(398.561, 570)));
  EXPECT_EQ((*lanes)[1].points.size(), 2u);
}

TEST(CulaneReaderTest, EmptyFileHasNoLanes) {
  const auto lanes = ParseCulaneLines("", "x.lines.txt");
  ASSERT_TRUE(lanes.ok());
  EXPECT_TRUE(lanes->empty());
}

TEST(CulaneReaderTest, MalformedLinesNameFileAndLine) {
  struct Case {
    const char* text;
    const char* message;
  } cases[] = {
      {"1 590 2 580\n3 590 4\n", "00090.lines.txt:2: 3 values"},
      {"1 590 2 580\n1 590 abc 580\n", "00090.lines.txt:2: \"abc\" is not a finite number"},
      {"\n\n12 590\n", "00090.lines.txt:3: a lane needs at least 2 points"},
      {"1 590 nan 580\n", "00090.lines.txt:1: \"nan\" is not a finite number"},
  };
  for (const Case& c : cases) {
    const auto lanes = ParseCulaneLines(c.text, "00090.lines.txt");
    ASSERT_FALSE(lanes.ok()) << c.text;
    EXPECT_EQ(lanes.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_TRUE(ErrorContains(lanes.status(), c.message));
  }
}

TEST(CulaneReaderTest, LabelName) {
  EXPECT_EQ(CulaneLabelName("00090.jpg"), "00090.lines.txt");
  EXPECT_EQ(CulaneLabelName("a.b/00090.jpg"), "a.b/00090.lines.txt");
  EXPECT_EQ(CulaneLabelName("a.b/00090"), "a.b/00090.lines.txt");
}

TEST(CulaneReaderTest, MissingFile) {
  const auto lanes = ReadCulaneLines("/nonexistent/00090.lines.txt");
  ASSERT_FALSE(lanes.ok());
  EXPECT_EQ(lanes.status().code(), absl::StatusCode::kNotFound);
  EXPECT_TRUE(ErrorContains(lanes.status(), "/nonexistent/00090.lines.txt"));
}

TEST(TusimpleReaderTest, ParsesFramesAndSkipsMissingPoints) {
  const auto frames = ParseTusimpleLabels(
      R"({"lanes": [[-2, 600, 610, -2], [-2, -2, 700, -2], [800, 790, 780, 770]], )"
      R"("h_samples": [240, 250, 260, 270], "raw_file": "clips/0313-1/6040/20.jpg"})"
      "\n\n"
      R"({"lanes": [], "h_samples": [], "raw_file": "clips/0313-1/6080/20.jpg"})"
      "\n",
      "label_data_0313.json");
  ASSERT_TRUE(frames.ok()) << frames.status();
  ASSERT_EQ(frames->size(), 2u);
  const TusimpleFrame& f = (*frames)[0];
  EXPECT_EQ(f.raw_file, "clips/0313-1/6040/20.jpg");
  // The second lane has a single point and is dropped.
  ASSERT_EQ(f.lanes.size(), 2u);
  ASSERT_EQ(f.lanes[0].points.size(), 2u);
  EXPECT_TRUE(f.lanes[0].points[0].isApprox(Eigen::Vector2d(600, 250)));
  EXPECT_TRUE(f.lanes[0].points[1].isApprox(Eigen::Vector2d(610, 260)));
  EXPECT_EQ(f.lanes[1].points.size(), 4u);
  EXPECT_TRUE((*frames)[1].lanes.empty());
}

TEST(TusimpleReaderTest, MalformedLinesNameFileAndLine) {
  struct Case {
    const char* text;
    const char* message;
  } cases[] = {
      {"{\"lanes\": [], \"h_samples\": [], \"raw_file\": \"a.jpg\"}\n{not json}\n",
       "t.json:2: not a JSON object"},
      {R"({"lanes": [[1, 2]], "h_samples": [240, 250, 260], "raw_file": "a.jpg"})",
       "t.json:1: lanes[0] has 2 values but h_samples has 3"},
      {R"({"lanes": [[1, 2]], "h_samples": [240, 250]})",
       "t.json:1: \"raw_file\" must be a non-empty string"},
      {R"({"lanes": [["a", 2]], "h_samples": [240, 250], "raw_file": "a.jpg"})",
       "t.json:1: lanes[0] must be an array of numbers"},
      {R"({"lanes": [[1, 2]], "h_samples": "240", "raw_file": "a.jpg"})",
       "t.json:1: \"h_samples\" must be an array of numbers"},
      {"\n\n[1, 2]\n", "t.json:3: not a JSON object"},
  };
  for (const Case& c : cases) {
    const auto frames = ParseTusimpleLabels(c.text, "t.json");
    ASSERT_FALSE(frames.ok()) << c.text;
    EXPECT_TRUE(ErrorContains(frames.status(), c.message));
  }
}

TEST(TusimpleReaderTest, Recognised) {
  EXPECT_TRUE(LooksLikeTusimple("\n{\"lanes\": [], \"h_samples\": [], \"raw_file\": \"a\"}\n"));
  EXPECT_FALSE(LooksLikeTusimple("{\"schema\": 1, \"frame\": \"a\"}"));
  EXPECT_FALSE(LooksLikeTusimple(""));
}

TEST(RenderLabelsReaderTest, ParsesBoundaries) {
  const auto frames = ParseRenderLabels(
      R"({"frame":"000000.png","width":640,"height":480,"boundaries":[)"
      R"({"points":[[130.5,479],[190.1,400.3],[250.7,320],[300.2,240.5]],"dashed":true,)"
      R"("color":"yellow","ego":"left"}]})",
      "labels.jsonl");
  ASSERT_TRUE(frames.ok()) << frames.status();
  ASSERT_EQ(frames->size(), 1u);
  const LabelledFrame& f = (*frames)[0];
  EXPECT_EQ(f.name, "000000.png");
  EXPECT_EQ(f.width, 640);
  EXPECT_EQ(f.height, 480);
  ASSERT_EQ(f.boundaries.size(), 1u);
  EXPECT_EQ(f.boundaries[0].curve.kind, Curve::Kind::kBezier);
  EXPECT_EQ(f.boundaries[0].type, "dashed yellow");
  const auto bad = ParseRenderLabels(
      "\n{\"frame\":\"a.png\",\"width\":640,\"height\":480,\"boundaries\":[{\"points\":[[1,2]]}]}",
      "labels.jsonl");
  ASSERT_FALSE(bad.ok());
  EXPECT_TRUE(ErrorContains(bad.status(), "labels.jsonl:2: boundaries[0].points"));
}

TEST(ResultsJsonlReaderTest, ParsesDetectionsAndErrors) {
  const auto results = ParseResultsJsonl(
      R"({"schema":1,"frame":"00090.jpg","width":1640,"height":590,"mode":"all",)"
      R"("lanes":[{"image":[[1,590],[2,550],[3,500],[4,450]],"ipm":[[0,0],[0,0],[0,0],[0,0]],)"
      R"("ground":[[0,0],[0,0],[0,0],[0,0]],"score":2.5}],"timing_ms":{"total":1.0}})"
      "\n"
      R"({"schema":1,"frame":"broken.jpg","mode":"two","error":"cannot decode image"})"
      "\n",
      "results.jsonl");
  ASSERT_TRUE(results.ok()) << results.status();
  ASSERT_EQ(results->size(), 2u);
  const FrameResult& r = (*results)[0];
  EXPECT_EQ(r.frame, "00090.jpg");
  EXPECT_EQ(r.width, 1640);
  EXPECT_EQ(r.height, 590);
  EXPECT_EQ(r.mode, "all");
  ASSERT_EQ(r.lanes.size(), 1u);
  EXPECT_EQ(r.lanes[0].curve.kind, Curve::Kind::kBezier);
  EXPECT_TRUE(r.lanes[0].curve.points[3].isApprox(Eigen::Vector2d(4, 450)));
  EXPECT_DOUBLE_EQ(r.lanes[0].score, 2.5);
  EXPECT_TRUE(r.error.empty());
  EXPECT_EQ((*results)[1].error, "cannot decode image");
  EXPECT_EQ((*results)[1].mode, "two");
  EXPECT_EQ((*results)[1].width, 0);
}

// `lane backfill`'s outputs end with a trailer line: skipped, not a frame.
TEST(ResultsJsonlReaderTest, SkipsTheBackfillTrailer) {
  const auto results = ParseResultsJsonl(
      R"({"schema":1,"frame":"a.jpg","mode":"all","error":"cannot decode image"})"
      "\n"
      R"({"trailer":{"schema":1,"frames":1,"failed_frames":1,"sha256":"00","version":"x"}})"
      "\n",
      "out.jsonl");
  ASSERT_TRUE(results.ok()) << results.status();
  ASSERT_EQ(results->size(), 1u);
  EXPECT_EQ((*results)[0].frame, "a.jpg");
}

TEST(ResultsJsonlReaderTest, MalformedLinesNameFileAndLine) {
  struct Case {
    const char* text;
    const char* message;
  } cases[] = {
      {R"({"schema":2,"frame":"a","lanes":[]})", "r.jsonl:1: schema 2 is not supported"},
      {R"({"frame":"a","lanes":[]})", "r.jsonl:1: no \"schema\""},
      {"{\"schema\":1,\"frame\":\"a\",\"lanes\":[]}\n{\"schema\":1,\"frame\":\"b\"}",
       "r.jsonl:2: \"lanes\" must be an array"},
      {R"({"schema":1,"frame":"a","lanes":[{"image":[[1,2],[3,4]]}]})",
       "r.jsonl:1: lanes[0].image must hold 4 [x, y] points"},
      {R"({"schema":1,"frame":"a","lanes":[{"image":[[1,2],[3,4],[5,6],[7,"x"]]}]})",
       "r.jsonl:1: lanes[0].image[3] must be [x, y]"},
      {"garbage", "r.jsonl:1: not a JSON object"},
  };
  for (const Case& c : cases) {
    const auto results = ParseResultsJsonl(c.text, "r.jsonl");
    ASSERT_FALSE(results.ok()) << c.text;
    EXPECT_TRUE(ErrorContains(results.status(), c.message));
  }
}

TEST(ResultsTxtTest, WriteThenRead) {
  const DetectedLane a{Curve::FromBezier(std::array<Eigen::Vector2d, 4>{
                           Eigen::Vector2d(100.125, 479), Eigen::Vector2d(150, 400),
                           Eigen::Vector2d(200, 320), Eigen::Vector2d(250.5, 240.25)}),
                       12.3};
  const DetectedLane b{Curve::FromBezier(std::array<Eigen::Vector2d, 4>{
                           Eigen::Vector2d(500, 479), Eigen::Vector2d(480, 400),
                           Eigen::Vector2d(460, 320), Eigen::Vector2d(440, 240)}),
                       3.5};
  const std::string text =
      ResultsTxtFrame(0, {a, b}) + ResultsTxtFrame(1, {}) + ResultsTxtFrame(2, {b});
  EXPECT_EQ(text.rfind("frame#00000000 has 2 splines\n"
                       "\tspline#1 has 4 points and score 12.3\n",
                       0),
            0u)
      << text;
  EXPECT_NE(text.find("\t\t100.125, 479.000\n"), std::string::npos) << text;

  const auto frames = ParseResultsTxt(text, "list.txt_results.txt");
  ASSERT_TRUE(frames.ok()) << frames.status();
  ASSERT_EQ(frames->size(), 3u);
  EXPECT_EQ((*frames)[0].index, 0);
  EXPECT_EQ((*frames)[0].frame, "#0");
  ASSERT_EQ((*frames)[0].lanes.size(), 2u);
  EXPECT_EQ((*frames)[0].lanes[0].curve.kind, Curve::Kind::kBezier);
  for (int i = 0; i < 4; ++i) {
    EXPECT_TRUE((*frames)[0].lanes[0].curve.points[i].isApprox(a.curve.points[i], 1e-6));
  }
  EXPECT_DOUBLE_EQ((*frames)[0].lanes[0].score, 12.3);
  EXPECT_TRUE((*frames)[1].lanes.empty());
  EXPECT_EQ((*frames)[2].index, 2);
  EXPECT_EQ((*frames)[2].lanes.size(), 1u);
}

TEST(ResultsTxtTest, MalformedFilesNameFileAndLine) {
  struct Case {
    const char* text;
    const char* message;
  } cases[] = {
      {"frame#0 has 1 splines\n\tspline#1 has 4 points and score 1\n\t\t1, 2\n\t\t3, 4\n",
       "r.txt:5: spline#1 of frame#0: expected point 3 of 4 as \"x, y\", got \"end of file\""},
      {"frame#0 has 1 splines\n\tspline#1 has 2 points and score 1\n\t\t1, 2\n\t\t3 4 5\n",
       "r.txt:4: spline#1 of frame#0: expected point 2 of 2"},
      {"frame#0 has 2 splines\n\tspline#1 has 2 points and score 1\n\t\t1, 2\n\t\t3, 4\n",
       "announces 2 splines, the file ends after 1"},
      {"frame#0 has 0 splines\nframe#0 has 0 splines\n", "r.txt:2: frame#0 appears twice"},
      {"hello\n", "r.txt:1: expected \"frame#N has K splines\""},
      {"frame#0 has 1 splines\nspline#1 has 1 points and score 1\n\t\t1, 2\n",
       "r.txt:2: expected \"spline#N has P points and score S\" with P >= 2"},
  };
  for (const Case& c : cases) {
    const auto frames = ParseResultsTxt(c.text, "r.txt");
    ASSERT_FALSE(frames.ok()) << c.text;
    EXPECT_TRUE(ErrorContains(frames.status(), c.message));
  }
}

TEST(ImageListTest, SkipsBlanksAndComments) {
  EXPECT_EQ(ParseImageList("f00000.png\n\n  f00001.png  \r\n# comment\nf00002.png"),
            (std::vector<std::string>{"f00000.png", "f00001.png", "f00002.png"}));
}

}  // namespace
}  // namespace lane::eval
