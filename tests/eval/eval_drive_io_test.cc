// Reading a rendered drive's labels and a tracker's results for `lane eval
// --drive`: the labels `lane render --sequence` writes read back as the
// truth the drive test scores in memory; results records keep ids, colour,
// type and the ego lane; malformed input names the file and line.
#include <gtest/gtest.h>

#include <string>

#include "lane/eval/drive_io.h"
#include "lane/eval/render_labels.h"
#include "lane/synthetic.h"

namespace lane::eval {
namespace {

TEST(DriveLabelsTest, RenderedLabelsReadBackAsTheDrivesTruth) {
  const CameraModel camera;  // the Caltech camera
  SyntheticDriveOptions options;
  options.count = 60;
  std::string text;
  std::vector<DriveTruthFrame> expected;
  for (int i : {0, 25, 59}) {
    absl::StatusOr<SyntheticFrame> frame = RenderSyntheticDriveFrame(camera, options, 3, i);
    ASSERT_TRUE(frame.ok()) << frame.status();
    text += RenderLabelsJson("f" + std::to_string(i) + ".png", *frame) + "\n";
    expected.push_back(DriveTruthOf(*frame));
  }
  const absl::StatusOr<DriveLabels> labels = ParseDriveLabels(text, "labels.jsonl");
  ASSERT_TRUE(labels.ok()) << labels.status();
  ASSERT_EQ(labels->truth.size(), 3u);
  EXPECT_EQ(labels->frames[1], "f25.png");
  for (size_t f = 0; f < 3; ++f) {
    const DriveTruthFrame& got = labels->truth[f];
    const DriveTruthFrame& want = expected[f];
    EXPECT_EQ(got.width, 640);
    EXPECT_NEAR(got.time_s, want.time_s, 1e-4);
    ASSERT_EQ(got.boundaries.size(), want.boundaries.size());
    ASSERT_FALSE(got.boundaries.empty());
    for (size_t b = 0; b < got.boundaries.size(); ++b) {
      EXPECT_EQ(got.boundaries[b].id, want.boundaries[b].id);
      EXPECT_EQ(got.boundaries[b].yellow, want.boundaries[b].yellow);
      EXPECT_EQ(got.boundaries[b].dashed, want.boundaries[b].dashed);
      EXPECT_EQ(got.boundaries[b].type_changes, want.boundaries[b].type_changes);
      ASSERT_EQ(got.boundaries[b].curve.points.size(), 4u);
      for (size_t k = 0; k < 4; ++k) {
        EXPECT_LT((got.boundaries[b].curve.points[k] - want.boundaries[b].curve.points[k]).norm(),
                  0.01);
      }
    }
    EXPECT_EQ(got.road_edges.size(), want.road_edges.size());
    ASSERT_TRUE(got.ego.has_value());
    ASSERT_TRUE(want.ego.has_value());
    EXPECT_EQ(got.ego->lane, want.ego->lane);
    EXPECT_NEAR(got.ego->offset_m, want.ego->offset_m, 1e-4);
    EXPECT_NEAR(got.ego->heading_deg, want.ego->heading_deg, 1e-4);
  }
  // The drive has asphalt edges in view somewhere (the labels carry them).
  size_t edges = 0;
  for (const DriveTruthFrame& t : labels->truth) edges += t.road_edges.size();
  EXPECT_GT(edges, 0u);
}

TEST(DriveLabelsTest, LabelsOfSingleFramesAreNoDrive) {
  const std::string line =
      R"({"frame":"000000.png","width":640,"height":480,"boundaries":[{"points":)"
      R"([[1,479],[2,400],[3,300],[4,250]],"dashed":true,"color":"white","ego":"left","id":0}]})";
  const absl::StatusOr<DriveLabels> labels = ParseDriveLabels(line + "\n", "labels.jsonl");
  ASSERT_FALSE(labels.ok());
  EXPECT_NE(labels.status().message().find("labels.jsonl:1"), std::string::npos);
  EXPECT_NE(labels.status().message().find("time_s"), std::string::npos);

  const std::string typed =
      R"({"frame":"0.png","width":640,"height":480,"time_s":0,"boundaries":[{"points":)"
      R"([[1,479],[2,400],[3,300],[4,250]],"dashed":"yes","id":0}]})";
  const absl::StatusOr<DriveLabels> wrong = ParseDriveLabels(typed + "\n", "labels.jsonl");
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.status().message().find("boundaries[0]"), std::string::npos) << wrong.status();
}

TEST(DriveResultsTest, TrackedRecordsKeepIdsAttributesAndTheEgoLanesBoundaries) {
  const std::string text =
      R"({"schema":1,"frame":"a/000000.png","lanes":[)"
      R"({"image":[[300,479],[310,400],[320,300],[330,250]],"id":4,"confirmed":true,)"
      R"("predicted":false,"color":"yellow","type":"double"},)"
      R"({"image":[[100,479],[150,400],[200,300],[250,250]],"id":7,"confirmed":false,)"
      R"("predicted":true,"color":"white","type":"dashed"}],)"
      R"("ego":{"offset_m":0.25,"width_m":3.5,"heading_deg":-1.5,"curvature_per_m":0.001,)"
      R"("left_id":7,"right_id":4,"left_distance_m":2,"right_distance_m":1.5,)"
      R"("offset_rate_mps":0.3,"departing":true}})"
      "\n"
      R"({"schema":1,"frame":"000001.png","error":"corrupt JPEG"})"
      "\n";
  const absl::StatusOr<DriveResults> results = ParseDriveResults(text, "r.jsonl");
  ASSERT_TRUE(results.ok()) << results.status();
  EXPECT_TRUE(results->tracked);
  ASSERT_EQ(results->outputs.size(), 2u);
  const DriveOutput& first = results->outputs[0];
  ASSERT_EQ(first.lanes.size(), 2u);
  EXPECT_EQ(first.lanes[0].id, 4);
  EXPECT_TRUE(first.lanes[0].confirmed);
  EXPECT_EQ(first.lanes[0].color, MarkingColor::kYellow);
  EXPECT_EQ(first.lanes[0].type, MarkingType::kDouble);
  EXPECT_TRUE(first.lanes[1].predicted);
  EXPECT_EQ(first.lanes[1].type, MarkingType::kDashed);
  EXPECT_TRUE(first.lanes[1].lane.image[3].isApprox(Eigen::Vector2d(250, 250)));
  ASSERT_TRUE(first.ego.has_value());
  EXPECT_EQ(first.ego->left_index, 1);  // the lane with id 7
  EXPECT_EQ(first.ego->right_index, 0);
  EXPECT_DOUBLE_EQ(first.ego->heading_deg, -1.5);
  EXPECT_TRUE(first.ego->departing);
  EXPECT_TRUE(results->outputs[1].lanes.empty());  // the failed frame
  EXPECT_FALSE(results->outputs[1].ego.has_value());
}

TEST(DriveResultsTest, UntrackedRecordsAndMalformedLanes) {
  const std::string untracked =
      R"({"schema":1,"frame":"0.png","lanes":[{"image":[[1,2],[3,4],[5,6],[7,8]]}]})";
  const absl::StatusOr<DriveResults> plain = ParseDriveResults(untracked + "\n", "u.jsonl");
  ASSERT_TRUE(plain.ok()) << plain.status();
  EXPECT_FALSE(plain->tracked);
  EXPECT_EQ(plain->outputs[0].lanes[0].id, -1);
  EXPECT_EQ(plain->outputs[0].lanes[0].color, MarkingColor::kUnknown);

  // Keys of the wrong type are errors, not exceptions.
  for (const std::string field : {R"("color":5)", R"("confirmed":"yes")", R"("type":[1])"}) {
    const std::string line =
        R"({"schema":1,"frame":"1.png","lanes":[{"image":[[1,2],[3,4],[5,6],[7,8]],)" + field +
        "}]}";
    const absl::StatusOr<DriveResults> typed = ParseDriveResults(line + "\n", "t.jsonl");
    ASSERT_FALSE(typed.ok()) << field;
    EXPECT_NE(typed.status().message().find("t.jsonl:1: lanes[0]"), std::string::npos)
        << typed.status();
  }
  const std::string bad_ego =
      R"({"schema":1,"frame":"1.png","lanes":[],"ego":{"offset_m":0,"width_m":3.5,)"
      R"("heading_deg":0,"curvature_per_m":0,"left_id":"a"}})";
  EXPECT_FALSE(ParseDriveResults(bad_ego + "\n", "t.jsonl").ok());

  const std::string bad = R"({"schema":1,"frame":"1.png","lanes":[{"image":[[1,2],[3,4]]}]})";
  const absl::StatusOr<DriveResults> broken =
      ParseDriveResults(untracked + "\n" + bad + "\n", "u.jsonl");
  ASSERT_FALSE(broken.ok());
  EXPECT_NE(broken.status().message().find("u.jsonl:2"), std::string::npos);
  EXPECT_NE(broken.status().message().find("lanes[0].image"), std::string::npos);
}

}  // namespace
}  // namespace lane::eval
