// Helpers shared by the config conversion and its schema check.
#ifndef LANE_WIRE_CONFIG_PROTO_INTERNAL_H_
#define LANE_WIRE_CONFIG_PROTO_INTERNAL_H_

#include <google/protobuf/descriptor.h>

#include <cctype>
#include <cstdint>
#include <string>
#include <type_traits>

namespace lane::wire::internal {

// The proto kind a member of each C++ type maps onto.
template <class T>
constexpr google::protobuf::FieldDescriptor::CppType CppTypeOf() {
  if constexpr (std::is_same_v<T, double>) return google::protobuf::FieldDescriptor::CPPTYPE_DOUBLE;
  if constexpr (std::is_same_v<T, int>) return google::protobuf::FieldDescriptor::CPPTYPE_INT32;
  if constexpr (std::is_same_v<T, uint64_t>)
    return google::protobuf::FieldDescriptor::CPPTYPE_UINT64;
  if constexpr (std::is_same_v<T, bool>) return google::protobuf::FieldDescriptor::CPPTYPE_BOOL;
  if constexpr (std::is_enum_v<T>) return google::protobuf::FieldDescriptor::CPPTYPE_ENUM;
  static_assert(std::is_arithmetic_v<T> || std::is_enum_v<T>, "no proto kind for this field");
  return google::protobuf::FieldDescriptor::CPPTYPE_MESSAGE;
}

// MODE_TWO <-> "two", IPM_VIEW_GROUND <-> "ground": proto enum values are the
// config's names in upper case behind the enum type's name in upper snake
// case; value 0 (..._UNSPECIFIED) means "keep the default".
inline std::string EnumValueName(const google::protobuf::EnumValueDescriptor& value) {
  std::string prefix;  // IpmView -> IPM_VIEW_
  for (const char c : value.type()->name()) {
    if (std::isupper(static_cast<unsigned char>(c)) && !prefix.empty()) prefix += '_';
    prefix += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  }
  prefix += '_';
  std::string name = value.name();
  if (name.compare(0, prefix.size(), prefix) == 0) name = name.substr(prefix.size());
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return name;
}

}  // namespace lane::wire::internal

#endif  // LANE_WIRE_CONFIG_PROTO_INTERNAL_H_
