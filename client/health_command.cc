// `lane-client health`: the gRPC health check of each target.
#include <grpcpp/generic/generic_stub.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "common.h"

namespace lane::client {
namespace {

constexpr char kHealthDescription[] =
    "Asks the gRPC health service (grpc.health.v1.Health/Check) of each target\n"
    "about NAME (default \"\": the whole server) and prints its answer.";

constexpr char kHealthFooter[] =
    "Exit status: 0 when every target is SERVING, 1 otherwise (NOT_SERVING,\n"
    "unreachable, timed out), 2 for a bad command line.";

struct HealthFlags {
  CallFlags call;
  std::string service;
};

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

// Health/Check of one target: the answer's status (DecodeHealthStatus), or
// -1 with `status` set when the call failed.
int CheckOne(const std::string& target, const std::string& request_bytes, absl::Duration timeout,
             grpc::Status* status) {
  grpc::GenericStub stub(MakeChannel(target));
  grpc::ClientContext context;
  SetDeadline(&context, timeout);
  // A message of zero bytes is still one (empty) slice.
  grpc::Slice slice(request_bytes.data(), request_bytes.size());
  const grpc::ByteBuffer request(&slice, 1);
  grpc::ByteBuffer response;
  grpc::CompletionQueue cq;
  std::unique_ptr<grpc::GenericClientAsyncResponseReader> call =
      stub.PrepareUnaryCall(&context, "/grpc.health.v1.Health/Check", request, &cq);
  call->StartCall();
  call->Finish(&response, status, &cq);
  void* tag = nullptr;
  bool ok = false;
  // Finish always completes (at the latest at the deadline).
  while (cq.Next(&tag, &ok) && tag != &cq) {
  }
  cq.Shutdown();
  while (cq.Next(&tag, &ok)) {
  }
  if (!status->ok()) return -1;
  std::vector<grpc::Slice> slices;
  std::string bytes;
  if (response.Dump(&slices).ok()) {
    for (const grpc::Slice& s : slices) {
      bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
    }
  }
  return DecodeHealthStatus(bytes);
}

int RunHealth(const CLI::App& app, const HealthFlags& flags) {
  const absl::StatusOr<CallSetup> setup = ParseCallSetup(flags.call, absl::Seconds(5));
  if (!setup.ok()) return io::UsageError(app, std::string(setup.status().message()));
  const std::string request_bytes = EncodeHealthRequest(flags.service);
  int exit_code = kExitOk;
  for (const std::string& target : setup->targets) {
    grpc::Status status;
    const int serving = CheckOne(target, request_bytes, setup->timeout, &status);
    if (!status.ok()) {
      exit_code = kExitFailure;
      std::printf("%s: %s\n", target.c_str(), StatusText(status).c_str());
      continue;
    }
    if (serving != 1) exit_code = kExitFailure;
    std::printf("%s: %s\n", target.c_str(), HealthStatusName(serving));
  }
  std::fflush(stdout);
  return exit_code;
}

}  // namespace

Command AddHealthCommand(CLI::App& client) {
  auto flags = std::make_shared<HealthFlags>();
  CLI::App* app = io::AddCommand(client, "health", "gRPC health check (exit 0 when SERVING)",
                                 kHealthDescription, kHealthFooter);
  AddCallOptions(app, &flags->call, "5s");
  app->add_option("--service", flags->service, "the service to ask about")->type_name("NAME");
  return {app, [app, flags] { return RunHealth(*app, *flags); }};
}

}  // namespace lane::client
