// `lane-client session create|get|list|delete`, `info` and `health`.
#include <google/protobuf/util/json_util.h>
#include <grpcpp/generic/generic_stub.h>

#include <cstdio>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "commands.h"
#include "common.h"
#include "lane/v1/lane_service.grpc.pb.h"
#include "session_config.h"

namespace lane_client {
namespace {

namespace v1 = lane::v1;

constexpr char kSessionUsage[] =
    "usage: lane-client session create --camera ID [--config FILE] [options]\n"
    "       lane-client session get --camera ID\n"
    "       lane-client session list\n"
    "       lane-client session delete --camera ID\n"
    "\n"
    "Manages the service's sessions (a camera's calibration and detector\n"
    "options). Prints the server's answer as JSON, one line per target.\n"
    "create is idempotent: the same config again is UNCHANGED.\n"
    "\n"
    "options:\n"
    "  --target T           server address, or a comma list: every target is asked\n"
    "                       (default 127.0.0.1:50051)\n"
    "  --camera ID          the camera id\n"
    "%s"
    "  --replace            create: replace a session with a different config\n"
    "  --timeout D          deadline of each call (default 10s)\n"
    "  -h, --help           show this help\n"
    "\n"
    "Exit status: 0 when every call succeeded, 1 otherwise, 2 for a bad command\n"
    "line.\n";

constexpr char kInfoUsage[] =
    "usage: lane-client info [--target T] [--timeout D]\n"
    "\n"
    "Prints the server's version, formats, limits and detector defaults\n"
    "(GetServerInfo) as JSON.\n";

constexpr char kHealthUsage[] =
    "usage: lane-client health [--target T] [--service NAME] [--timeout D]\n"
    "\n"
    "Asks the gRPC health service (grpc.health.v1.Health/Check) of each target\n"
    "about NAME (default \"\": the whole server) and prints its answer.\n"
    "Exit status: 0 when every target is SERVING, 1 otherwise (NOT_SERVING,\n"
    "unreachable, timed out), 2 for a bad command line.\n";

std::string SessionUsage() {
  char buffer[4096];
  std::snprintf(buffer, sizeof(buffer), kSessionUsage, kSessionConfigUsage);
  return buffer;
}

std::string ToJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  std::string json;
  if (!google::protobuf::util::MessageToJsonString(message, &json, options).ok()) return "{}";
  return json;
}

// Common options of the one-call commands.
struct CallSetup {
  std::vector<std::string> targets;
  absl::Duration timeout = absl::Seconds(10);
};

absl::StatusOr<CallSetup> ParseCallSetup(const lane_tools::Args& args) {
  CallSetup setup;
  absl::StatusOr<std::vector<std::string>> targets =
      SplitTargets(args.Get("target").value_or(kDefaultTarget));
  if (!targets.ok()) return targets.status();
  setup.targets = *std::move(targets);
  const auto timeout = GetDuration(args, "timeout");
  if (!timeout.ok()) return timeout.status();
  if (*timeout) setup.timeout = **timeout;
  return setup;
}

// Protobuf wire format of grpc.health.v1: HealthCheckRequest{string service = 1},
// HealthCheckResponse{ServingStatus status = 1}.
std::string EncodeHealthRequest(const std::string& service) {
  std::string bytes;
  if (service.empty()) return bytes;
  bytes.push_back(0x0A);  // field 1, length-delimited
  for (size_t n = service.size();; n >>= 7) {
    if (n < 0x80) {
      bytes.push_back(static_cast<char>(n));
      break;
    }
    bytes.push_back(static_cast<char>((n & 0x7F) | 0x80));
  }
  return bytes + service;
}

bool ReadVarint(const std::string& bytes, size_t* pos, uint64_t* value) {
  *value = 0;
  for (int shift = 0; *pos < bytes.size() && shift < 64; shift += 7) {
    const auto byte = static_cast<unsigned char>(bytes[(*pos)++]);
    *value |= uint64_t{byte & 0x7Fu} << shift;
    if ((byte & 0x80) == 0) return true;
  }
  return false;
}

// The status field of a HealthCheckResponse (0 when absent); -1 if malformed.
int DecodeHealthStatus(const std::string& bytes) {
  int status = 0;
  size_t pos = 0;
  while (pos < bytes.size()) {
    uint64_t key = 0;
    uint64_t value = 0;
    if (!ReadVarint(bytes, &pos, &key)) return -1;
    switch (key & 7) {
      case 0:
        if (!ReadVarint(bytes, &pos, &value)) return -1;
        if ((key >> 3) == 1) status = static_cast<int>(value);
        break;
      case 1:
        pos += 8;
        break;
      case 2:
        if (!ReadVarint(bytes, &pos, &value)) return -1;
        pos += value;
        break;
      case 5:
        pos += 4;
        break;
      default:
        return -1;
    }
  }
  return pos == bytes.size() ? status : -1;
}

const char* HealthStatusName(int status) {
  switch (status) {
    case 0:
      return "UNKNOWN";
    case 1:
      return "SERVING";
    case 2:
      return "NOT_SERVING";
    case 3:
      return "SERVICE_UNKNOWN";
    default:
      return "MALFORMED";
  }
}

}  // namespace

int RunSession(const std::vector<std::string>& argv) {
  const std::string usage = SessionUsage();
  if (argv.empty()) return UsageError("session", "missing create|get|list|delete", usage.c_str());
  const std::string action = argv.front();
  if (action == "-h" || action == "--help") {
    std::fputs(usage.c_str(), stdout);
    return kExitOk;
  }
  if (action != "create" && action != "get" && action != "list" && action != "delete") {
    return UsageError("session", absl::StrCat("unknown action ", action), usage.c_str());
  }
  const std::string command = "session " + action;
  std::vector<lane_tools::OptionSpec> specs = {{"target"}, {"camera"}, {"timeout"}};
  if (action == "create") {
    for (const lane_tools::OptionSpec& spec : SessionConfigOptionSpecs()) specs.push_back(spec);
    specs.push_back({"replace", false});
  }
  const absl::StatusOr<lane_tools::Args> args =
      lane_tools::Args::Parse(std::vector<std::string>(argv.begin() + 1, argv.end()), specs);
  if (!args.ok()) return UsageError(command, std::string(args.status().message()), usage.c_str());
  if (args->help()) {
    std::fputs(usage.c_str(), stdout);
    return kExitOk;
  }
  if (!args->positional().empty()) {
    return UsageError(command, absl::StrCat("unexpected argument ", args->positional().front()),
                      usage.c_str());
  }
  const absl::StatusOr<CallSetup> setup = ParseCallSetup(*args);
  if (!setup.ok()) return UsageError(command, std::string(setup.status().message()), usage.c_str());
  const std::string camera = args->Get("camera").value_or("");
  if (action != "list" && camera.empty()) {
    return UsageError(command, "--camera is required", usage.c_str());
  }
  std::optional<v1::SessionConfig> config;
  if (action == "create") {
    absl::StatusOr<std::optional<v1::SessionConfig>> parsed = SessionConfigFromArgs(*args, true);
    if (!parsed.ok()) return Failure(command, std::string(parsed.status().message()));
    config = **parsed;
  }

  int exit_code = kExitOk;
  for (const std::string& target : setup->targets) {
    const auto stub = v1::LaneService::NewStub(MakeChannel(target));
    grpc::ClientContext context;
    SetDeadline(&context, setup->timeout);
    grpc::Status status;
    std::string json;
    if (action == "create") {
      v1::CreateSessionRequest request;
      request.set_camera_id(camera);
      *request.mutable_config() = *config;
      request.set_replace(args->Has("replace"));
      v1::CreateSessionResponse response;
      status = stub->CreateSession(&context, request, &response);
      json = ToJson(response);
    } else if (action == "get") {
      v1::GetSessionRequest request;
      request.set_camera_id(camera);
      v1::Session response;
      status = stub->GetSession(&context, request, &response);
      json = ToJson(response);
    } else if (action == "list") {
      v1::ListSessionsResponse response;
      status = stub->ListSessions(&context, v1::ListSessionsRequest(), &response);
      json = ToJson(response);
    } else {
      v1::DeleteSessionRequest request;
      request.set_camera_id(camera);
      v1::DeleteSessionResponse response;
      status = stub->DeleteSession(&context, request, &response);
      json = absl::StrCat("{\"deleted\":\"", camera, "\"}");
    }
    if (!status.ok()) {
      exit_code = kExitFailure;
      Note(command, absl::StrCat(target, ": ", StatusText(status)));
      continue;
    }
    std::printf("%s\n", json.c_str());
  }
  std::fflush(stdout);
  return exit_code;
}

int RunInfo(const std::vector<std::string>& argv) {
  const absl::StatusOr<lane_tools::Args> args =
      lane_tools::Args::Parse(argv, {{"target"}, {"timeout"}});
  if (!args.ok()) return UsageError("info", std::string(args.status().message()), kInfoUsage);
  if (args->help()) {
    std::fputs(kInfoUsage, stdout);
    return kExitOk;
  }
  const absl::StatusOr<CallSetup> setup = ParseCallSetup(*args);
  if (!setup.ok()) return UsageError("info", std::string(setup.status().message()), kInfoUsage);
  int exit_code = kExitOk;
  for (const std::string& target : setup->targets) {
    const auto stub = v1::LaneService::NewStub(MakeChannel(target));
    grpc::ClientContext context;
    SetDeadline(&context, setup->timeout);
    v1::ServerInfo info;
    const grpc::Status status = stub->GetServerInfo(&context, v1::GetServerInfoRequest(), &info);
    if (!status.ok()) {
      exit_code = kExitFailure;
      Note("info", absl::StrCat(target, ": ", StatusText(status)));
      continue;
    }
    std::printf("%s\n", ToJson(info).c_str());
  }
  std::fflush(stdout);
  return exit_code;
}

int RunHealth(const std::vector<std::string>& argv) {
  const absl::StatusOr<lane_tools::Args> args =
      lane_tools::Args::Parse(argv, {{"target"}, {"timeout"}, {"service"}});
  if (!args.ok()) return UsageError("health", std::string(args.status().message()), kHealthUsage);
  if (args->help()) {
    std::fputs(kHealthUsage, stdout);
    return kExitOk;
  }
  absl::StatusOr<CallSetup> setup = ParseCallSetup(*args);
  if (!setup.ok()) return UsageError("health", std::string(setup.status().message()), kHealthUsage);
  if (!args->Has("timeout")) setup->timeout = absl::Seconds(5);
  const std::string request_bytes = EncodeHealthRequest(args->Get("service").value_or(""));

  int exit_code = kExitOk;
  for (const std::string& target : setup->targets) {
    grpc::GenericStub stub(MakeChannel(target));
    grpc::ClientContext context;
    SetDeadline(&context, setup->timeout);
    // A message of zero bytes is still one (empty) slice.
    grpc::Slice slice(request_bytes.data(), request_bytes.size());
    const grpc::ByteBuffer request(&slice, 1);
    grpc::ByteBuffer response;
    grpc::Status status;
    grpc::CompletionQueue cq;
    std::unique_ptr<grpc::GenericClientAsyncResponseReader> call =
        stub.PrepareUnaryCall(&context, "/grpc.health.v1.Health/Check", request, &cq);
    call->StartCall();
    call->Finish(&response, &status, &cq);
    void* tag = nullptr;
    bool ok = false;
    // Finish always completes (at the latest at the deadline).
    while (cq.Next(&tag, &ok) && tag != &cq) {
    }
    cq.Shutdown();
    while (cq.Next(&tag, &ok)) {
    }
    if (!status.ok()) {
      exit_code = kExitFailure;
      std::printf("%s: %s\n", target.c_str(), StatusText(status).c_str());
      continue;
    }
    std::vector<grpc::Slice> slices;
    std::string bytes;
    if (response.Dump(&slices).ok()) {
      for (const grpc::Slice& s : slices) {
        bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
      }
    }
    const int serving = DecodeHealthStatus(bytes);
    if (serving != 1) exit_code = kExitFailure;
    std::printf("%s: %s\n", target.c_str(), HealthStatusName(serving));
  }
  std::fflush(stdout);
  return exit_code;
}

}  // namespace lane_client
