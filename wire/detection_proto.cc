#include "wire/detection_proto.h"

#include <google/protobuf/descriptor.h>

#include "absl/strings/str_cat.h"

namespace lane::wire {
namespace {

v1::Bezier BezierToProto(const std::array<Eigen::Vector2d, 4>& points) {
  v1::Bezier out;
  out.mutable_control_points()->Reserve(4);
  for (const Eigen::Vector2d& p : points) {
    v1::Point2* q = out.add_control_points();
    q->set_x(p.x());
    q->set_y(p.y());
  }
  return out;
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

lane::MarkingType TypeFromProto(v1::MarkingType t) {
  // MarkingType's order is the proto's.
  return t >= v1::MARKING_TYPE_UNKNOWN && t <= v1::MARKING_TYPE_ROAD_EDGE
             ? static_cast<lane::MarkingType>(static_cast<int>(t))
             : lane::MarkingType::kUnknown;
}

v1::Lane LaneToProto(const lane::Lane& lane) {
  v1::Lane l;
  *l.mutable_image() = BezierToProto(lane.image);
  *l.mutable_ipm() = BezierToProto(lane.ipm);
  *l.mutable_ground() = BezierToProto(lane.ground);
  l.set_score(lane.score);
  l.set_inferred(lane.inferred);
  l.set_refit(lane.refit);
  return l;
}

v1::Lane LaneToProto(const lane::TrackedLane& tracked) {
  v1::Lane l = LaneToProto(tracked.lane);
  l.set_id(tracked.id > 0 ? tracked.id : 0);
  l.set_confirmed(tracked.confirmed);
  l.set_predicted(tracked.predicted);
  l.set_color(ColorToProto(tracked.color));
  l.set_type(static_cast<v1::MarkingType>(static_cast<int>(tracked.type)));
  return l;
}

v1::EgoLane EgoToProto(const lane::EgoLane& ego) {
  v1::EgoLane e;
  e.set_offset_m(ego.offset_m);
  e.set_width_m(ego.width_m);
  e.set_heading_deg(ego.heading_deg);
  e.set_curvature_per_m(ego.curvature_per_m);
  e.set_left_lane_id(ego.left_id > 0 ? ego.left_id : 0);
  e.set_right_lane_id(ego.right_id > 0 ? ego.right_id : 0);
  e.set_left_distance_m(ego.left_distance_m);
  e.set_right_distance_m(ego.right_distance_m);
  e.set_offset_rate_mps(ego.offset_rate_mps);
  e.set_departing(ego.departing);
  return e;
}

lane::Lane LaneFromProto(const v1::Lane& l) {
  lane::Lane lane;
  lane.image = BezierFromProto(l.image());
  lane.ipm = BezierFromProto(l.ipm());
  lane.ground = BezierFromProto(l.ground());
  lane.score = l.score();
  lane.inferred = l.inferred();
  lane.refit = l.refit();
  return lane;
}

}  // namespace

v1::FrameResponse LanesToProto(const lane::Detection& detection) {
  v1::FrameResponse out;
  out.mutable_lanes()->Reserve(static_cast<int>(detection.lanes.size()));
  for (const lane::Lane& lane : detection.lanes) out.mutable_lanes()->Add(LaneToProto(lane));
  return out;
}

v1::FrameResponse LanesToProto(const lane::TrackedFrame& frame) {
  v1::FrameResponse out;
  out.mutable_lanes()->Reserve(static_cast<int>(frame.lanes.size()));
  for (const lane::TrackedLane& lane : frame.lanes) out.mutable_lanes()->Add(LaneToProto(lane));
  if (frame.ego) *out.mutable_ego() = EgoToProto(*frame.ego);
  return out;
}

std::vector<lane::TrackedLane> LanesFromProto(const v1::FrameResponse& response) {
  std::vector<lane::TrackedLane> lanes;
  lanes.reserve(static_cast<size_t>(response.lanes_size()));
  for (const v1::Lane& l : response.lanes()) {
    lane::TrackedLane& lane = lanes.emplace_back();
    lane.lane = LaneFromProto(l);
    lane.id = l.id() > 0 ? l.id() : -1;
    lane.confirmed = l.confirmed();
    lane.predicted = l.predicted();
    lane.color = ColorFromProto(l.color());
    lane.type = TypeFromProto(l.type());
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
  for (int i = response.lanes_size() - 1; i >= 0; --i) {
    const int id = response.lanes(i).id();
    if (id <= 0) continue;
    if (id == e.left_lane_id()) ego.left_index = i;
    if (id == e.right_lane_id()) ego.right_index = i;
  }
  return ego;
}

lane::TrackedFrame TrackedFrameFromProto(const v1::FrameResponse& response) {
  lane::TrackedFrame frame;
  frame.lanes = LanesFromProto(response);
  frame.ego = EgoFromProto(response);
  for (const lane::TrackedLane& lane : frame.lanes) {
    if (lane.predicted) continue;
    frame.detection.lanes.push_back(lane.lane);
    frame.detection.refit_lanes += lane.lane.refit ? 1 : 0;
  }
  frame.detection.timings = TimingsFromProto(response.timings());
  return frame;
}

lane::Detection DetectionFromProto(const v1::FrameResponse& response) {
  lane::Detection detection;
  detection.lanes.reserve(static_cast<size_t>(response.lanes_size()));
  for (const v1::Lane& l : response.lanes()) {
    detection.lanes.push_back(LaneFromProto(l));
    detection.refit_lanes += l.refit() ? 1 : 0;
  }
  detection.timings = TimingsFromProto(response.timings());
  return detection;
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

v1::StageTimings TimingsToProto(const lane::StageTimings& timings) {
  v1::StageTimings out;
  const google::protobuf::Reflection* reflection = out.GetReflection();
  const std::vector<const google::protobuf::FieldDescriptor*>& fields = StageTimingFields();
  for (size_t i = 0; i < fields.size(); ++i) {
    if (fields[i] != nullptr) reflection->SetDouble(&out, fields[i], timings.stage_ms[i]);
  }
  out.set_detect_ms(timings.total_ms);
  return out;
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
