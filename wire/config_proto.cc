#include "wire/config_proto.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <cstdint>
#include <type_traits>
#include <vector>

#include "absl/strings/str_cat.h"
#include "lane/config/config_fields.h"
#include "lane/geometry/ground_view_rule.h"
#include "wire/config_proto_internal.h"
#include "wire/status_map.h"

namespace lane::wire {
namespace {

using google::protobuf::EnumValueDescriptor;
using google::protobuf::FieldDescriptor;
using google::protobuf::Message;
using google::protobuf::Reflection;
using internal::EnumValueName;

// Reads the fields a message sets into the config struct it describes.
class ProtoReader {
 public:
  ProtoReader(const Message& message, std::string path)
      : message_(message), path_(std::move(path)) {}

  template <class T>
  void Field(const char* name, T& member) {
    const FieldDescriptor* field = Find(name);
    if (field == nullptr || !status_.ok()) return;
    const Reflection& r = *message_.GetReflection();
    if constexpr (std::is_enum_v<T>) {
      const int number = r.GetEnumValue(message_, field);
      if (number == 0) return;
      const EnumValueDescriptor* value = field->enum_type()->FindValueByNumber(number);
      const std::optional<T> parsed =
          value == nullptr ? std::nullopt : EnumTraits<T>::Parse(EnumValueName(*value));
      if (!parsed) {
        status_ = InvalidRequest(absl::StrCat(Key(name), ": unknown value ", number));
        return;
      }
      member = *parsed;
    } else {
      if (!r.HasField(message_, field)) return;
      if constexpr (std::is_same_v<T, double>) member = r.GetDouble(message_, field);
      if constexpr (std::is_same_v<T, int>) member = r.GetInt32(message_, field);
      if constexpr (std::is_same_v<T, uint64_t>) member = r.GetUInt64(message_, field);
      if constexpr (std::is_same_v<T, bool>) member = r.GetBool(message_, field);
    }
  }

  template <class T>
  void Section(const char* name, T& member) {
    const FieldDescriptor* field = Find(name);
    if (field == nullptr || !status_.ok()) return;
    const Reflection& r = *message_.GetReflection();
    if (!r.HasField(message_, field)) return;
    ProtoReader nested(r.GetMessage(message_, field), Key(name));
    VisitFields(member, nested);
    if (status_.ok()) status_ = nested.status_;
  }

  template <class T>
  void List(const char* name, std::vector<T>& member) {
    const FieldDescriptor* field = Find(name);
    if (field == nullptr || !status_.ok()) return;
    const Reflection& r = *message_.GetReflection();
    const int n = r.FieldSize(message_, field);
    if (n == 0) return;  // unset: the default (an empty list)
    std::vector<T> items(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) {
      ProtoReader nested(r.GetRepeatedMessage(message_, field, i),
                         absl::StrCat(Key(name), "[", i, "]"));
      VisitFields(items[static_cast<size_t>(i)], nested);
      if (!nested.status_.ok()) {
        status_ = nested.status_;
        return;
      }
    }
    member = std::move(items);
  }

  const absl::Status& status() const { return status_; }

 private:
  std::string Key(const char* name) const {
    return path_.empty() ? std::string(name) : absl::StrCat(path_, ".", name);
  }
  const FieldDescriptor* Find(const char* name) {
    const FieldDescriptor* field = message_.GetDescriptor()->FindFieldByName(name);
    // A schema mismatch is a bug of ours (ProtoSchemaMismatches finds it).
    if (field == nullptr && status_.ok()) {
      status_ = absl::InternalError(
          absl::StrCat(message_.GetDescriptor()->full_name(), " has no field ", name));
    }
    return field;
  }

  const Message& message_;
  std::string path_;
  absl::Status status_;
};

// Sets every field of a message from the config struct it describes.
class ProtoWriter {
 public:
  explicit ProtoWriter(Message* message) : message_(message) {}

  template <class T>
  void Field(const char* name, const T& member) {
    const FieldDescriptor* field = message_->GetDescriptor()->FindFieldByName(name);
    if (field == nullptr) return;  // reported by ProtoSchemaMismatches
    const Reflection& r = *message_->GetReflection();
    if constexpr (std::is_enum_v<T>) {
      const std::string wanted = EnumTraits<T>::Name(member);
      for (int i = 0; i < field->enum_type()->value_count(); ++i) {
        const EnumValueDescriptor* value = field->enum_type()->value(i);
        if (value->number() != 0 && EnumValueName(*value) == wanted) {
          r.SetEnumValue(message_, field, value->number());
        }
      }
    }
    if constexpr (std::is_same_v<T, double>) r.SetDouble(message_, field, member);
    if constexpr (std::is_same_v<T, int>) r.SetInt32(message_, field, member);
    if constexpr (std::is_same_v<T, uint64_t>) r.SetUInt64(message_, field, member);
    if constexpr (std::is_same_v<T, bool>) r.SetBool(message_, field, member);
  }

  template <class T>
  void Section(const char* name, const T& member) {
    const FieldDescriptor* field = message_->GetDescriptor()->FindFieldByName(name);
    if (field == nullptr) return;
    ProtoWriter nested(message_->GetReflection()->MutableMessage(message_, field));
    VisitFields(member, nested);
  }

  template <class T>
  void List(const char* name, const std::vector<T>& member) {
    const FieldDescriptor* field = message_->GetDescriptor()->FindFieldByName(name);
    if (field == nullptr) return;
    for (const T& item : member) {
      ProtoWriter nested(message_->GetReflection()->AddMessage(message_, field));
      VisitFields(item, nested);
    }
  }

 private:
  Message* message_;
};

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
    // The mode's defaults first, as lane::ParseConfig does; the walk below
    // then applies every field that is set (the mode again, harmlessly).
    ProtoReader mode_reader(proto.detector(), "detector");
    mode_reader.Field("mode", config->detector.mode);
    if (!mode_reader.status().ok()) return mode_reader.status();
    config->detector = lane::DetectorOptions::ForMode(config->detector.mode);
    // As in the config file: a ground section without a view selects the
    // ground view (a view that is set is read below and wins).
    if (proto.ipm().has_ground() && proto.ipm().view() == v1::IPM_VIEW_UNSPECIFIED) {
      config->ipm.view = lane::IpmView::kGround;
    }
    ProtoReader reader(proto, "");
    VisitFields(*config, reader);
    if (!reader.status().ok()) return reader.status();
    // As in the config file: a camera and no ipm gets the view the camera
    // needs (lane/geometry/ground_view_rule.h).
    if (proto.has_camera() && !proto.has_ipm()) {
      if (absl::Status s = config->camera.Validate(); !s.ok()) {
        return InvalidRequest(absl::StrCat("session config: ", s.message()));
      }
      absl::StatusOr<lane::IpmOptions> ipm = lane::BuiltInIpm(config->camera);
      if (!ipm.ok()) {
        return InvalidRequest(absl::StrCat(
            "session config: a camera and no ipm, and the built-in top view does not fit the "
            "camera: ",
            ipm.status().message()));
      }
      config->ipm = *std::move(ipm);
    }
  }
  // The server never returns intermediate images.
  config->detector.keep_intermediates = false;
  if (absl::Status s = config->Validate(); !s.ok()) {
    return InvalidRequest(absl::StrCat("session config: ", s.message()));
  }
  return config;
}

void ConfigToProto(const lane::Config& config, v1::SessionConfig* out) {
  ProtoWriter writer(out);
  VisitFields(config, writer);
}

}  // namespace lane::wire
