// `lane-client session create|get|list|delete` and `info`.
#include <google/protobuf/util/json_util.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "commands.h"
#include "common.h"
#include "lane/v1/lane_service.grpc.pb.h"
#include "session_config.h"
#include "wire/camera_id.h"

namespace lane::client {
namespace {

namespace v1 = lane::v1;

constexpr char kSessionDescription[] =
    "Manages the service's sessions (a camera's calibration and detector\n"
    "options). Prints the server's answer as JSON, one line per target.\n"
    "create is idempotent: the same config again is UNCHANGED.";

constexpr char kSessionFooter[] =
    "Exit status: 0 when every call succeeded, 1 otherwise, 2 for a bad command\n"
    "line.";

std::string ToJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  std::string json;
  if (!google::protobuf::util::MessageToJsonString(message, &json, options).ok()) return "{}";
  return json;
}

enum class Action { kCreate, kGet, kList, kDelete };

struct SessionFlags {
  Action action = Action::kList;
  CallFlags call;
  std::string camera;
  SessionConfigFlags config;  // create
  bool replace = false;       // create
};

// One call of `action` on `stub`; `json` is the answer to print.
grpc::Status CallSession(const SessionFlags& flags, const v1::SessionConfig* config,
                         v1::LaneService::Stub& stub, grpc::ClientContext* context,
                         std::string* json) {
  const auto answer = [json](const grpc::Status& status, const google::protobuf::Message& reply) {
    *json = ToJson(reply);
    return status;
  };
  switch (flags.action) {
    case Action::kCreate: {
      v1::CreateSessionRequest request;
      request.set_camera_id(flags.camera);
      *request.mutable_config() = *config;
      request.set_replace(flags.replace);
      v1::CreateSessionResponse response;
      return answer(stub.CreateSession(context, request, &response), response);
    }
    case Action::kGet: {
      v1::GetSessionRequest request;
      request.set_camera_id(flags.camera);
      v1::Session response;
      return answer(stub.GetSession(context, request, &response), response);
    }
    case Action::kList: {
      v1::ListSessionsResponse response;
      return answer(stub.ListSessions(context, v1::ListSessionsRequest(), &response), response);
    }
    case Action::kDelete:
      break;
  }
  v1::DeleteSessionRequest request;
  request.set_camera_id(flags.camera);
  v1::DeleteSessionResponse response;
  *json = absl::StrCat("{\"deleted\":\"", flags.camera, "\"}");
  return stub.DeleteSession(context, request, &response);
}

int RunSession(const CLI::App& app, const SessionFlags& flags) {
  const std::string command = "session " + app.get_name();
  const absl::StatusOr<CallSetup> setup = ParseCallSetup(flags.call, absl::Seconds(10));
  if (!setup.ok()) return io::UsageError(app, std::string(setup.status().message()));
  if (flags.action != Action::kList) {
    // The server's rule, checked before the id goes out (and into the
    // x-camera-id header a proxy reads).
    if (const absl::Status id = lane::wire::ValidateCameraId(flags.camera); !id.ok()) {
      return io::UsageError(app, absl::StrCat("--camera: ", id.message()));
    }
  }
  std::optional<v1::SessionConfig> config;
  if (flags.action == Action::kCreate) {
    absl::StatusOr<std::optional<v1::SessionConfig>> parsed =
        SessionConfigFromFlags(flags.config, true);
    if (!parsed.ok()) return Failure(command, std::string(parsed.status().message()));
    config = **parsed;
  }

  int exit_code = kExitOk;
  for (const std::string& target : setup->targets) {
    const auto stub = v1::LaneService::NewStub(MakeChannel(target));
    grpc::ClientContext context;
    SetDeadline(&context, setup->timeout);
    // For a proxy's camera affinity (deploy/nginx): the replica that holds
    // the camera's streams answers its session calls.
    if (!flags.camera.empty()) context.AddMetadata(kCameraIdHeader, flags.camera);
    std::string json;
    const grpc::Status status =
        CallSession(flags, config ? &*config : nullptr, *stub, &context, &json);
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

int RunInfo(const CLI::App& app, const CallFlags& flags) {
  const absl::StatusOr<CallSetup> setup = ParseCallSetup(flags, absl::Seconds(10));
  if (!setup.ok()) return io::UsageError(app, std::string(setup.status().message()));
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

}  // namespace

std::vector<Command> AddSessionCommands(CLI::App& client) {
  CLI::App* session = io::AddCommand(client, "session", "manage camera sessions",
                                     kSessionDescription, kSessionFooter);
  session->require_subcommand(1);
  struct ActionInfo {
    Action action;
    const char* name;
    const char* summary;
  };
  const ActionInfo actions[] = {
      {Action::kCreate, "create", "create (or confirm) a camera's session"},
      {Action::kGet, "get", "the session of a camera"},
      {Action::kList, "list", "every session"},
      {Action::kDelete, "delete", "delete a camera's session"}};
  std::vector<Command> commands;
  for (const ActionInfo& info : actions) {
    auto flags = std::make_shared<SessionFlags>();
    flags->action = info.action;
    CLI::App* app =
        io::AddCommand(*session, info.name, info.summary, kSessionDescription, kSessionFooter);
    AddCallOptions(app, &flags->call, "10s");
    if (info.action != Action::kList) {
      app->add_option("--camera", flags->camera, "the camera id")->type_name("ID")->required();
    }
    if (info.action == Action::kCreate) {
      AddSessionConfigOptions(app, &flags->config);
      app->add_flag("--replace", flags->replace, "replace a session with a different config");
    }
    commands.push_back({app, [app, flags] { return RunSession(*app, *flags); }});
  }
  return commands;
}

Command AddInfoCommand(CLI::App& client) {
  auto flags = std::make_shared<CallFlags>();
  CLI::App* app =
      io::AddCommand(client, "info", "the server's version, limits and defaults",
                     "Prints the server's version, formats, limits and detector defaults\n"
                     "(GetServerInfo) as JSON.");
  AddCallOptions(app, flags.get(), "10s");
  return {app, [app, flags] { return RunInfo(*app, *flags); }};
}

}  // namespace lane::client
