// ProtoSchemaMismatches: the config schema (lane/config/config_fields.h) against the
// lane.v1 descriptors, so that a field missing on either side fails a test
// by name instead of being dropped silently by the conversion.
#include <google/protobuf/descriptor.h>

#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "lane/config/config_fields.h"
#include "wire/config_proto.h"
#include "wire/config_proto_internal.h"

namespace lane::wire {
namespace {

using google::protobuf::Descriptor;
using google::protobuf::FieldDescriptor;
using internal::CppTypeOf;
using internal::EnumValueName;

// Compares the schema with the proto descriptors, message by message.
class SchemaChecker {
 public:
  SchemaChecker(const Descriptor* descriptor, std::vector<std::string>* problems)
      : descriptor_(descriptor), problems_(problems) {}

  template <class T>
  void Field(const char* name, const T& /*member*/) {
    const FieldDescriptor* field = Claim(name);
    if (field == nullptr) return;
    if (field->cpp_type() != CppTypeOf<T>() || field->is_repeated()) {
      Problem(name, absl::StrCat("is a ", field->cpp_type_name(), ", the config field is not"));
    } else if (!std::is_enum_v<T> && !field->has_presence()) {
      Problem(name, "must be `optional` so that an unset field keeps the default");
    } else if constexpr (std::is_enum_v<T>) {
      for (int i = 1; i < field->enum_type()->value_count(); ++i) {
        const std::string value = EnumValueName(*field->enum_type()->value(i));
        if (!EnumTraits<T>::Parse(value)) Problem(name, "has the value " + value + ", unknown");
      }
    }
  }

  template <class T>
  void Section(const char* name, const T& member) {
    const FieldDescriptor* field = Claim(name);
    if (field == nullptr) return;
    if (field->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE) {
      Problem(name, "is not a message, the config section is");
      return;
    }
    SchemaChecker nested(field->message_type(), problems_);
    VisitFields(member, nested);
    nested.Finish({});
  }

  template <class T>
  void List(const char* name, const std::vector<T>& /*member*/) {
    const FieldDescriptor* field = Claim(name);
    if (field == nullptr) return;
    if (field->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE || !field->is_repeated()) {
      Problem(name, "is not a repeated message, the config list is");
      return;
    }
    SchemaChecker nested(field->message_type(), problems_);
    const T item;
    VisitFields(item, nested);
    nested.Finish({});
  }

  // Proto fields no config field claimed, but for `extra` (not config).
  void Finish(const std::set<std::string>& extra) {
    for (int i = 0; i < descriptor_->field_count(); ++i) {
      const std::string& name = descriptor_->field(i)->name();
      if (claimed_.count(name) == 0 && extra.count(name) == 0) {
        Problem(name.c_str(), "has no config field of that name");
      }
    }
  }

 private:
  const FieldDescriptor* Claim(const char* name) {
    claimed_.insert(name);
    const FieldDescriptor* field = descriptor_->FindFieldByName(name);
    if (field == nullptr) Problem(name, "is missing from the proto");
    return field;
  }
  void Problem(const char* name, const std::string& why) {
    problems_->push_back(absl::StrCat(descriptor_->full_name(), ".", name, ": ", why));
  }

  const Descriptor* descriptor_;
  std::vector<std::string>* problems_;
  std::set<std::string> claimed_;
};

}  // namespace

std::vector<std::string> ProtoSchemaMismatches() {
  std::vector<std::string> problems;
  SchemaChecker checker(v1::SessionConfig::descriptor(), &problems);
  const lane::Config config;
  VisitFields(config, checker);
  checker.Finish({"config_json", "stream", "decode", "calibration", "tracking"});
  return problems;
}

}  // namespace lane::wire
