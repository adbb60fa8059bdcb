#include "wire/detection_proto.h"

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

}  // namespace

void LanesToProto(const lane::Detection& detection, v1::FrameResponse* out) {
  out->mutable_lanes()->Reserve(static_cast<int>(detection.lanes.size()));
  for (const lane::Lane& lane : detection.lanes) {
    v1::Lane* l = out->add_lanes();
    BezierToProto(lane.image, l->mutable_image());
    BezierToProto(lane.ipm, l->mutable_ipm());
    BezierToProto(lane.ground, l->mutable_ground());
    l->set_score(lane.score);
  }
}

void TimingsToProto(const lane::StageTimings& timings, v1::StageTimings* out) {
  out->set_ipm_ms(timings.ipm_ms);
  out->set_filter_ms(timings.filter_ms);
  out->set_threshold_ms(timings.threshold_ms);
  out->set_lines_ms(timings.lines_ms);
  out->set_splines_ms(timings.splines_ms);
  out->set_postprocess_ms(timings.postprocess_ms);
  out->set_detect_ms(timings.total_ms);
}

}  // namespace lane::wire
