#include "server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>

#include <algorithm>
#include <exception>
#include <fstream>
#include <opencv2/core/version.hpp>
#include <sstream>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "calibration_metrics.h"
#include "lane/config/config.h"
#include "process_metrics.h"

#ifndef LANE_VERSION
#define LANE_VERSION "0.0.0"
#endif
#ifndef LANE_GIT_REVISION
#define LANE_GIT_REVISION "unknown"
#endif
#ifndef LANE_BUILD_TYPE
#define LANE_BUILD_TYPE "unknown"
#endif

namespace lane::server {
namespace {

absl::StatusOr<std::string> ReadPem(const std::string& flag, const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  if (!in || !(text << in.rdbuf())) {
    return absl::InvalidArgumentError(absl::StrCat(flag, ": cannot read ", path));
  }
  return text.str();
}

absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> MakeCredentials(
    const ServerOptions& options) {
  if (options.tls_cert_path.empty() && options.tls_key_path.empty()) {
    if (!options.tls_client_ca_path.empty()) {
      return absl::InvalidArgumentError("--tls_client_ca needs --tls_cert and --tls_key");
    }
    return grpc::InsecureServerCredentials();
  }
  if (options.tls_cert_path.empty() || options.tls_key_path.empty()) {
    return absl::InvalidArgumentError("--tls_cert and --tls_key go together");
  }
  absl::StatusOr<std::string> cert = ReadPem("--tls_cert", options.tls_cert_path);
  if (!cert.ok()) return cert.status();
  absl::StatusOr<std::string> key = ReadPem("--tls_key", options.tls_key_path);
  if (!key.ok()) return key.status();
  grpc::SslServerCredentialsOptions ssl(GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE);
  ssl.pem_key_cert_pairs.push_back({*key, *cert});
  if (!options.tls_client_ca_path.empty()) {
    absl::StatusOr<std::string> ca = ReadPem("--tls_client_ca", options.tls_client_ca_path);
    if (!ca.ok()) return ca.status();
    ssl.pem_root_certs = *ca;
    ssl.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
  }
  return grpc::SslServerCredentials(ssl);
}

int ToMillis(absl::Duration d) {
  return static_cast<int>(std::min<int64_t>(absl::ToInt64Milliseconds(d), INT32_MAX));
}

}  // namespace

BuildInfo CurrentBuildInfo() {
  BuildInfo info;
  info.version = LANE_VERSION;
  info.git_revision = LANE_GIT_REVISION;
  info.build_type = LANE_BUILD_TYPE;
  info.grpc_version = grpc::Version();
  info.opencv_version = CV_VERSION;
  return info;
}

LaneServer::LaneServer(const ServerOptions& options) : options_(options) {}

LaneServer::~LaneServer() { Drain(); }

absl::StatusOr<std::unique_ptr<LaneServer>> LaneServer::Start(
    const ServerOptions& options, std::shared_ptr<prometheus::Registry> registry) {
  // Fail fast on bad TLS files or a bad default config, before anything
  // listens.
  absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> credentials = MakeCredentials(options);
  if (!credentials.ok()) return credentials.status();
  absl::StatusOr<lane::Config> default_config;
  if (!options.default_config_path.empty()) {
    default_config = lane::LoadConfigFile(options.default_config_path);
    if (!default_config.ok()) {
      return absl::InvalidArgumentError(absl::StrCat("--default_config ",
                                                     options.default_config_path, ": ",
                                                     default_config.status().message()));
    }
  }

  std::unique_ptr<LaneServer> server(new LaneServer(options));
  server->registry_ = registry ? std::move(registry) : std::make_shared<prometheus::Registry>();
  server->metrics_ =
      std::make_unique<Metrics>(*server->registry_, options.build, options.metrics_camera_labels);

  SessionRegistry::Options registry_options;
  registry_options.max_sessions = options.max_sessions;
  registry_options.ttl = options.session_ttl;
  registry_options.default_max_inflight_frames = std::max<uint32_t>(1, options.max_inflight_frames);
  registry_options.max_frame_pixels = options.max_frame_pixels;
  registry_options.max_receive_message_bytes =
      static_cast<uint64_t>(std::max(0, options.max_receive_message_bytes));
  registry_options.max_session_memory_bytes = options.max_session_memory_bytes;
  Metrics* metrics = server->metrics_.get();
  registry_options.on_size_change = [metrics](size_t n) {
    metrics->SetSessions(static_cast<double>(n));
  };
  server->sessions_ = std::make_unique<SessionRegistry>(std::move(registry_options));

  WorkerPool::Options pool_options;
  pool_options.threads = options.workers;
  pool_options.max_queued = options.max_queued_tasks;
  server->pool_ = std::make_unique<WorkerPool>(pool_options);

  ServiceOptions service_options;
  service_options.frame_limits.max_frame_pixels = options.max_frame_pixels;
  service_options.frame_limits.decode_cpu_budget = options.decode_cpu_budget;
  service_options.max_receive_message_bytes =
      static_cast<uint64_t>(std::max(0, options.max_receive_message_bytes));
  service_options.auth_tokens = options.auth_tokens;
  service_options.build = options.build;
  server->service_ = std::make_unique<LaneServiceImpl>(service_options, *server->sessions_,
                                                       *server->pool_, *server->metrics_);

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options.address, *credentials, &server->port_);
  builder.RegisterService(server->service_.get());
  builder.SetMaxReceiveMessageSize(options.max_receive_message_bytes);
  // gRPC sets SO_REUSEPORT by default: a second server on a busy port would
  // then start and the kernel would split connections between the two. With
  // it off, a busy port fails here.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, ToMillis(options.keepalive_time));
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, ToMillis(options.keepalive_timeout));
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS,
                             options.keepalive_permit_without_calls ? 1 : 0);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS,
                             ToMillis(options.keepalive_min_client_interval));
  if (options.max_concurrent_streams > 0) {
    builder.AddChannelArgument(GRPC_ARG_MAX_CONCURRENT_STREAMS, options.max_concurrent_streams);
  }
  server->server_ = builder.BuildAndStart();
  if (server->server_ == nullptr || server->port_ == 0) {
    return absl::UnavailableError(absl::StrCat(
        "cannot listen on ", options.address,
        ": the port is in use by another process (or the address is not this host's)"));
  }
  // Start-up: NOT_SERVING (the lane service answers UNAVAILABLE) until ready.
  server->server_->GetHealthCheckService()->SetServingStatus(false);

  if (!options.metrics_address.empty()) {
    absl::StatusOr<std::unique_ptr<HttpEndpoint>> http = HttpEndpoint::Start(
        options.metrics_address, 2,
        {server->registry_, std::make_shared<ProcessMetrics>(),
         std::make_shared<CalibrationMetrics>(*server->sessions_)},
        [s = server.get()] { return s->ready_.load(std::memory_order_acquire); });
    if (!http.ok()) {
      return absl::UnavailableError(
          absl::StrCat("cannot serve metrics: ", http.status().message()));
    }
    server->http_ = std::move(*http);
    server->metrics_port_ = server->http_->port();
  }

  if (default_config.ok() && !options.default_config_path.empty()) {
    absl::StatusOr<SessionRegistry::CreateResult> created =
        server->sessions_->Create(options.default_camera_id,
                                  SessionSpec{*default_config, StreamPolicy{}, DecodePolicy{},
                                              CalibrationPolicy{}, TrackingPolicy{}},
                                  false);
    if (!created.ok()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--default_config ", options.default_config_path, ": ", created.status().message()));
    }
  }

  if (options.session_ttl != absl::InfiniteDuration()) {
    server->sweeper_ = std::thread([s = server.get()] { s->SweepLoop(); });
  }

  server->service_->SetServing();
  server->server_->GetHealthCheckService()->SetServingStatus(true);
  server->ready_.store(true, std::memory_order_release);
  return server;
}

void LaneServer::SweepLoop() {
  const absl::Duration interval =
      std::clamp(options_.session_ttl / 4, absl::Milliseconds(10), absl::Seconds(1));
  std::unique_lock<std::mutex> lock(mu_);
  while (!stopping_) {
    cv_.wait_for(lock, absl::ToChronoMilliseconds(interval), [this] { return stopping_; });
    if (stopping_) break;
    lock.unlock();
    sessions_->EvictIdle();
    lock.lock();
  }
}

void LaneServer::BeginDrain() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (draining_) return;
    draining_ = true;
    drain_deadline_ = absl::Now() + options_.shutdown_deadline;
  }
  // 1. Health NOT_SERVING, /readyz 503.
  ready_.store(false, std::memory_order_release);
  if (server_ != nullptr) server_->GetHealthCheckService()->SetServingStatus(false);
  // 2. New calls and streams are refused; open streams stop reading.
  if (service_ != nullptr) service_->StartDrain();
}

void LaneServer::Drain() {
  BeginDrain();
  absl::Time deadline;
  {
    std::unique_lock<std::mutex> lock(mu_);
    if (shutting_down_) {
      cv_.wait(lock, [this] { return drained_; });
      return;
    }
    shutting_down_ = true;
    deadline = drain_deadline_;
  }
  // 3. Open streams answer every frame they have received, then end.
  if (service_ != nullptr) service_->WaitForStreams(deadline);
  // 4. Shutdown with the deadline: calls still open then are cancelled.
  if (server_ != nullptr) server_->Shutdown(absl::ToChronoTime(deadline));
  // Tasks still queued only release their streams (the calls are over).
  if (pool_ != nullptr) pool_->Shutdown();
  {
    std::lock_guard<std::mutex> lock(mu_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (sweeper_.joinable()) sweeper_.join();
  http_.reset();
  {
    std::lock_guard<std::mutex> lock(mu_);
    drained_ = true;
  }
  cv_.notify_all();
}

void LaneServer::Wait() {
  std::unique_lock<std::mutex> lock(mu_);
  cv_.wait(lock, [this] { return drained_; });
}

}  // namespace lane::server
