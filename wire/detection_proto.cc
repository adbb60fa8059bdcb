#include "wire/detection_proto.h"

#include <google/protobuf/descriptor.h>

#include "absl/strings/str_cat.h"

namespace lane::wire {
namespace {

void BezierToProto(const std::array<Eigen::Vector2d, 4>& points, v1::Bezier* out) {
  out->mutable_control_points()->Reserve(4);
  for (const Eigen::Vector2d& p : points) {
    v1::Point2* q = out->add_control_points();
    q->set_x(p.x());
    q->set_y(p.y());
  }
}

v1::MarkingColor ColorToProto(lane::MarkingColor c) {
  switch (c) {
    case lane::MarkingColor::kWhite:
      return v1::MARKING_COLOR_WHITE;
    case lane::MarkingColor::kYellow:
      return v1::MARKING_COLOR_YELLOW;
    case lane::MarkingColor::kUnknown:
      break;
  }
  return v1::MARKING_COLOR_UNKNOWN;
}

lane::MarkingColor ColorFromProto(v1::MarkingColor c) {
  switch (c) {
    case v1::MARKING_COLOR_WHITE:
      return lane::MarkingColor::kWhite;
    case v1::MARKING_COLOR_YELLOW:
      return lane::MarkingColor::kYellow;
    default:
      return lane::MarkingColor::kUnknown;
  }
}

std::array<Eigen::Vector2d, 4> BezierFromProto(const v1::Bezier& b) {
  std::array<Eigen::Vector2d, 4> out;
  for (int k = 0; k < 4; ++k) {
    out[k] = k < b.control_points_size()
                 ? Eigen::Vector2d(b.control_points(k).x(), b.control_points(k).y())
                 : Eigen::Vector2d::Zero();
  }
  return out;
}

void IdentityToProto(const lane::Lane& lane, v1::Lane* l) {
  l->set_id(lane.id > 0 ? lane.id : 0);
  l->set_confirmed(lane.confirmed);
  l->set_color(ColorToProto(lane.color));
  // MarkingType's order is the proto's.
  l->set_type(static_cast<v1::MarkingType>(static_cast<int>(lane.type)));
  l->set_predicted(lane.predicted);
  l->set_inferred(lane.inferred);
  l->set_refit(lane.refit);
}

void LaneToProto(const lane::Lane& lane, v1::Lane* l) {
  BezierToProto(lane.image, l->mutable_image());
  BezierToProto(lane.ipm, l->mutable_ipm());
  BezierToProto(lane.ground, l->mutable_ground());
  l->set_score(lane.score);
  IdentityToProto(lane, l);
}

void EgoToProto(const std::optional<lane::EgoLane>& ego, v1::FrameResponse* out) {
  if (!ego) {
    out->clear_ego();
    return;
  }
  v1::EgoLane* e = out->mutable_ego();
  e->set_offset_m(ego->offset_m);
  e->set_width_m(ego->width_m);
  e->set_heading_deg(ego->heading_deg);
  e->set_curvature_per_m(ego->curvature_per_m);
  e->set_left_lane_id(ego->left_id > 0 ? ego->left_id : 0);
  e->set_right_lane_id(ego->right_id > 0 ? ego->right_id : 0);
  e->set_left_distance_m(ego->left_distance_m);
  e->set_right_distance_m(ego->right_distance_m);
  e->set_offset_rate_mps(ego->offset_rate_mps);
  e->set_departing(ego->departing);
}

}  // namespace

void LanesToProto(const lane::Detection& detection, v1::FrameResponse* out) {
  out->mutable_lanes()->Reserve(static_cast<int>(detection.lanes.size()));
  for (const lane::Lane& lane : detection.lanes) LaneToProto(lane, out->add_lanes());
  if (detection.ego) EgoToProto(detection.ego, out);
}

std::vector<lane::Lane> LanesFromProto(const v1::FrameResponse& response) {
  std::vector<lane::Lane> lanes;
  for (const v1::Lane& l : response.lanes()) {
    lane::Lane lane;
    lane.image = BezierFromProto(l.image());
    lane.ipm = BezierFromProto(l.ipm());
    lane.ground = BezierFromProto(l.ground());
    lane.score = l.score();
    lane.id = l.id() > 0 ? l.id() : -1;
    lane.confirmed = l.confirmed();
    lane.predicted = l.predicted();
    lane.inferred = l.inferred();
    lane.refit = l.refit();
    lane.color = ColorFromProto(l.color());
    lane.type = l.type() >= v1::MARKING_TYPE_UNKNOWN && l.type() <= v1::MARKING_TYPE_ROAD_EDGE
                    ? static_cast<lane::MarkingType>(static_cast<int>(l.type()))
                    : lane::MarkingType::kUnknown;
    lanes.push_back(lane);
  }
  return lanes;
}

std::optional<lane::EgoLane> EgoFromProto(const v1::FrameResponse& response) {
  if (!response.has_ego()) return std::nullopt;
  const v1::EgoLane& e = response.ego();
  lane::EgoLane ego;
  ego.offset_m = e.offset_m();
  ego.width_m = e.width_m();
  ego.heading_deg = e.heading_deg();
  ego.curvature_per_m = e.curvature_per_m();
  ego.left_id = e.left_lane_id() > 0 ? e.left_lane_id() : -1;
  ego.right_id = e.right_lane_id() > 0 ? e.right_lane_id() : -1;
  ego.left_distance_m = e.left_distance_m();
  ego.right_distance_m = e.right_distance_m();
  ego.offset_rate_mps = e.offset_rate_mps();
  ego.departing = e.departing();
  return ego;
}

const std::vector<const google::protobuf::FieldDescriptor*>& StageTimingFields() {
  // Found once by name: the detector's stage table names the fields.
  static const std::vector<const google::protobuf::FieldDescriptor*> fields = [] {
    std::vector<const google::protobuf::FieldDescriptor*> out;
    const google::protobuf::Descriptor* d = v1::StageTimings::descriptor();
    for (size_t i = 0; i < lane::DetectorStageCount(); ++i) {
      out.push_back(d->FindFieldByName(absl::StrCat(lane::DetectorStageName(i), "_ms")));
    }
    return out;
  }();
  return fields;
}

void TimingsToProto(const lane::StageTimings& timings, v1::StageTimings* out) {
  const google::protobuf::Reflection* reflection = out->GetReflection();
  const std::vector<const google::protobuf::FieldDescriptor*>& fields = StageTimingFields();
  for (size_t i = 0; i < fields.size(); ++i) {
    if (fields[i] != nullptr) reflection->SetDouble(out, fields[i], timings.stage_ms[i]);
  }
  out->set_detect_ms(timings.total_ms);
}

lane::StageTimings TimingsFromProto(const v1::StageTimings& timings) {
  lane::StageTimings out;
  const google::protobuf::Reflection* reflection = timings.GetReflection();
  const std::vector<const google::protobuf::FieldDescriptor*>& fields = StageTimingFields();
  for (size_t i = 0; i < fields.size(); ++i) {
    if (fields[i] == nullptr) continue;
    out.stage_ms[i] = reflection->GetDouble(timings, fields[i]);
    out.ran[i] = out.stage_ms[i] > 0;
  }
  out.total_ms = timings.detect_ms();
  return out;
}

}  // namespace lane::wire
