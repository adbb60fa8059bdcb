#include "convert.h"

#include <string>

#include "absl/strings/str_cat.h"
#include "status_map.h"

namespace lane::server {
namespace {

// The proto messages name their fields as the core structs do, so a field is
// copied by name. Unset `optional` fields keep the struct's value.
#define LANE_COPY_IF_SET(from, to, field) \
  if ((from).has_##field()) (to).field = (from).field()
#define LANE_SET(to, from, field) (to)->set_##field((from).field)

absl::StatusOr<lane::Mode> ModeFromProto(v1::Mode mode) {
  switch (mode) {
    case v1::MODE_UNSPECIFIED:
    case v1::MODE_ALL:
      return lane::Mode::kAll;
    case v1::MODE_TWO:
      return lane::Mode::kTwo;
    default:
      return InvalidRequest(absl::StrCat("detector.mode: unknown value ", mode));
  }
}

v1::Mode ModeToProto(lane::Mode mode) {
  return mode == lane::Mode::kTwo ? v1::MODE_TWO : v1::MODE_ALL;
}

absl::StatusOr<lane::Channel> ChannelFromProto(v1::Channel channel) {
  switch (channel) {
    case v1::CHANNEL_UNSPECIFIED:
    case v1::CHANNEL_RED:
      return lane::Channel::kRed;
    case v1::CHANNEL_GREEN:
      return lane::Channel::kGreen;
    case v1::CHANNEL_BLUE:
      return lane::Channel::kBlue;
    case v1::CHANNEL_GRAY:
      return lane::Channel::kGray;
    case v1::CHANNEL_MIN_RED_GREEN:
      return lane::Channel::kMinRedGreen;
    default:
      return InvalidRequest(absl::StrCat("detector.channel: unknown value ", channel));
  }
}

v1::Channel ChannelToProto(lane::Channel channel) {
  switch (channel) {
    case lane::Channel::kRed:
      return v1::CHANNEL_RED;
    case lane::Channel::kGreen:
      return v1::CHANNEL_GREEN;
    case lane::Channel::kBlue:
      return v1::CHANNEL_BLUE;
    case lane::Channel::kGray:
      return v1::CHANNEL_GRAY;
    case lane::Channel::kMinRedGreen:
      return v1::CHANNEL_MIN_RED_GREEN;
  }
  return v1::CHANNEL_RED;
}

void CameraFromProto(const v1::CameraCalibration& p, lane::CameraModel& c) {
  LANE_COPY_IF_SET(p, c, fu);
  LANE_COPY_IF_SET(p, c, fv);
  LANE_COPY_IF_SET(p, c, cu);
  LANE_COPY_IF_SET(p, c, cv);
  LANE_COPY_IF_SET(p, c, pitch_deg);
  LANE_COPY_IF_SET(p, c, yaw_deg);
  LANE_COPY_IF_SET(p, c, height_m);
  LANE_COPY_IF_SET(p, c, image_width);
  LANE_COPY_IF_SET(p, c, image_height);
}

absl::Status IpmFromProto(const v1::IpmOptions& p, lane::IpmOptions& o) {
  LANE_COPY_IF_SET(p, o, width);
  LANE_COPY_IF_SET(p, o, height);
  LANE_COPY_IF_SET(p.roi(), o.roi, left);
  LANE_COPY_IF_SET(p.roi(), o.roi, right);
  LANE_COPY_IF_SET(p.roi(), o.roi, top);
  LANE_COPY_IF_SET(p.roi(), o.roi, bottom);
  LANE_COPY_IF_SET(p, o, horizon_margin_px);
  switch (p.interpolation()) {
    case v1::INTERPOLATION_UNSPECIFIED:
      break;
    case v1::INTERPOLATION_NEAREST:
      o.interpolation = lane::Interpolation::kNearest;
      break;
    case v1::INTERPOLATION_BILINEAR:
      o.interpolation = lane::Interpolation::kBilinear;
      break;
    case v1::INTERPOLATION_AREA:
      o.interpolation = lane::Interpolation::kArea;
      break;
    default:
      return InvalidRequest(absl::StrCat("ipm.interpolation: unknown value ", p.interpolation()));
  }
  const v1::GroundView& g = p.ground();
  LANE_COPY_IF_SET(g, o.ground, x_min_m);
  LANE_COPY_IF_SET(g, o.ground, x_max_m);
  LANE_COPY_IF_SET(g, o.ground, y_min_m);
  LANE_COPY_IF_SET(g, o.ground, y_max_m);
  LANE_COPY_IF_SET(g, o.ground, metres_per_px_x);
  LANE_COPY_IF_SET(g, o.ground, metres_per_px_y);
  switch (p.view()) {
    case v1::IPM_VIEW_UNSPECIFIED:
      if (p.has_ground()) o.view = lane::IpmView::kGround;
      break;
    case v1::IPM_VIEW_ROI:
      o.view = lane::IpmView::kRoi;
      break;
    case v1::IPM_VIEW_GROUND:
      o.view = lane::IpmView::kGround;
      break;
    default:
      return InvalidRequest(absl::StrCat("ipm.view: unknown value ", p.view()));
  }
  return absl::OkStatus();
}

absl::Status DetectorFromProto(const v1::DetectorOptions& p, lane::DetectorOptions& o) {
  absl::StatusOr<lane::Mode> mode = ModeFromProto(p.mode());
  if (!mode.ok()) return mode.status();
  absl::StatusOr<lane::Channel> channel = ChannelFromProto(p.channel());
  if (!channel.ok()) return channel.status();
  // The mode's defaults first, as lane::ParseConfig does.
  o = lane::DetectorOptions::ForMode(*mode);
  if (p.channel() != v1::CHANNEL_UNSPECIFIED) o.channel = *channel;

  const v1::FilterOptions& f = p.filter();
  LANE_COPY_IF_SET(f, o.filter, marking_width_m);
  LANE_COPY_IF_SET(f, o.filter, segment_length_m);
  LANE_COPY_IF_SET(f, o.filter, min_sigma_x_px);
  LANE_COPY_IF_SET(f, o.filter, min_sigma_y_px);
  LANE_COPY_IF_SET(f, o.filter, kernel_extent_sigmas);
  LANE_COPY_IF_SET(f, o.filter, zero_border_x_px);
  LANE_COPY_IF_SET(f, o.filter, zero_border_bottom_px);
  LANE_COPY_IF_SET(f, o.filter, bar_side_m);
  LANE_COPY_IF_SET(f, o.filter, void_level);
  LANE_COPY_IF_SET(f, o.filter, void_margin_y_px);

  LANE_COPY_IF_SET(p.threshold(), o.threshold, quantile);
  LANE_COPY_IF_SET(p.threshold(), o.threshold, transverse_max_fraction);
  LANE_COPY_IF_SET(p.threshold(), o.threshold, transverse_margin_m);

  const v1::HoughOptions& h = p.hough();
  LANE_COPY_IF_SET(h, o.hough, smooth_sigma_px);
  LANE_COPY_IF_SET(h, o.hough, min_peak);
  LANE_COPY_IF_SET(h, o.hough, group_distance_m);

  const v1::LineRansacOptions& l = p.line_ransac();
  LANE_COPY_IF_SET(l, o.line_ransac, window_half_width_m);
  LANE_COPY_IF_SET(l, o.line_ransac, iterations);
  LANE_COPY_IF_SET(l, o.line_ransac, inlier_distance_px);
  LANE_COPY_IF_SET(l, o.line_ransac, min_inliers);
  LANE_COPY_IF_SET(l, o.line_ransac, max_angle_from_vertical_deg);

  const v1::SplineRansacOptions& s = p.spline_ransac();
  LANE_COPY_IF_SET(s, o.spline_ransac, window_half_width_m);
  LANE_COPY_IF_SET(s, o.spline_ransac, iterations);
  LANE_COPY_IF_SET(s, o.spline_ransac, k1);
  LANE_COPY_IF_SET(s, o.spline_ransac, k2);
  LANE_COPY_IF_SET(s, o.spline_ransac, jitter_px);
  LANE_COPY_IF_SET(s, o.spline_ransac, merge_distance_px);

  const v1::PostprocessOptions& pp = p.postprocess();
  lane::PostprocessOptions& po = o.postprocess;
  LANE_COPY_IF_SET(pp, po, ipm_max_angle_from_vertical_deg);
  LANE_COPY_IF_SET(pp, po, min_straightness);
  LANE_COPY_IF_SET(pp, po, min_length_fraction);
  LANE_COPY_IF_SET(pp, po, ipm_extend_step_px);
  LANE_COPY_IF_SET(pp, po, ipm_normal_search_px);
  LANE_COPY_IF_SET(pp, po, backproject_samples);
  LANE_COPY_IF_SET(pp, po, localize_points);
  LANE_COPY_IF_SET(pp, po, localize_search_px);
  LANE_COPY_IF_SET(pp, po, profile_sigma_px);
  LANE_COPY_IF_SET(pp, po, localize_min_cos);
  LANE_COPY_IF_SET(pp, po, extend_step_px);
  LANE_COPY_IF_SET(pp, po, extend_search_px);
  LANE_COPY_IF_SET(pp, po, continuation_threshold);
  LANE_COPY_IF_SET(pp, po, extend_min_cos_up);
  LANE_COPY_IF_SET(pp, po, extend_min_cos_down);
  LANE_COPY_IF_SET(pp, po, extend_min_row);
  LANE_COPY_IF_SET(pp, po, extend_max_row);
  LANE_COPY_IF_SET(pp, po, min_image_length_px);
  LANE_COPY_IF_SET(pp, po, side_offset_m);
  LANE_COPY_IF_SET(pp, po, min_side_contrast);
  LANE_COPY_IF_SET(pp, po, localize_in_image);
  LANE_COPY_IF_SET(pp, po, extend_in_image);
  LANE_COPY_IF_SET(pp, po, extend_in_ipm);
  LANE_COPY_IF_SET(pp, po, extend_geometric);
  LANE_COPY_IF_SET(pp, po, extend_search_m);
  LANE_COPY_IF_SET(pp, po, extend_gap_m);
  LANE_COPY_IF_SET(pp, po, extend_to_max_row);
  LANE_COPY_IF_SET(pp, po, localize_geometric);
  LANE_COPY_IF_SET(pp, po, localize_search_m);
  LANE_COPY_IF_SET(pp, po, localize_sigma_m);
  LANE_COPY_IF_SET(pp, po, clip_to_image);
  LANE_COPY_IF_SET(pp, po, check_ground_angle);
  LANE_COPY_IF_SET(pp, po, min_ray_angle_deg);
  LANE_COPY_IF_SET(pp, po, max_ray_bend_m);
  LANE_COPY_IF_SET(pp, po, max_bright_side_fraction);
  LANE_COPY_IF_SET(pp, po, max_redness);

  const v1::TwoLaneOptions& t = p.two_lanes();
  LANE_COPY_IF_SET(t, o.two_lanes, search_half_width_m);
  LANE_COPY_IF_SET(t, o.two_lanes, lane_width_m);
  LANE_COPY_IF_SET(t, o.two_lanes, lane_width_sigma_m);
  LANE_COPY_IF_SET(t, o.two_lanes, min_pair_score);

  LANE_COPY_IF_SET(p, o, seed);
  return absl::OkStatus();
}

void BezierToProto(const std::array<Eigen::Vector2d, 4>& points, v1::Bezier* out) {
  out->mutable_control_points()->Reserve(4);
  for (const Eigen::Vector2d& p : points) {
    v1::Point2* q = out->add_control_points();
    q->set_x(p.x());
    q->set_y(p.y());
  }
}

}  // namespace

absl::StatusOr<lane::Config> ConfigFromProto(const v1::SessionConfig& proto) {
  absl::StatusOr<lane::Config> config;
  if (!proto.config_json().empty()) {
    if (proto.has_camera() || proto.has_ipm() || proto.has_detector()) {
      return InvalidRequest(
          "session config: config_json and camera/ipm/detector are alternatives; set one");
    }
    config = lane::ParseConfig(proto.config_json());
    if (!config.ok()) {
      return InvalidRequest(
          absl::StrCat("session config: config_json: ", config.status().message()));
    }
  } else {
    config = lane::Config{};
    CameraFromProto(proto.camera(), config->camera);
    if (absl::Status s = IpmFromProto(proto.ipm(), config->ipm); !s.ok()) return s;
    if (absl::Status s = DetectorFromProto(proto.detector(), config->detector); !s.ok()) return s;
  }
  // The server never returns intermediate images.
  config->detector.keep_intermediates = false;
  if (absl::Status s = config->Validate(); !s.ok()) {
    return InvalidRequest(absl::StrCat("session config: ", s.message()));
  }
  return config;
}

void ConfigToProto(const lane::Config& config, v1::SessionConfig* out) {
  v1::CameraCalibration* cam = out->mutable_camera();
  const lane::CameraModel& c = config.camera;
  LANE_SET(cam, c, fu);
  LANE_SET(cam, c, fv);
  LANE_SET(cam, c, cu);
  LANE_SET(cam, c, cv);
  LANE_SET(cam, c, pitch_deg);
  LANE_SET(cam, c, yaw_deg);
  LANE_SET(cam, c, height_m);
  LANE_SET(cam, c, image_width);
  LANE_SET(cam, c, image_height);

  v1::IpmOptions* ipm = out->mutable_ipm();
  const lane::IpmOptions& i = config.ipm;
  LANE_SET(ipm, i, width);
  LANE_SET(ipm, i, height);
  v1::Roi* roi = ipm->mutable_roi();
  LANE_SET(roi, i.roi, left);
  LANE_SET(roi, i.roi, right);
  LANE_SET(roi, i.roi, top);
  LANE_SET(roi, i.roi, bottom);
  LANE_SET(ipm, i, horizon_margin_px);
  switch (i.interpolation) {
    case lane::Interpolation::kNearest:
      ipm->set_interpolation(v1::INTERPOLATION_NEAREST);
      break;
    case lane::Interpolation::kBilinear:
      ipm->set_interpolation(v1::INTERPOLATION_BILINEAR);
      break;
    case lane::Interpolation::kArea:
      ipm->set_interpolation(v1::INTERPOLATION_AREA);
      break;
  }
  ipm->set_view(i.view == lane::IpmView::kGround ? v1::IPM_VIEW_GROUND : v1::IPM_VIEW_ROI);
  v1::GroundView* g = ipm->mutable_ground();
  LANE_SET(g, i.ground, x_min_m);
  LANE_SET(g, i.ground, x_max_m);
  LANE_SET(g, i.ground, y_min_m);
  LANE_SET(g, i.ground, y_max_m);
  LANE_SET(g, i.ground, metres_per_px_x);
  LANE_SET(g, i.ground, metres_per_px_y);

  v1::DetectorOptions* det = out->mutable_detector();
  const lane::DetectorOptions& d = config.detector;
  det->set_mode(ModeToProto(d.mode));
  det->set_channel(ChannelToProto(d.channel));

  v1::FilterOptions* f = det->mutable_filter();
  LANE_SET(f, d.filter, marking_width_m);
  LANE_SET(f, d.filter, segment_length_m);
  LANE_SET(f, d.filter, min_sigma_x_px);
  LANE_SET(f, d.filter, min_sigma_y_px);
  LANE_SET(f, d.filter, kernel_extent_sigmas);
  LANE_SET(f, d.filter, zero_border_x_px);
  LANE_SET(f, d.filter, zero_border_bottom_px);
  LANE_SET(f, d.filter, bar_side_m);
  LANE_SET(f, d.filter, void_level);
  LANE_SET(f, d.filter, void_margin_y_px);

  v1::ThresholdOptions* th = det->mutable_threshold();
  LANE_SET(th, d.threshold, quantile);
  LANE_SET(th, d.threshold, transverse_max_fraction);
  LANE_SET(th, d.threshold, transverse_margin_m);

  v1::HoughOptions* h = det->mutable_hough();
  LANE_SET(h, d.hough, smooth_sigma_px);
  LANE_SET(h, d.hough, min_peak);
  LANE_SET(h, d.hough, group_distance_m);

  v1::LineRansacOptions* l = det->mutable_line_ransac();
  LANE_SET(l, d.line_ransac, window_half_width_m);
  LANE_SET(l, d.line_ransac, iterations);
  LANE_SET(l, d.line_ransac, inlier_distance_px);
  LANE_SET(l, d.line_ransac, min_inliers);
  LANE_SET(l, d.line_ransac, max_angle_from_vertical_deg);

  v1::SplineRansacOptions* s = det->mutable_spline_ransac();
  LANE_SET(s, d.spline_ransac, window_half_width_m);
  LANE_SET(s, d.spline_ransac, iterations);
  LANE_SET(s, d.spline_ransac, k1);
  LANE_SET(s, d.spline_ransac, k2);
  LANE_SET(s, d.spline_ransac, jitter_px);
  LANE_SET(s, d.spline_ransac, merge_distance_px);

  v1::PostprocessOptions* pp = det->mutable_postprocess();
  const lane::PostprocessOptions& po = d.postprocess;
  LANE_SET(pp, po, ipm_max_angle_from_vertical_deg);
  LANE_SET(pp, po, min_straightness);
  LANE_SET(pp, po, min_length_fraction);
  LANE_SET(pp, po, ipm_extend_step_px);
  LANE_SET(pp, po, ipm_normal_search_px);
  LANE_SET(pp, po, backproject_samples);
  LANE_SET(pp, po, localize_points);
  LANE_SET(pp, po, localize_search_px);
  LANE_SET(pp, po, profile_sigma_px);
  LANE_SET(pp, po, localize_min_cos);
  LANE_SET(pp, po, extend_step_px);
  LANE_SET(pp, po, extend_search_px);
  LANE_SET(pp, po, continuation_threshold);
  LANE_SET(pp, po, extend_min_cos_up);
  LANE_SET(pp, po, extend_min_cos_down);
  LANE_SET(pp, po, extend_min_row);
  LANE_SET(pp, po, extend_max_row);
  LANE_SET(pp, po, min_image_length_px);
  LANE_SET(pp, po, side_offset_m);
  LANE_SET(pp, po, min_side_contrast);
  LANE_SET(pp, po, localize_in_image);
  LANE_SET(pp, po, extend_in_image);
  LANE_SET(pp, po, extend_in_ipm);
  LANE_SET(pp, po, extend_geometric);
  LANE_SET(pp, po, extend_search_m);
  LANE_SET(pp, po, extend_gap_m);
  LANE_SET(pp, po, extend_to_max_row);
  LANE_SET(pp, po, localize_geometric);
  LANE_SET(pp, po, localize_search_m);
  LANE_SET(pp, po, localize_sigma_m);
  LANE_SET(pp, po, clip_to_image);
  LANE_SET(pp, po, check_ground_angle);
  LANE_SET(pp, po, min_ray_angle_deg);
  LANE_SET(pp, po, max_ray_bend_m);
  LANE_SET(pp, po, max_bright_side_fraction);
  LANE_SET(pp, po, max_redness);

  v1::TwoLaneOptions* t = det->mutable_two_lanes();
  LANE_SET(t, d.two_lanes, search_half_width_m);
  LANE_SET(t, d.two_lanes, lane_width_m);
  LANE_SET(t, d.two_lanes, lane_width_sigma_m);
  LANE_SET(t, d.two_lanes, min_pair_score);

  det->set_seed(d.seed);
}

#undef LANE_COPY_IF_SET
#undef LANE_SET

absl::StatusOr<StreamPolicy> StreamPolicyFromProto(const v1::StreamOptions& proto) {
  StreamPolicy policy;
  switch (proto.backpressure()) {
    case v1::BACKPRESSURE_UNSPECIFIED:
    case v1::BACKPRESSURE_BLOCK:
      policy.backpressure = Backpressure::kBlock;
      break;
    case v1::BACKPRESSURE_DROP_OLDEST:
      policy.backpressure = Backpressure::kDropOldest;
      break;
    default:
      return InvalidRequest(
          absl::StrCat("stream.backpressure: unknown value ", proto.backpressure()));
  }
  policy.max_inflight_frames = proto.max_inflight_frames();
  return policy;
}

void StreamPolicyToProto(const StreamPolicy& policy, v1::StreamOptions* out) {
  out->set_backpressure(policy.backpressure == Backpressure::kDropOldest
                            ? v1::BACKPRESSURE_DROP_OLDEST
                            : v1::BACKPRESSURE_BLOCK);
  out->set_max_inflight_frames(policy.max_inflight_frames);
}

absl::StatusOr<SessionSpec> SessionSpecFromProto(const v1::SessionConfig& proto) {
  absl::StatusOr<lane::Config> config = ConfigFromProto(proto);
  if (!config.ok()) return config.status();
  absl::StatusOr<StreamPolicy> stream = StreamPolicyFromProto(proto.stream());
  if (!stream.ok()) return stream.status();
  return SessionSpec{*std::move(config), *stream};
}

void SessionToProto(const Session& session, absl::Time last_used, v1::Session* out) {
  out->set_camera_id(session.camera_id);
  out->set_version(session.version);
  ConfigToProto(session.config, out->mutable_config());
  StreamPolicyToProto(session.stream, out->mutable_config()->mutable_stream());
  out->set_create_time_unix_ns(absl::ToUnixNanos(session.create_time));
  out->set_last_used_unix_ns(absl::ToUnixNanos(last_used));
  out->set_frames_processed(session.frames_processed.load(std::memory_order_relaxed));
}

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

}  // namespace lane::server
