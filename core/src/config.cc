#include "lane/config.h"

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "absl/strings/str_cat.h"

namespace lane {
namespace {

// ordered_json keeps the keys in the order of the field lists below, so the
// written document reads like the headers.
using Json = nlohmann::ordered_json;

// ---------------------------------------------------------------------------
// The field lists: the ONLY place that names the keys of each struct. Both
// the reader and the writer walk them. A visitor V provides
//   v.Field(name, member)    for numbers, booleans and enums;
//   v.Section(name, member)  for nested structs (which have a list here too).
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
  v.Field("iterations", s.iterations);
  v.Field("inlier_distance_px", s.inlier_distance_px);
  v.Field("min_inliers", s.min_inliers);
  v.Field("max_angle_from_vertical_deg", s.max_angle_from_vertical_deg);
}

LANE_FIELDS(SplineRansacOptions) {
  v.Field("window_half_width_m", s.window_half_width_m);
  v.Field("iterations", s.iterations);
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
  v.Field("extend_geometric", s.extend_geometric);
  v.Field("localize_geometric", s.localize_geometric);
  v.Field("localize_search_m", s.localize_search_m);
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
}

LANE_FIELDS(Config) {
  v.Section("camera", s.camera);
  v.Section("ipm", s.ipm);
  v.Section("detector", s.detector);
}

#undef LANE_FIELDS

// ---------------------------------------------------------------------------
// Enums <-> names.

const char* InterpolationName(Interpolation interpolation) {
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

std::optional<Interpolation> ParseInterpolation(const std::string& name) {
  if (name == "nearest") return Interpolation::kNearest;
  if (name == "bilinear") return Interpolation::kBilinear;
  if (name == "area") return Interpolation::kArea;
  return std::nullopt;
}

const char* IpmViewName(IpmView view) { return view == IpmView::kGround ? "ground" : "roi"; }

std::optional<IpmView> ParseIpmView(const std::string& name) {
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

// ---------------------------------------------------------------------------
// Reading.

std::string Quoted(const std::string& key) { return absl::StrCat("\"", key, "\""); }

// `"abc"`, `1.5`, `{...}`: the offending value, shortened.
std::string Describe(const Json& j) {
  std::string text = j.dump();
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  return absl::StrCat(j.type_name(), " ", text);
}

absl::Status WrongType(const std::string& key, const char* expected, const Json& j) {
  return absl::InvalidArgumentError(
      absl::StrCat(Quoted(key), " must be ", expected, ", got ", Describe(j)));
}

// One value of a field list from JSON, with its type checked.
template <class T>
absl::Status ReadValue(const Json& j, const std::string& key, T& out) {
  if constexpr (std::is_same_v<T, bool>) {
    if (!j.is_boolean()) return WrongType(key, "true or false", j);
    out = j.get<bool>();
  } else if constexpr (std::is_same_v<T, double>) {
    if (!j.is_number()) return WrongType(key, "a number", j);
    out = j.get<double>();
  } else if constexpr (std::is_same_v<T, int>) {
    if (!j.is_number_integer()) return WrongType(key, "an integer", j);
    const bool fits = j.is_number_unsigned()
                          ? j.get<uint64_t>() <= uint64_t{std::numeric_limits<int>::max()}
                          : j.get<int64_t>() >= std::numeric_limits<int>::min() &&
                                j.get<int64_t>() <= std::numeric_limits<int>::max();
    if (!fits) return WrongType(key, "an integer that fits in 32 bits", j);
    out = j.get<int>();
  } else if constexpr (std::is_same_v<T, uint64_t>) {
    if (!j.is_number_unsigned()) return WrongType(key, "a non-negative integer", j);
    out = j.get<uint64_t>();
  } else if constexpr (std::is_enum_v<T>) {
    const char* allowed = EnumTraits<T>::kAllowed;
    if (!j.is_string()) return WrongType(key, allowed, j);
    const std::optional<T> parsed = EnumTraits<T>::Parse(j.get<std::string>());
    if (!parsed) return WrongType(key, allowed, j);
    out = *parsed;
  } else {
    static_assert(sizeof(T) == 0, "no JSON reader for this field type");
  }
  return absl::OkStatus();
}

template <class T>
absl::Status ReadObject(const Json& j, const std::string& path, T& out);

// Visitor that assigns the members present in one JSON object and then
// rejects the object's keys that no field claimed.
class Reader {
 public:
  Reader(const Json& object, std::string path) : object_(object), path_(std::move(path)) {}

  template <class T>
  void Field(const char* name, T& member) {
    Visit(name, [&](const Json& j, const std::string& key) { return ReadValue(j, key, member); });
  }
  template <class T>
  void Section(const char* name, T& member) {
    Visit(name, [&](const Json& j, const std::string& key) { return ReadObject(j, key, member); });
  }

  // The first error, unknown keys first (they are usually typos that also
  // explain any other surprise).
  absl::Status Finish() const {
    for (const auto& item : object_.items()) {
      bool known = false;
      for (const char* name : known_) known = known || item.key() == name;
      if (!known) {
        return absl::InvalidArgumentError(
            absl::StrCat("unknown key ", Quoted(Key(item.key().c_str()))));
      }
    }
    return status_;
  }

 private:
  std::string Key(const char* name) const {
    return path_.empty() ? std::string(name) : absl::StrCat(path_, ".", name);
  }
  template <class Fn>
  void Visit(const char* name, Fn read) {
    known_.push_back(name);
    if (!status_.ok()) return;
    const auto it = object_.find(name);
    if (it != object_.end()) status_ = read(*it, Key(name));
  }

  const Json& object_;
  std::string path_;
  std::vector<const char*> known_;
  absl::Status status_;
};

template <class T>
absl::Status ReadObject(const Json& j, const std::string& path, T& out) {
  if (!j.is_object()) {
    return WrongType(path.empty() ? "the config" : path, "a JSON object", j);
  }
  Reader reader(j, path);
  VisitFields(out, reader);
  return reader.Finish();
}

absl::StatusOr<Config> ConfigFromJson(const Json& doc) {
  Config config;
  // The mode's defaults first, so that the document's other detector keys
  // override them whatever their order.
  const auto detector = doc.is_object() ? doc.find("detector") : doc.end();
  if (detector != doc.end() && detector->is_object()) {
    const auto mode = detector->find("mode");
    if (mode != detector->end()) {
      Mode m = Mode::kAll;
      if (absl::Status s = ReadValue(*mode, "detector.mode", m); !s.ok()) return s;
      config.detector = DetectorOptions::ForMode(m);
    }
  }
  // A "ground" section without "view" means the ground view ("view" itself,
  // when present, is read below and wins).
  const auto ipm = doc.is_object() ? doc.find("ipm") : doc.end();
  if (ipm != doc.end() && ipm->is_object() && ipm->contains("ground") && !ipm->contains("view")) {
    config.ipm.view = IpmView::kGround;
  }
  if (absl::Status s = ReadObject(doc, "", config); !s.ok()) return s;
  if (absl::Status s = config.Validate(); !s.ok()) return s;
  return config;
}

// ---------------------------------------------------------------------------
// Writing.

template <class T>
Json WriteValue(const T& value) {
  if constexpr (std::is_enum_v<T>) {
    return EnumTraits<T>::Name(value);
  } else {
    return value;
  }
}

class Writer {
 public:
  template <class T>
  void Field(const char* name, const T& member) {
    out_[name] = WriteValue(member);
  }
  template <class T>
  void Section(const char* name, const T& member) {
    Writer nested;
    VisitFields(member, nested);
    out_[name] = std::move(nested.out_);
  }
  Json& out() { return out_; }

 private:
  Json out_ = Json::object();
};

}  // namespace

absl::Status Config::Validate() const {
  if (absl::Status s = camera.Validate(); !s.ok()) return s;
  if (absl::Status s = ipm.Validate(); !s.ok()) return s;
  return detector.Validate();
}

absl::StatusOr<Config> ParseConfig(const std::string& json_text) {
  Json doc;
  try {
    doc = Json::parse(json_text, /*cb=*/nullptr, /*allow_exceptions=*/true,
                      /*ignore_comments=*/true);
  } catch (const Json::exception& e) {
    // A parse_error, or an out_of_range for a number beyond double (found by
    // fuzz/config_fuzzer: "1e999" used to escape as an exception). e.what()
    // is "[json.exception.parse_error.101] parse error at line L, column C:
    // ..."; the bracketed id means nothing to a user.
    std::string what = e.what();
    if (const size_t close = what.find("] "); what.rfind("[json.", 0) == 0 && close != what.npos) {
      what = what.substr(close + 2);
    }
    return absl::InvalidArgumentError(absl::StrCat("malformed JSON: ", what));
  }
  return ConfigFromJson(doc);
}

absl::StatusOr<Config> LoadConfigFile(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot read config file \"", path, "\": it is a directory"));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const int err = errno;
    const std::string message =
        absl::StrCat("cannot open config file \"", path, "\": ", std::strerror(err));
    if (err == EACCES || err == EPERM) return absl::PermissionDeniedError(message);
    return absl::NotFoundError(message);
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) {
    return absl::UnknownError(absl::StrCat("error reading config file \"", path, "\""));
  }
  absl::StatusOr<Config> config = ParseConfig(text.str());
  if (!config.ok()) {
    return absl::Status(config.status().code(),
                        absl::StrCat(path, ": ", config.status().message()));
  }
  return config;
}

std::string ConfigToJson(const Config& config) {
  Writer writer;
  VisitFields(config, writer);
  return writer.out().dump(2) + "\n";
}

}  // namespace lane
