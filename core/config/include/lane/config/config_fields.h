// The configuration's schema, written once: for every options struct the
// list of its fields with their names, and for every enum its names. The
// config file's reader and writer and the service's protobuf conversion walk
// these lists, so a new option is one line here (plus its proto field, which
// a test checks by name).
//
// A visitor V provides
//   v.Field(name, member)    for numbers, booleans and enums;
//   v.Section(name, member)  for nested structs (which have a list here too);
//   v.List(name, member)     for a std::vector of such structs (a JSON array
//                            of objects, a repeated message field).
#ifndef LANE_CONFIG_FIELDS_H_
#define LANE_CONFIG_FIELDS_H_

#include <optional>
#include <string>
#include <type_traits>

#include "lane/config/config.h"

namespace lane {

// ---------------------------------------------------------------------------
// The field lists: the ONLY place that names the keys of each struct. The
// JSON reader and writer (config.cc) and the protobuf conversion of the
// service (wire/config_proto.cc, which finds each proto field by this name)
// walk them. A visitor V provides
//   v.Field(name, member)    for numbers, booleans and enums;
//   v.Section(name, member)  for nested structs (which have a list here too);
//   v.List(name, member)     for a std::vector of such structs.
// S is the struct or the const struct (the writer only reads).
#define LANE_FIELDS(Type)     \
  template <class S, class V> \
  std::enable_if_t<std::is_same_v<std::remove_const_t<S>, Type>> VisitFields(S& s, V& v)

LANE_FIELDS(CameraModel) {
  v.Field("fu", s.fu);
  v.Field("fv", s.fv);
  v.Field("cu", s.cu);
  v.Field("cv", s.cv);
  v.Field("pitch_deg", s.pitch_deg);
  v.Field("yaw_deg", s.yaw_deg);
  v.Field("height_m", s.height_m);
  v.Field("image_width", s.image_width);
  v.Field("image_height", s.image_height);
}

LANE_FIELDS(Roi) {
  v.Field("left", s.left);
  v.Field("right", s.right);
  v.Field("top", s.top);
  v.Field("bottom", s.bottom);
}

LANE_FIELDS(GroundView) {
  v.Field("x_min_m", s.x_min_m);
  v.Field("x_max_m", s.x_max_m);
  v.Field("y_min_m", s.y_min_m);
  v.Field("y_max_m", s.y_max_m);
  v.Field("metres_per_px_x", s.metres_per_px_x);
  v.Field("metres_per_px_y", s.metres_per_px_y);
}

// `view` is also set before everything else by ConfigFromJson: a "ground"
// section without "view" selects the ground view.
LANE_FIELDS(IpmOptions) {
  v.Field("view", s.view);
  v.Section("ground", s.ground);
  v.Field("width", s.width);
  v.Field("height", s.height);
  v.Section("roi", s.roi);
  v.Field("horizon_margin_px", s.horizon_margin_px);
  v.Field("interpolation", s.interpolation);
  v.List("static_mask", s.static_mask);
}

LANE_FIELDS(FilterOptions) {
  v.Field("marking_width_m", s.marking_width_m);
  v.Field("segment_length_m", s.segment_length_m);
  v.Field("min_sigma_x_px", s.min_sigma_x_px);
  v.Field("min_sigma_y_px", s.min_sigma_y_px);
  v.Field("kernel_extent_sigmas", s.kernel_extent_sigmas);
  v.Field("zero_border_x_px", s.zero_border_x_px);
  v.Field("zero_border_bottom_px", s.zero_border_bottom_px);
  v.Field("bar_side_m", s.bar_side_m);
  v.Field("void_level", s.void_level);
  v.Field("void_margin_y_px", s.void_margin_y_px);
}

LANE_FIELDS(ThresholdOptions) {
  v.Field("quantile", s.quantile);
  v.Field("transverse_max_fraction", s.transverse_max_fraction);
  v.Field("transverse_margin_m", s.transverse_margin_m);
}

LANE_FIELDS(HoughOptions) {
  v.Field("smooth_sigma_px", s.smooth_sigma_px);
  v.Field("min_peak", s.min_peak);
  v.Field("group_distance_m", s.group_distance_m);
}

LANE_FIELDS(LineRansacOptions) {
  v.Field("window_half_width_m", s.window_half_width_m);
  v.Field("iterations", s.ransac.iterations);
  v.Field("confidence", s.ransac.confidence);
  v.Field("min_iterations", s.ransac.min_iterations);
  v.Field("inlier_distance_px", s.inlier_distance_px);
  v.Field("min_inliers", s.min_inliers);
  v.Field("max_angle_from_vertical_deg", s.max_angle_from_vertical_deg);
}

LANE_FIELDS(SplineRansacOptions) {
  v.Field("window_half_width_m", s.window_half_width_m);
  v.Field("iterations", s.ransac.iterations);
  v.Field("confidence", s.ransac.confidence);
  v.Field("min_iterations", s.ransac.min_iterations);
  v.Field("k1", s.k1);
  v.Field("k2", s.k2);
  v.Field("jitter_px", s.jitter_px);
  v.Field("merge_distance_px", s.merge_distance_px);
}

LANE_FIELDS(PostprocessOptions) {
  v.Field("ipm_max_angle_from_vertical_deg", s.ipm_max_angle_from_vertical_deg);
  v.Field("min_straightness", s.min_straightness);
  v.Field("min_length_fraction", s.min_length_fraction);
  v.Field("side_offset_m", s.side_offset_m);
  v.Field("min_side_contrast", s.min_side_contrast);
  v.Field("min_bar_fraction", s.min_bar_fraction);
  v.Field("min_ray_angle_deg", s.min_ray_angle_deg);
  v.Field("max_ray_bend_m", s.max_ray_bend_m);
  v.Field("max_bright_side_fraction", s.max_bright_side_fraction);
  v.Field("ipm_extend_step_px", s.ipm_extend_step_px);
  v.Field("ipm_normal_search_px", s.ipm_normal_search_px);
  v.Field("backproject_samples", s.backproject_samples);
  v.Field("localize_points", s.localize_points);
  v.Field("localize_search_px", s.localize_search_px);
  v.Field("profile_sigma_px", s.profile_sigma_px);
  v.Field("localize_min_cos", s.localize_min_cos);
  v.Field("extend_step_px", s.extend_step_px);
  v.Field("extend_search_px", s.extend_search_px);
  v.Field("continuation_threshold", s.continuation_threshold);
  v.Field("extend_min_cos_up", s.extend_min_cos_up);
  v.Field("extend_min_cos_down", s.extend_min_cos_down);
  v.Field("extend_min_row", s.extend_min_row);
  v.Field("extend_max_row", s.extend_max_row);
  v.Field("localize_search_m", s.localize_search_m);
  v.Field("localize_on_bars", s.localize_on_bars);
  v.Field("localize_only_coarse_top_view", s.localize_only_coarse_top_view);
  v.Field("localize_sigma_m", s.localize_sigma_m);
  v.Field("extend_search_m", s.extend_search_m);
  v.Field("extend_gap_m", s.extend_gap_m);
  v.Field("extend_to_max_row", s.extend_to_max_row);
  v.Field("clip_to_image", s.clip_to_image);
  v.Field("check_ground_angle", s.check_ground_angle);
  v.Field("max_redness", s.max_redness);
  v.Field("min_image_length_px", s.min_image_length_px);
  v.Field("localize_in_image", s.localize_in_image);
  v.Field("extend_in_image", s.extend_in_image);
  v.Field("extend_in_ipm", s.extend_in_ipm);
}

LANE_FIELDS(TwoLaneOptions) {
  v.Field("search_half_width_m", s.search_half_width_m);
  v.Field("lane_width_m", s.lane_width_m);
  v.Field("lane_width_sigma_m", s.lane_width_sigma_m);
  v.Field("min_pair_score", s.min_pair_score);
}

LANE_FIELDS(RoadModelOptions) {
  v.Field("infer_hidden", s.infer_hidden);
  v.Field("search_hidden", s.search_hidden);
  v.Field("search_outer", s.search_outer);
  v.Field("search_half_width_m", s.search_half_width_m);
  v.Field("search_quantile", s.search_quantile);
  v.Field("search_min_fraction", s.search_min_fraction);
  v.Field("min_lane_width_m", s.min_lane_width_m);
  v.Field("max_lane_width_m", s.max_lane_width_m);
  v.Field("width_tolerance", s.width_tolerance);
  v.Field("max_gap_change_m", s.max_gap_change_m);
  v.Field("min_overlap_m", s.min_overlap_m);
}

// `mode` is also applied before everything else by ConfigFromJson.
// keep_intermediates is a debugging switch of the API, not configuration.
LANE_FIELDS(DetectorOptions) {
  v.Field("mode", s.mode);
  v.Field("channel", s.channel);
  v.Field("seed", s.seed);
  v.Section("filter", s.filter);
  v.Section("threshold", s.threshold);
  v.Section("hough", s.hough);
  v.Section("line_ransac", s.line_ransac);
  v.Section("spline_ransac", s.spline_ransac);
  v.Section("postprocess", s.postprocess);
  v.Section("two_lanes", s.two_lanes);
  v.Section("road_model", s.road_model);
}

LANE_FIELDS(Config) {
  v.Section("camera", s.camera);
  v.Section("ipm", s.ipm);
  v.Section("detector", s.detector);
}

#undef LANE_FIELDS

// ---------------------------------------------------------------------------
// Enums <-> names.

inline const char* InterpolationName(Interpolation interpolation) {
  switch (interpolation) {
    case Interpolation::kNearest:
      return "nearest";
    case Interpolation::kBilinear:
      return "bilinear";
    case Interpolation::kArea:
      return "area";
  }
  return "bilinear";
}

inline std::optional<Interpolation> ParseInterpolation(const std::string& name) {
  if (name == "nearest") return Interpolation::kNearest;
  if (name == "bilinear") return Interpolation::kBilinear;
  if (name == "area") return Interpolation::kArea;
  return std::nullopt;
}

inline const char* IpmViewName(IpmView view) { return view == IpmView::kGround ? "ground" : "roi"; }

inline std::optional<IpmView> ParseIpmView(const std::string& name) {
  if (name == "roi") return IpmView::kRoi;
  if (name == "ground") return IpmView::kGround;
  return std::nullopt;
}

// Name, parser and allowed names of each enum type used in a field list.
template <class E>
struct EnumTraits;
template <>
struct EnumTraits<Mode> {
  static const char* Name(Mode m) { return ModeName(m); }
  static std::optional<Mode> Parse(const std::string& s) { return ParseMode(s); }
  static constexpr const char* kAllowed = "\"all\" or \"two\"";
};
template <>
struct EnumTraits<Channel> {
  static const char* Name(Channel c) { return ChannelName(c); }
  static std::optional<Channel> Parse(const std::string& s) { return ParseChannel(s); }
  static constexpr const char* kAllowed = "\"red\", \"green\", \"blue\", \"gray\" or \"min_rg\"";
};
template <>
struct EnumTraits<Interpolation> {
  static const char* Name(Interpolation i) { return InterpolationName(i); }
  static std::optional<Interpolation> Parse(const std::string& s) { return ParseInterpolation(s); }
  static constexpr const char* kAllowed = "\"bilinear\", \"nearest\" or \"area\"";
};
template <>
struct EnumTraits<IpmView> {
  static const char* Name(IpmView v) { return IpmViewName(v); }
  static std::optional<IpmView> Parse(const std::string& s) { return ParseIpmView(s); }
  static constexpr const char* kAllowed = "\"roi\" or \"ground\"";
};

}  // namespace lane

#endif  // LANE_CONFIG_FIELDS_H_
