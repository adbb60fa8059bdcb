#include "test_util.h"

#include <arpa/inet.h>
#include <grpcpp/generic/generic_stub.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <future>
#include <thread>

namespace lane::server::testing {

ServerOptions TestServer::DefaultOptions() {
  ServerOptions options;
  options.address = "127.0.0.1:0";
  options.metrics_address = "";
  options.workers = 2;
  options.shutdown_deadline = absl::Seconds(20);
  options.build = CurrentBuildInfo();
  return options;
}

TestServer::TestServer(ServerOptions options)
    : registry_(std::make_shared<prometheus::Registry>()) {
  absl::StatusOr<std::unique_ptr<LaneServer>> server = LaneServer::Start(options, registry_);
  if (!server.ok()) {
    ADD_FAILURE() << "server did not start: " << server.status();
    return;
  }
  server_ = *std::move(server);
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 * 1024 * 1024);
  args.SetMaxSendMessageSize(64 * 1024 * 1024);
  channel_ = grpc::CreateCustomChannel(target(), grpc::InsecureChannelCredentials(), args);
  stub_ = v1::LaneService::NewStub(channel_);
}

TestServer::~TestServer() {
  stub_.reset();
  channel_.reset();
  if (server_ != nullptr) server_->Drain();
}

std::string TestServer::target() const { return "127.0.0.1:" + std::to_string(server_->port()); }

uint64_t TestServer::CreateSession(const std::string& camera_id, const v1::SessionConfig& config) {
  grpc::ClientContext context;
  v1::CreateSessionRequest request;
  request.set_camera_id(camera_id);
  *request.mutable_config() = config;
  v1::CreateSessionResponse response;
  const grpc::Status status = stub_->CreateSession(&context, request, &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return response.session().version();
}

grpc::Status CreateSessionStatus(v1::LaneService::Stub& stub, const std::string& camera_id,
                                 const v1::SessionConfig& config) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  v1::CreateSessionRequest request;
  request.set_camera_id(camera_id);
  *request.mutable_config() = config;
  v1::CreateSessionResponse response;
  return stub.CreateSession(&context, request, &response);
}

double MetricValue(const prometheus::Registry& registry, const std::string& name,
                   const std::vector<std::pair<std::string, std::string>>& labels) {
  double sum = 0;
  for (const prometheus::MetricFamily& family : registry.Collect()) {
    if (family.name != name) continue;
    for (const prometheus::ClientMetric& metric : family.metric) {
      bool match = true;
      for (const auto& [key, value] : labels) {
        bool found = false;
        for (const prometheus::ClientMetric::Label& label : metric.label) {
          if (label.name == key && label.value == value) found = true;
        }
        match = match && found;
      }
      if (!match) continue;
      switch (family.type) {
        case prometheus::MetricType::Counter:
          sum += metric.counter.value;
          break;
        case prometheus::MetricType::Gauge:
          sum += metric.gauge.value;
          break;
        case prometheus::MetricType::Histogram:
          sum += static_cast<double>(metric.histogram.sample_count);
          break;
        default:
          break;
      }
    }
  }
  return sum;
}

StreamResult RunStream(v1::LaneService::Stub& stub, const std::vector<v1::FrameRequest>& requests) {
  StreamResult result;
  grpc::ClientContext context;
  std::unique_ptr<grpc::ClientReaderWriter<v1::FrameRequest, v1::FrameResponse>> stream =
      stub.StreamFrames(&context);
  std::thread writer([&] {
    for (const v1::FrameRequest& request : requests) {
      if (!stream->Write(request)) break;  // the server ended the stream
    }
    stream->WritesDone();
  });
  v1::FrameResponse response;
  while (stream->Read(&response)) result.responses.push_back(response);
  writer.join();
  result.status = stream->Finish();
  return result;
}

namespace {
std::string BufferToString(const grpc::ByteBuffer& buffer);
}  // namespace

int HealthStatus(const std::shared_ptr<grpc::Channel>& channel) {
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  // HealthCheckRequest{service: ""} encodes to no bytes (one empty slice:
  // a ByteBuffer without slices is not a message).
  grpc::Slice empty;
  grpc::ByteBuffer request(&empty, 1);
  grpc::ByteBuffer response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                 [&done](grpc::Status status) { done.set_value(status); });
  const grpc::Status status = done.get_future().get();
  if (!status.ok()) return -1;
  const std::string bytes = BufferToString(response);
  // HealthCheckResponse{status = 1 (varint)}: 0x08 <value>; empty = UNKNOWN.
  if (bytes.empty()) return 0;
  if (bytes.size() != 2 || bytes[0] != 0x08) return -1;
  return bytes[1];
}

namespace {

std::string BufferToString(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  std::string bytes;
  if (!buffer.Dump(&slices).ok()) return bytes;
  for (const grpc::Slice& slice : slices) {
    bytes.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
  }
  return bytes;
}

}  // namespace

bool ReflectionListsLaneService(const std::shared_ptr<grpc::Channel>& channel) {
  grpc::GenericStub stub(channel);
  grpc::CompletionQueue cq;
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  auto call = stub.PrepareCall(
      &context, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", &cq);
  // Each step waits for its own completion.
  auto step = [&cq](intptr_t id) {
    void* tag = nullptr;
    bool ok = false;
    return cq.Next(&tag, &ok) && ok && reinterpret_cast<intptr_t>(tag) == id;
  };
  call->StartCall(reinterpret_cast<void*>(1));
  bool ok = step(1);
  // ServerReflectionRequest{list_services (field 7): ""}.
  const std::string request_bytes("\x3a\x00", 2);
  grpc::Slice slice(request_bytes.data(), request_bytes.size());
  grpc::ByteBuffer request(&slice, 1);
  if (ok) {
    call->Write(request, reinterpret_cast<void*>(2));
    ok = step(2);
  }
  grpc::ByteBuffer response;
  if (ok) {
    call->Read(&response, reinterpret_cast<void*>(3));
    ok = step(3);
  }
  call->WritesDone(reinterpret_cast<void*>(4));
  step(4);
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(5));
  step(5);
  cq.Shutdown();
  void* tag = nullptr;
  bool drained_ok = false;
  while (cq.Next(&tag, &drained_ok)) {
  }
  return ok && BufferToString(response).find("lane.v1.LaneService") != std::string::npos;
}

HttpResponse HttpFetch(int port, const std::string& path, const std::string& method) {
  HttpResponse response;
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return response;
  timeval timeout{5, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    close(fd);
    return response;
  }
  const std::string request = method + " " + path + " HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n";
  if (send(fd, request.data(), request.size(), MSG_NOSIGNAL) !=
      static_cast<ssize_t>(request.size())) {
    close(fd);
    return response;
  }
  std::string reply;
  char buffer[4096];
  for (;;) {
    const ssize_t n = recv(fd, buffer, sizeof(buffer), 0);
    if (n <= 0) break;
    reply.append(buffer, static_cast<size_t>(n));
  }
  close(fd);
  const size_t header_end = reply.find("\r\n\r\n");
  if (header_end == std::string::npos || reply.compare(0, 5, "HTTP/") != 0) return response;
  const size_t space = reply.find(' ');
  response.status = std::atoi(reply.c_str() + space + 1);
  response.headers = reply.substr(0, header_end);
  response.body = reply.substr(header_end + 4);
  return response;
}

}  // namespace lane::server::testing
