// Caltech Lanes labels: a labels.ccvl is written with libmatio in the
// documented layout (reference-implementation-notes.md), then read back,
// alone and as a clip with its list.txt.
#include <gtest/gtest.h>
#include <matio.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "lane/eval/caltech.h"
#include "lane/eval/dataset.h"

namespace lane::eval {
namespace {

namespace fs = std::filesystem;

fs::path CcvlTempDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("lane_eval_ccvl_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

matvar_t* Text(const std::string& s) {
  size_t dims[2] = {1, s.size()};
  return Mat_VarCreate(nullptr, MAT_C_CHAR, MAT_T_UTF8, 2, dims, const_cast<char*>(s.data()), 0);
}

matvar_t* Scalar(double v) {
  size_t dims[2] = {1, 1};
  return Mat_VarCreate(nullptr, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, &v, 0);
}

matvar_t* EmptyMatrix() {
  size_t dims[2] = {0, 0};
  return Mat_VarCreate(nullptr, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, nullptr, 0);
}

// An rows x 2 double matrix [x y] (MATLAB stores it column-major).
matvar_t* Points(const std::vector<Eigen::Vector2d>& points, size_t cols = 2) {
  std::vector<double> data;
  for (const auto& p : points) data.push_back(p.x());
  for (const auto& p : points) data.push_back(p.y());
  size_t dims[2] = {points.size(), cols};
  if (cols != 2) dims[0] = data.size() / cols;
  return Mat_VarCreate(nullptr, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, data.data(), 0);
}

struct TestLabel {
  std::vector<Eigen::Vector2d> points;
  std::string subtype;
  size_t cols = 2;  // a malformed file has another shape
};
struct TestFrame {
  std::string name;
  std::vector<TestLabel> labels;
  bool labels_as_empty_matrix = false;  // [] instead of a 1x0 struct
};

// ld.version, ld.source, ld.frames(i).frame, ld.frames(i).labels(k).{points,
// type, subtype, obj}, as the original labeller saves it.
void WriteCcvl(const fs::path& path, const std::vector<TestFrame>& frames) {
  const char* frame_fields[] = {"frame", "labels"};
  size_t frame_dims[2] = {1, frames.size()};
  matvar_t* frames_var = Mat_VarCreateStruct("frames", 2, frame_dims, frame_fields, 2);
  ASSERT_NE(frames_var, nullptr);
  for (size_t i = 0; i < frames.size(); ++i) {
    Mat_VarSetStructFieldByName(frames_var, "frame", i, Text(frames[i].name));
    matvar_t* labels_var = nullptr;
    if (frames[i].labels_as_empty_matrix) {
      labels_var = EmptyMatrix();
    } else {
      const char* label_fields[] = {"points", "type", "subtype", "obj"};
      size_t label_dims[2] = {1, frames[i].labels.size()};
      labels_var = Mat_VarCreateStruct("labels", 2, label_dims, label_fields, 4);
      for (size_t k = 0; k < frames[i].labels.size(); ++k) {
        const TestLabel& l = frames[i].labels[k];
        Mat_VarSetStructFieldByName(labels_var, "points", k, Points(l.points, l.cols));
        Mat_VarSetStructFieldByName(labels_var, "type", k, Text("spline"));
        Mat_VarSetStructFieldByName(labels_var, "subtype", k, Text(l.subtype));
        Mat_VarSetStructFieldByName(labels_var, "obj", k, EmptyMatrix());
      }
    }
    Mat_VarSetStructFieldByName(frames_var, "labels", i, labels_var);
  }
  const char* ld_fields[] = {"version", "source", "frames"};
  size_t ld_dims[2] = {1, 1};
  matvar_t* ld = Mat_VarCreateStruct("ld", 2, ld_dims, ld_fields, 3);
  Mat_VarSetStructFieldByName(ld, "version", 0, Scalar(0));
  Mat_VarSetStructFieldByName(ld, "source", 0, Text("image"));
  Mat_VarSetStructFieldByName(ld, "frames", 0, frames_var);

  mat_t* mat = Mat_CreateVer(path.c_str(), nullptr, MAT_FT_MAT5);
  ASSERT_NE(mat, nullptr) << path;
  EXPECT_EQ(Mat_VarWrite(mat, ld, MAT_COMPRESSION_ZLIB), 0);
  Mat_VarFree(ld);
  Mat_Close(mat);
}

const std::vector<Eigen::Vector2d> kLeft = {
    {130.5, 479}, {190.1, 400.3}, {250.7, 320}, {300.2, 240.5}};
const std::vector<Eigen::Vector2d> kRight = {{520, 479}, {470, 400}, {420, 320}, {380, 240}};

TEST(CcvlTest, WrittenInTheDocumentedLayoutAndReadBack) {
  const fs::path dir = CcvlTempDir("layout");
  WriteCcvl(dir / "labels.ccvl", {{"f00000.png", {{kLeft, "bw"}, {kRight, "sy"}}},
                                  {"f00001.png", {}},
                                  {"f00002.png", {}, /*labels_as_empty_matrix=*/true},
                                  {"f00003.png", {{{{10, 470}, {20, 400}, {30, 300}}, "dy"}}}});
  const auto frames = ReadCcvl((dir / "labels.ccvl").string());
  ASSERT_TRUE(frames.ok()) << frames.status();
  ASSERT_EQ(frames->size(), 4u);
  const CcvlFrame& f0 = (*frames)[0];
  EXPECT_EQ(f0.frame, "f00000.png");
  ASSERT_EQ(f0.labels.size(), 2u);
  EXPECT_EQ(f0.labels[0].type, "bw");
  EXPECT_EQ(f0.labels[1].type, "sy");
  ASSERT_EQ(f0.labels[0].curve.kind, Curve::Kind::kBezier);
  ASSERT_EQ(f0.labels[0].curve.points.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_TRUE(f0.labels[0].curve.points[i].isApprox(kLeft[i])) << "point " << i;
    EXPECT_TRUE(f0.labels[1].curve.points[i].isApprox(kRight[i])) << "point " << i;
  }
  EXPECT_EQ((*frames)[1].frame, "f00001.png");
  EXPECT_TRUE((*frames)[1].labels.empty());
  EXPECT_TRUE((*frames)[2].labels.empty());
  // 3 points: not a Bezier, kept as a polyline.
  ASSERT_EQ((*frames)[3].labels.size(), 1u);
  EXPECT_EQ((*frames)[3].labels[0].curve.kind, Curve::Kind::kPolyline);
  EXPECT_EQ((*frames)[3].labels[0].curve.points.size(), 3u);
}

TEST(CcvlTest, MalformedPointsNameTheElement) {
  const fs::path dir = CcvlTempDir("malformed");
  WriteCcvl(dir / "labels.ccvl", {{"f00000.png", {{kLeft, "bw"}}},
                                  {"f00001.png", {{kLeft, "bw"}, {kLeft, "sw", /*cols=*/8}}}});
  const auto frames = ReadCcvl((dir / "labels.ccvl").string());
  ASSERT_FALSE(frames.ok());
  const std::string message(frames.status().message());
  EXPECT_NE(message.find("labels.ccvl: ld.frames(2).labels(2).points is 1x8, expected 4x2"),
            std::string::npos)
      << message;
}

TEST(CcvlTest, NotAMatFile) {
  const fs::path dir = CcvlTempDir("not_mat");
  std::ofstream(dir / "labels.ccvl") << "this is not a MAT-file\n";
  const auto frames = ReadCcvl((dir / "labels.ccvl").string());
  ASSERT_FALSE(frames.ok());
  EXPECT_NE(std::string(frames.status().message()).find("labels.ccvl"), std::string::npos);
}

TEST(CcvlTest, ClipWithListLoadsAsCaltechDataset) {
  // caltech/cordova1/{labels.ccvl,list.txt}; the list names one frame the
  // labels do not have.
  const fs::path root = CcvlTempDir("dataset");
  const fs::path clip = root / "cordova1";
  fs::create_directories(clip);
  WriteCcvl(clip / "labels.ccvl",
            {{"f00000.png", {{kLeft, "bw"}, {kRight, "sy"}}}, {"f00001.png", {{kLeft, "bw"}}}});
  std::ofstream(clip / "list.txt") << "f00000.png\nf00001.png\nf00002.png\n";

  const auto format = DetectDatasetFormat(root.string());
  ASSERT_TRUE(format.ok()) << format.status();
  EXPECT_EQ(*format, DatasetFormat::kCaltech);
  const auto dataset = LoadDataset(root.string());
  ASSERT_TRUE(dataset.ok()) << dataset.status();
  ASSERT_EQ(dataset->clips.size(), 1u);
  const Clip& c = dataset->clips[0];
  EXPECT_EQ(c.name, "cordova1");
  ASSERT_EQ(c.frames.size(), 3u);
  EXPECT_EQ(c.frames[0].name, "cordova1/f00000.png");
  EXPECT_EQ(c.frames[0].boundaries.size(), 2u);
  EXPECT_EQ(fs::path(c.frames[1].image_path), clip / "f00001.png");
  EXPECT_TRUE(c.frames[1].labelled);
  EXPECT_FALSE(c.frames[2].labelled);
  ASSERT_EQ(dataset->warnings.size(), 1u);
  EXPECT_NE(dataset->warnings[0].find("no labels for 1 listed frame"), std::string::npos);

  // The clip folder itself is a data set of one clip named after it.
  const auto single = LoadDataset(clip.string());
  ASSERT_TRUE(single.ok()) << single.status();
  EXPECT_EQ(single->clips[0].name, "cordova1");
  EXPECT_EQ(single->clips[0].frames[0].name, "f00000.png");
}

}  // namespace
}  // namespace lane::eval
