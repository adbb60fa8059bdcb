// The detector's config on the wire: lane::Config <-> lane.v1.SessionConfig.
//
// The conversion is written once, over the config's schema
// (lane/config/config_fields.h): each field of the core structs is found in the
// proto message by its name (protobuf reflection), so a new option needs its
// field-list entry and a proto field of the same name, nothing else.
// ProtoSchemaMismatches() lists what does not line up; a test requires it to
// be empty.
#ifndef LANE_WIRE_CONFIG_PROTO_H_
#define LANE_WIRE_CONFIG_PROTO_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "lane/config/config.h"
#include "lane/v1/lane_service.pb.h"

namespace lane::wire {

// The detector config of a SessionConfig: either its `config_json` (parsed by
// lane::ParseConfig) or its structured fields applied over the defaults of
// the requested mode (unset `optional` fields and UNSPECIFIED enums keep the
// default). INVALID_ARGUMENT for both at once, an unknown enum value, or a
// config that does not validate.
absl::StatusOr<lane::Config> ConfigFromProto(const v1::SessionConfig& proto);
// Every config field set; `config_json`, `stream` and `decode` are left alone.
void ConfigToProto(const lane::Config& config, v1::SessionConfig* out);

// Fields of the config schema without a proto field of the same name and
// kind, and proto fields without a config field (apart from SessionConfig's
// own config_json, stream and decode), as "lane.v1.Message.field: why".
std::vector<std::string> ProtoSchemaMismatches();

}  // namespace lane::wire

#endif  // LANE_WIRE_CONFIG_PROTO_H_
