#include "lane/config/config.h"

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
#include "lane/base/excerpt.h"
#include "lane/config/config_fields.h"
#include "lane/geometry/ground_view_rule.h"

namespace lane {
namespace {

// ordered_json keeps the keys in the order of the field lists
// (config_fields.h), so the written document reads like the headers.
using Json = nlohmann::ordered_json;

// ---------------------------------------------------------------------------
// Reading.

// Keys of the field lists (ours) and paths built from them.
std::string Quoted(const std::string& key) { return absl::StrCat("\"", key, "\""); }

// `string "abc"`, `number 1.5`, `array of 3 elements`: the offending value
// described in a bounded number of characters. Arrays and objects are never
// dumped: dumping recurses over client data of any depth and size.
std::string Describe(const Json& j) {
  if (j.is_array()) return absl::StrCat("an array of ", j.size(), " elements");
  if (j.is_object()) return absl::StrCat("an object of ", j.size(), " keys");
  if (j.is_string()) return absl::StrCat("string ", QuotedExcerpt(j.get_ref<const std::string&>()));
  return absl::StrCat(j.type_name(), " ", Excerpt(j.dump()));
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
  // An array of objects, each read like a section over the type's defaults.
  template <class T>
  void List(const char* name, std::vector<T>& member) {
    Visit(name, [&](const Json& j, const std::string& key) -> absl::Status {
      if (!j.is_array()) return WrongType(key, "an array of objects", j);
      std::vector<T> items(j.size());
      for (size_t i = 0; i < j.size(); ++i) {
        if (absl::Status s = ReadObject(j[i], absl::StrCat(key, "[", i, "]"), items[i]); !s.ok()) {
          return s;
        }
      }
      member = std::move(items);
      return absl::OkStatus();
    });
  }

  // The first error, unknown keys first (they are usually typos that also
  // explain any other surprise).
  absl::Status Finish() const {
    for (const auto& item : object_.items()) {
      bool known = false;
      for (const char* name : known_) known = known || item.key() == name;
      if (!known) {
        // The key is the client's: quoted as a bounded excerpt.
        return absl::InvalidArgumentError(
            absl::StrCat("unknown key \"", path_.empty() ? "" : absl::StrCat(path_, "."),
                         Excerpt(item.key()), "\""));
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
  // A camera and no top view: the view the camera needs, by lane
  // calibrate's rule (lane/geometry/ground_view_rule.h).
  if (doc.is_object() && doc.contains("camera") && !doc.contains("ipm")) {
    if (absl::Status s = config.camera.Validate(); !s.ok()) return s;
    absl::StatusOr<IpmOptions> built_in = BuiltInIpm(config.camera);
    if (!built_in.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("the config gives a camera and no \"ipm\", and the built-in top view does "
                       "not fit the camera: ",
                       built_in.status().message()));
    }
    config.ipm = *std::move(built_in);
  }
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
  static Json Object(const T& value) {
    Writer nested;
    VisitFields(value, nested);
    return std::move(nested.out_);
  }

  template <class T>
  void Field(const char* name, const T& member) {
    out_[name] = WriteValue(member);
  }
  template <class T>
  void Section(const char* name, const T& member) {
    out_[name] = Object(member);
  }
  template <class T>
  void List(const char* name, const std::vector<T>& member) {
    Json items = Json::array();
    for (const T& item : member) items.push_back(Object(item));
    out_[name] = std::move(items);
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

namespace {

// Checks the document's size and nesting before anything parses or walks it:
// nothing downstream then recurses deeper than kMaxConfigDepth. Comments and
// strings are skipped, as the parser skips them.
absl::Status CheckConfigShape(const std::string& text) {
  if (text.size() > kMaxConfigBytes) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the config is ", text.size(), " bytes, more than the limit of ", kMaxConfigBytes));
  }
  int depth = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '"') {
      for (++i; i < text.size() && text[i] != '"'; ++i) {
        if (text[i] == '\\') ++i;
      }
    } else if (c == '/' && i + 1 < text.size() && text[i + 1] == '/') {
      while (i < text.size() && text[i] != '\n') ++i;
    } else if (c == '/' && i + 1 < text.size() && text[i + 1] == '*') {
      const size_t end = text.find("*/", i + 2);
      i = end == std::string::npos ? text.size() : end + 1;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxConfigDepth) {
        return absl::InvalidArgumentError(
            absl::StrCat("the config nests deeper than ", kMaxConfigDepth,
                         " levels (its schema has 4: sections, subsections, lists, values)"));
      }
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<Config> ParseConfig(const std::string& json_text) {
  if (absl::Status s = CheckConfigShape(json_text); !s.ok()) return s;
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
    // The parser quotes the last token it read, which is the client's.
    return absl::InvalidArgumentError(absl::StrCat("malformed JSON: ", Excerpt(what, 160)));
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
