#include "wire/config_proto.h"

#include <google/protobuf/descriptor.h>
#include <gtest/gtest.h>

#include <functional>
#include <nlohmann/json.hpp>

#include "lane/geometry/ground_view_rule.h"
#include "wire/detection_proto.h"

namespace lane::wire {
namespace {

// The conversion finds proto fields by the config schema's names: a config
// field without a proto field (or of another kind), or a proto field without
// a config field, is named here.
TEST(ConvertTest, ProtoAndConfigSchemaLineUp) {
  const std::vector<std::string> problems = ProtoSchemaMismatches();
  for (const std::string& problem : problems) ADD_FAILURE() << problem;
  EXPECT_TRUE(problems.empty());
}

TEST(ConvertTest, EmptyConfigIsTheDefaults) {
  absl::StatusOr<lane::Config> config = ConfigFromProto(v1::SessionConfig());
  ASSERT_TRUE(config.ok()) << config.status();
  EXPECT_EQ(lane::ConfigToJson(*config), lane::ConfigToJson(lane::Config{}));
}

// A camera and no ipm: the view the camera needs, as in a config file
// (lane/geometry/ground_view_rule.h); with an ipm, the ipm.
TEST(ConvertTest, CameraWithoutIpmGetsTheBuiltInView) {
  v1::SessionConfig proto;
  proto.mutable_camera()->set_fu(730);
  proto.mutable_camera()->set_fv(730);
  proto.mutable_camera()->set_cu(256);
  proto.mutable_camera()->set_cv(144);
  proto.mutable_camera()->set_pitch_deg(2.9);
  proto.mutable_camera()->set_height_m(1.67);
  proto.mutable_camera()->set_image_width(512);
  proto.mutable_camera()->set_image_height(288);
  absl::StatusOr<lane::Config> config = ConfigFromProto(proto);
  ASSERT_TRUE(config.ok()) << config.status();
  const absl::StatusOr<lane::IpmOptions> built_in = lane::BuiltInIpm(config->camera);
  ASSERT_TRUE(built_in.ok()) << built_in.status();
  EXPECT_EQ(config->ipm.view, lane::IpmView::kGround);
  EXPECT_DOUBLE_EQ(config->ipm.ground.y_min_m, built_in->ground.y_min_m);
  EXPECT_DOUBLE_EQ(config->ipm.ground.y_max_m, built_in->ground.y_max_m);
  // The same camera as JSON gives the same config.
  v1::SessionConfig json;
  json.set_config_json(R"({"camera": {"fu": 730, "fv": 730, "cu": 256, "cv": 144,
      "pitch_deg": 2.9, "height_m": 1.67, "image_width": 512, "image_height": 288}})");
  absl::StatusOr<lane::Config> from_json = ConfigFromProto(json);
  ASSERT_TRUE(from_json.ok()) << from_json.status();
  EXPECT_EQ(lane::ConfigToJson(*from_json), lane::ConfigToJson(*config));
  proto.mutable_ipm()->set_width(160);
  config = ConfigFromProto(proto);
  ASSERT_TRUE(config.ok()) << config.status();
  EXPECT_EQ(config->ipm.view, lane::IpmView::kRoi);
  // A camera that sees no road is refused.
  proto.clear_ipm();
  proto.mutable_camera()->set_pitch_deg(-40);
  EXPECT_EQ(ConfigFromProto(proto).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(ConvertTest, ModeSelectsItsDefaultsThenFieldsOverride) {
  v1::SessionConfig proto;
  proto.mutable_detector()->set_mode(v1::MODE_TWO);
  proto.mutable_detector()->mutable_spline_ransac()->set_iterations(11);
  proto.mutable_camera()->set_pitch_deg(12.5);
  proto.mutable_ipm()->mutable_roi()->set_top(230);
  absl::StatusOr<lane::Config> config = ConfigFromProto(proto);
  ASSERT_TRUE(config.ok()) << config.status();
  const lane::DetectorOptions two = lane::DetectorOptions::ForMode(lane::Mode::kTwo);
  EXPECT_EQ(config->detector.mode, lane::Mode::kTwo);
  EXPECT_EQ(config->detector.threshold.quantile, two.threshold.quantile);
  EXPECT_EQ(config->detector.spline_ransac.ransac.iterations, 11);
  EXPECT_DOUBLE_EQ(config->camera.pitch_deg, 12.5);
  EXPECT_DOUBLE_EQ(config->ipm.roi.top, 230);
  EXPECT_DOUBLE_EQ(config->ipm.roi.left, lane::Roi{}.left);
}

TEST(ConvertTest, RoundTrip) {
  lane::Config config;
  config.detector = lane::DetectorOptions::ForMode(lane::Mode::kTwo);
  config.detector.channel = lane::Channel::kGray;
  config.detector.seed = 99;
  config.detector.postprocess.extend_in_image = false;
  config.ipm.interpolation = lane::Interpolation::kNearest;
  config.camera.yaw_deg = 1.5;
  v1::SessionConfig proto;
  ConfigToProto(config, &proto);
  absl::StatusOr<lane::Config> back = ConfigFromProto(proto);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(lane::ConfigToJson(*back), lane::ConfigToJson(config));
}

// The list the perturbation below cannot reach: ipm.static_mask, a
// repeated Roi.
TEST(ConvertTest, StaticMaskRoundTrips) {
  lane::Config config;
  config.ipm.static_mask = {{1199, 1323, 339, 372}, {0, 10.5, 20, 30}};
  v1::SessionConfig proto;
  ConfigToProto(config, &proto);
  ASSERT_EQ(proto.ipm().static_mask_size(), 2);
  EXPECT_DOUBLE_EQ(proto.ipm().static_mask(1).right(), 10.5);
  absl::StatusOr<lane::Config> back = ConfigFromProto(proto);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(lane::ConfigToJson(*back), lane::ConfigToJson(config));
  // A rectangle's unset fields keep a Roi's defaults; a bad one is refused.
  v1::SessionConfig partial;
  partial.mutable_ipm()->add_static_mask()->set_top(300);
  back = ConfigFromProto(partial);
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->ipm.static_mask.size(), 1u);
  EXPECT_DOUBLE_EQ(back->ipm.static_mask[0].left, lane::Roi{}.left);
  EXPECT_DOUBLE_EQ(back->ipm.static_mask[0].top, 300);
  v1::SessionConfig bad;
  v1::Roi* box = bad.mutable_ipm()->add_static_mask();
  box->set_left(10);
  box->set_right(5);
  back = ConfigFromProto(bad);
  EXPECT_EQ(back.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(back.status().message().find("static_mask[0]"), std::string::npos) << back.status();
}

// The enums the perturbation below cannot reach: the ground view, area
// sampling and the min(red, green) channel.
TEST(ConvertTest, GroundViewAreaSamplingAndMinRedGreenRoundTrip) {
  lane::Config config;
  config.ipm.view = lane::IpmView::kGround;
  config.ipm.ground = {-6, 6, 7, 19, 0.05, 0.1};
  config.ipm.interpolation = lane::Interpolation::kArea;
  config.detector.channel = lane::Channel::kMinRedGreen;
  v1::SessionConfig proto;
  ConfigToProto(config, &proto);
  EXPECT_EQ(proto.ipm().view(), v1::IPM_VIEW_GROUND);
  EXPECT_EQ(proto.ipm().interpolation(), v1::INTERPOLATION_AREA);
  absl::StatusOr<lane::Config> back = ConfigFromProto(proto);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(lane::ConfigToJson(*back), lane::ConfigToJson(config));
  // A ground section without a view selects the ground view.
  v1::SessionConfig implicit;
  implicit.mutable_ipm()->mutable_ground()->set_y_max_m(20);
  absl::StatusOr<lane::Config> ground = ConfigFromProto(implicit);
  ASSERT_TRUE(ground.ok()) << ground.status();
  EXPECT_EQ(ground->ipm.view, lane::IpmView::kGround);
  EXPECT_DOUBLE_EQ(ground->ipm.ground.y_max_m, 20);
}

// Every key of the config file must survive the proto: perturb every number
// and switch of a full config, then compare config -> proto -> config.
TEST(ConvertTest, EveryConfigFieldSurvivesTheProto) {
  nlohmann::json doc = nlohmann::json::parse(lane::ConfigToJson(lane::Config{}));
  int leaves = 0;
  std::function<void(nlohmann::json&)> perturb = [&](nlohmann::json& j) {
    for (auto& [key, value] : j.items()) {
      if (value.is_object()) {
        perturb(value);
      } else if (value.is_boolean()) {
        value = !value.get<bool>();
        ++leaves;
      } else if (value.is_number_integer() || value.is_number_unsigned()) {
        value = value.get<int64_t>() + 1;
        ++leaves;
      } else if (value.is_number_float()) {
        value = value.get<double>() * 0.97 + 0.001;
        ++leaves;
      }
    }
  };
  perturb(doc);
  ASSERT_GT(leaves, 50);
  absl::StatusOr<lane::Config> config = lane::ParseConfig(doc.dump());
  ASSERT_TRUE(config.ok()) << config.status();
  v1::SessionConfig proto;
  ConfigToProto(*config, &proto);
  absl::StatusOr<lane::Config> back = ConfigFromProto(proto);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(lane::ConfigToJson(*back), lane::ConfigToJson(*config));
}

TEST(ConvertTest, JsonAlternative) {
  v1::SessionConfig proto;
  proto.set_config_json(R"({"camera": {"pitch_deg": 11}})");
  absl::StatusOr<lane::Config> config = ConfigFromProto(proto);
  ASSERT_TRUE(config.ok()) << config.status();
  EXPECT_DOUBLE_EQ(config->camera.pitch_deg, 11);
  proto.mutable_camera()->set_fu(1);
  EXPECT_EQ(ConfigFromProto(proto).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(ConvertTest, RefusesUnknownEnumsAndInvalidValues) {
  v1::SessionConfig proto;
  proto.mutable_detector()->set_channel(static_cast<v1::Channel>(9));
  EXPECT_EQ(ConfigFromProto(proto).status().code(), absl::StatusCode::kInvalidArgument);
  proto = {};
  proto.mutable_ipm()->set_interpolation(static_cast<v1::Interpolation>(9));
  EXPECT_EQ(ConfigFromProto(proto).status().code(), absl::StatusCode::kInvalidArgument);
  proto = {};
  proto.mutable_camera()->set_fu(-1);
  EXPECT_EQ(ConfigFromProto(proto).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(ConvertTest, Lanes) {
  lane::Detection detection;
  lane::Lane lane;
  for (int i = 0; i < 4; ++i) {
    lane.image[i] = {i, 10.0 * i};
    lane.ipm[i] = {2.0 * i, 3.0};
    lane.ground[i] = {-1.8, 5.0 * i};
  }
  lane.score = 4.5;
  detection.lanes = {lane, lane};
  detection.lanes[1].inferred = true;
  detection.timings.total_ms = 3;
  v1::FrameResponse response = LanesToProto(detection);
  *response.mutable_timings() = TimingsToProto(detection.timings);
  ASSERT_EQ(response.lanes_size(), 2);
  const v1::Lane& l = response.lanes(0);
  ASSERT_EQ(l.image().control_points_size(), 4);
  EXPECT_DOUBLE_EQ(l.image().control_points(3).y(), 30.0);
  EXPECT_DOUBLE_EQ(l.ipm().control_points(2).x(), 4.0);
  EXPECT_DOUBLE_EQ(l.ground().control_points(1).y(), 5.0);
  EXPECT_DOUBLE_EQ(l.score(), 4.5);
  EXPECT_FALSE(l.inferred());
  EXPECT_TRUE(response.lanes(1).inferred());
  EXPECT_FALSE(response.has_ego());
  EXPECT_EQ(l.id(), 0);  // untracked
  EXPECT_DOUBLE_EQ(response.timings().detect_ms(), 3);
  // And back, as lane-client reads an untracked session's response.
  const lane::Detection back = DetectionFromProto(response);
  ASSERT_EQ(back.lanes.size(), 2u);
  EXPECT_EQ(back.lanes[0].image, lane.image);
  EXPECT_EQ(back.lanes[0].ipm, lane.ipm);
  EXPECT_EQ(back.lanes[0].ground, lane.ground);
  EXPECT_DOUBLE_EQ(back.lanes[0].score, 4.5);
  EXPECT_FALSE(back.lanes[0].inferred);
  EXPECT_TRUE(back.lanes[1].inferred);
  EXPECT_DOUBLE_EQ(back.timings.total_ms, 3);
}

// A tracked frame goes onto the wire and comes back with every field: the
// lanes' curves, score, inferred and refit flags, ids, confirmed and
// predicted flags, colours and types, and the ego lane (its boundaries found
// again by their ids). What the server sends is what lane-client writes.
// Three tracked lanes of every kind (confirmed, predicted, inferred, refit;
// colours and types), an ego lane and timings.
lane::TrackedFrame SampleTrackedFrame() {
  lane::TrackedFrame frame;
  for (int k = 0; k < 3; ++k) {
    lane::TrackedLane& tracked = frame.lanes.emplace_back();
    for (int i = 0; i < 4; ++i) {
      tracked.lane.image[i] = {100.0 * k + i, 10.0 * i + 0.125};
      tracked.lane.ipm[i] = {2.0 * i + k, 3.5};
      tracked.lane.ground[i] = {-1.8 + 3.6 * k, 5.0 * i};
    }
    tracked.lane.score = 1.5 + k;
    tracked.id = 7 + k;
  }
  frame.lanes[0].confirmed = true;
  frame.lanes[0].color = lane::MarkingColor::kYellow;
  frame.lanes[0].type = lane::MarkingType::kDouble;
  frame.lanes[0].lane.refit = true;
  frame.lanes[1].predicted = true;
  frame.lanes[1].confirmed = true;
  frame.lanes[1].color = lane::MarkingColor::kWhite;
  frame.lanes[1].type = lane::MarkingType::kDashed;
  frame.lanes[1].lane.score = 0;
  frame.lanes[2].lane.inferred = true;
  frame.lanes[2].type = lane::MarkingType::kRoadEdge;
  lane::EgoLane ego;
  ego.offset_m = -0.25;
  ego.width_m = 3.5;
  ego.heading_deg = 1.25;
  ego.curvature_per_m = 1e-4;
  ego.left_index = 0;
  ego.right_index = 1;
  ego.left_id = 7;
  ego.right_id = 8;
  ego.left_distance_m = 1.5;
  ego.right_distance_m = 2.0;
  ego.offset_rate_mps = -0.5;
  ego.departing = true;
  frame.ego = ego;
  frame.detection.timings.stage_ms[0] = 0.5;
  frame.detection.timings.total_ms = 2.5;
  return frame;
}

TEST(ConvertTest, TrackedFrameRoundTrip) {
  lane::TrackedFrame frame = SampleTrackedFrame();
  const lane::EgoLane ego = *frame.ego;

  v1::FrameResponse response = LanesToProto(frame);
  *response.mutable_timings() = TimingsToProto(frame.detection.timings);
  const lane::TrackedFrame back = TrackedFrameFromProto(response);
  ASSERT_EQ(back.lanes.size(), frame.lanes.size());
  for (size_t k = 0; k < frame.lanes.size(); ++k) {
    const lane::TrackedLane& a = frame.lanes[k];
    const lane::TrackedLane& b = back.lanes[k];
    EXPECT_EQ(b.lane.image, a.lane.image) << k;
    EXPECT_EQ(b.lane.ipm, a.lane.ipm) << k;
    EXPECT_EQ(b.lane.ground, a.lane.ground) << k;
    EXPECT_EQ(b.lane.score, a.lane.score) << k;
    EXPECT_EQ(b.lane.inferred, a.lane.inferred) << k;
    EXPECT_EQ(b.lane.refit, a.lane.refit) << k;
    EXPECT_EQ(b.id, a.id) << k;
    EXPECT_EQ(b.confirmed, a.confirmed) << k;
    EXPECT_EQ(b.predicted, a.predicted) << k;
    EXPECT_EQ(b.color, a.color) << k;
    EXPECT_EQ(b.type, a.type) << k;
  }
  ASSERT_TRUE(back.ego.has_value());
  EXPECT_EQ(back.ego->offset_m, ego.offset_m);
  EXPECT_EQ(back.ego->width_m, ego.width_m);
  EXPECT_EQ(back.ego->heading_deg, ego.heading_deg);
  EXPECT_EQ(back.ego->curvature_per_m, ego.curvature_per_m);
  EXPECT_EQ(back.ego->left_index, ego.left_index);
  EXPECT_EQ(back.ego->right_index, ego.right_index);
  EXPECT_EQ(back.ego->left_id, ego.left_id);
  EXPECT_EQ(back.ego->right_id, ego.right_id);
  EXPECT_EQ(back.ego->left_distance_m, ego.left_distance_m);
  EXPECT_EQ(back.ego->right_distance_m, ego.right_distance_m);
  EXPECT_EQ(back.ego->offset_rate_mps, ego.offset_rate_mps);
  EXPECT_EQ(back.ego->departing, ego.departing);
  // The detection: the lanes the frame showed (not the predicted one), its
  // refit count and timings.
  ASSERT_EQ(back.detection.lanes.size(), 2u);
  EXPECT_EQ(back.detection.lanes[1].image, frame.lanes[2].lane.image);
  EXPECT_EQ(back.detection.refit_lanes, 1);
  EXPECT_DOUBLE_EQ(back.detection.timings.stage_ms[0], 0.5);
  EXPECT_DOUBLE_EQ(back.detection.timings.total_ms, 2.5);
  // A tracked frame without an ego lane sends none.
  frame.ego.reset();
  EXPECT_FALSE(LanesToProto(frame).has_ego());
  EXPECT_FALSE(TrackedFrameFromProto(LanesToProto(frame)).ego.has_value());
}

// Every stage of the detector's table has its timing field in the proto
// (StageTimings.<name>_ms), and the timings go there and come back by name.
TEST(ConvertTest, EveryDetectorStageHasATimingField) {
  ASSERT_GE(lane::DetectorStageCount(), 7u);
  const std::vector<const google::protobuf::FieldDescriptor*>& fields = StageTimingFields();
  ASSERT_EQ(fields.size(), lane::DetectorStageCount());
  lane::StageTimings timings;
  for (size_t i = 0; i < fields.size(); ++i) {
    ASSERT_NE(fields[i], nullptr) << "lane.v1.StageTimings has no field "
                                  << lane::DetectorStageName(i) << "_ms";
    timings.stage_ms[i] = 1.5 + static_cast<double>(i);
    timings.ran[i] = true;
  }
  const v1::StageTimings proto = TimingsToProto(timings);
  EXPECT_DOUBLE_EQ(proto.ipm_ms(), timings.Ms("ipm"));
  EXPECT_DOUBLE_EQ(proto.postprocess_ms(), timings.Ms("postprocess"));
  const lane::StageTimings back = TimingsFromProto(proto);
  for (size_t i = 0; i < fields.size(); ++i) {
    EXPECT_DOUBLE_EQ(back.stage_ms[i], timings.stage_ms[i]) << lane::DetectorStageName(i);
    EXPECT_TRUE(back.ran[i]);
  }
}

}  // namespace
}  // namespace lane::wire
