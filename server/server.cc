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

// HTTP request threads of the metrics port: 2 for scrapes and probes, and
// with the live view 2 more per viewer (a page asks for its data and its
// pictures at once), at most 16 in all.
int HttpThreads(const ServerOptions& options) {
  return options.live_view ? std::min(16, 2 + 2 * options.live_view_max_viewers) : 2;
}

int ToMillis(absl::Duration d) {
  return static_cast<int>(std::min<int64_t>(absl::ToInt64Milliseconds(d), INT32_MAX));
}

}  // namespace

LiveViewOptions LiveViewOptionsOf(const ServerOptions& options) {
  LiveViewOptions live;
  live.fps = options.live_view_fps;
  live.max_viewers = options.live_view_max_viewers;
  live.lease = options.live_view_lease;
  live.auth_tokens = options.auth_tokens;
  return live;
}

BuildInfo CurrentBuildInfo() {
  BuildInfo info;
  info.version = LANE_VERSION;
  info.git_revision = LANE_GIT_REVISION;
  info.build_type = LANE_BUILD_TYPE;
  info.grpc_version = grpc::Version();
  info.opencv_version = CV_VERSION;
  return info;
}

absl::Status ServerOptions::Validate() const {
  const auto bad = [](absl::string_view flag, const auto& value, absl::string_view rule) {
    return absl::InvalidArgumentError(absl::StrCat("--", flag, " ", value, ": ", rule));
  };
  const auto positive = [](absl::Duration d) { return d > absl::ZeroDuration(); };
  if (address.empty()) return absl::InvalidArgumentError("--address must not be empty");
  if (workers < 0 || workers > 1024) return bad("workers", workers, "must lie in 0..1024");
  if (max_queued_tasks < 1) return bad("max_queued_tasks", max_queued_tasks, "must be at least 1");
  if (max_inflight_frames < 1 || max_inflight_frames > 4096) {
    return bad("max_inflight_frames", max_inflight_frames, "must lie in 1..4096");
  }
  if (max_sessions < 1) return bad("max_sessions", max_sessions, "must be at least 1");
  if (!positive(session_ttl)) {
    return bad("session_ttl", absl::FormatDuration(session_ttl), "must be positive ('inf': never)");
  }
  if (max_frame_pixels < 1) return bad("max_frame_pixels", max_frame_pixels, "must be positive");
  if (!positive(decode_cpu_budget)) {
    return bad("decode_cpu_budget", absl::FormatDuration(decode_cpu_budget), "must be positive");
  }
  if (max_receive_message_bytes < 1) {
    return bad("max_receive_message_bytes", max_receive_message_bytes, "must be positive");
  }
  for (const auto& [flag, d] :
       {std::pair<const char*, absl::Duration>{"keepalive_time", keepalive_time},
        {"keepalive_timeout", keepalive_timeout},
        {"keepalive_min_client_interval", keepalive_min_client_interval}}) {
    if (!positive(d)) return bad(flag, absl::FormatDuration(d), "must be positive");
  }
  if (!positive(max_connection_age)) {
    return bad("max_connection_age", absl::FormatDuration(max_connection_age),
               "must be positive ('inf': never)");
  }
  if (max_connection_age_grace < absl::ZeroDuration()) {
    return bad("max_connection_age_grace", absl::FormatDuration(max_connection_age_grace),
               "must not be negative");
  }
  if (resume_state_every > 1000000) {
    return bad("resume_state_every", resume_state_every, "must lie in 0..1000000");
  }
  if (shutdown_deadline < absl::ZeroDuration()) {
    return bad("shutdown_deadline", absl::FormatDuration(shutdown_deadline),
               "must not be negative");
  }
  if (!default_config_path.empty() && default_camera_id.empty()) {
    return absl::InvalidArgumentError("--default_camera_id must not be empty");
  }
  // The TLS files are checked as they are read (MakeCredentials).
  if (max_concurrent_streams < 0) {
    return bad("max_concurrent_streams", max_concurrent_streams, "must not be negative");
  }
  if (metrics_camera_labels > 10000) {
    return bad("metrics_camera_labels", metrics_camera_labels, "must lie in 0..10000");
  }
  if (live_view) {
    if (metrics_address.empty()) {
      return absl::InvalidArgumentError(
          "--live_view needs --metrics_address: its pages are served on the metrics port");
    }
    if (absl::Status s = LiveViewOptionsOf(*this).Validate(); !s.ok()) return s;
  }
  return absl::OkStatus();
}

LaneServer::LaneServer(const ServerOptions& options) : options_(options) {}

LaneServer::~LaneServer() { Drain(); }

bool LaneServer::random_resume_key() const { return !options_.resume_state_keys.has_value(); }

absl::StatusOr<std::unique_ptr<LaneServer>> LaneServer::Start(
    const ServerOptions& options, std::shared_ptr<prometheus::Registry> registry) {
  // Fail fast on bad options, TLS files or default config, before anything
  // listens.
  if (absl::Status s = options.Validate(); !s.ok()) return s;
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
  server->BuildService();
  if (absl::Status s = server->StartGrpc(*credentials); !s.ok()) return s;
  if (absl::Status s = server->StartHttp(); !s.ok()) return s;
  if (!options.default_config_path.empty()) {
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

void LaneServer::BuildService() {
  metrics_ = std::make_unique<Metrics>(*registry_, options_.build, options_.metrics_camera_labels);
  SessionRegistry::Options registry_options;
  registry_options.max_sessions = options_.max_sessions;
  registry_options.ttl = options_.session_ttl;
  registry_options.default_max_inflight_frames = options_.max_inflight_frames;
  registry_options.max_frame_pixels = options_.max_frame_pixels;
  registry_options.max_receive_message_bytes =
      static_cast<uint64_t>(options_.max_receive_message_bytes);
  registry_options.max_session_memory_bytes = options_.max_session_memory_bytes;
  const LiveViewOptions live_options = LiveViewOptionsOf(options_);
  if (options_.live_view) {
    registry_options.live_view_draw_interval_ns = live_options.DrawIntervalNs();
  }
  Metrics* metrics = metrics_.get();
  registry_options.on_size_change = [metrics](size_t n) {
    metrics->SetSessions(static_cast<double>(n));
  };
  sessions_ = std::make_unique<SessionRegistry>(std::move(registry_options));
  if (options_.live_view) live_view_ = std::make_unique<LiveView>(live_options, *sessions_);

  WorkerPool::Options pool_options;
  pool_options.threads = options_.workers;
  pool_options.max_queued = options_.max_queued_tasks;
  pool_ = std::make_unique<WorkerPool>(pool_options);

  ServiceOptions service_options;
  service_options.frame_limits.max_frame_pixels = options_.max_frame_pixels;
  service_options.frame_limits.decode_cpu_budget = options_.decode_cpu_budget;
  service_options.max_receive_message_bytes =
      static_cast<uint64_t>(options_.max_receive_message_bytes);
  service_options.auth_tokens = options_.auth_tokens;
  service_options.stream.resume_state_every = options_.resume_state_every;
  service_options.resume_seal = std::make_shared<ResumeStateSeal>(
      options_.resume_state_keys ? *options_.resume_state_keys : ResumeStateKeys::Random());
  service_options.stream.max_age = options_.max_connection_age;
  service_options.build = options_.build;
  service_options.live_view = live_view_.get();
  service_ = std::make_unique<LaneServiceImpl>(service_options, *sessions_, *pool_, *metrics_);
}

absl::Status LaneServer::StartGrpc(const std::shared_ptr<grpc::ServerCredentials>& credentials) {
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options_.address, credentials, &port_);
  builder.RegisterService(service_.get());
  builder.SetMaxReceiveMessageSize(options_.max_receive_message_bytes);
  // gRPC sets SO_REUSEPORT by default: a second server on a busy port would
  // then start and the kernel would split connections between the two. With
  // it off, a busy port fails here.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, ToMillis(options_.keepalive_time));
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, ToMillis(options_.keepalive_timeout));
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS,
                             options_.keepalive_permit_without_calls ? 1 : 0);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS,
                             ToMillis(options_.keepalive_min_client_interval));
  if (options_.max_connection_age != absl::InfiniteDuration()) {
    builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_AGE_MS,
                               ToMillis(options_.max_connection_age));
    // Streams drain within max_connection_age of their start (FrameStream),
    // which may be up to max_connection_age after the GOAWAY: the grace
    // counts from there.
    builder.AddChannelArgument(
        GRPC_ARG_MAX_CONNECTION_AGE_GRACE_MS,
        ToMillis(options_.max_connection_age + options_.max_connection_age_grace));
  }
  if (options_.max_concurrent_streams > 0) {
    builder.AddChannelArgument(GRPC_ARG_MAX_CONCURRENT_STREAMS, options_.max_concurrent_streams);
  }
  server_ = builder.BuildAndStart();
  if (server_ == nullptr || port_ == 0) {
    return absl::UnavailableError(absl::StrCat(
        "cannot listen on ", options_.address,
        ": the port is in use by another process (or the address is not this host's)"));
  }
  // Start-up: NOT_SERVING (the lane service answers UNAVAILABLE) until ready.
  server_->GetHealthCheckService()->SetServingStatus(false);
  return absl::OkStatus();
}

absl::Status LaneServer::StartHttp() {
  if (options_.metrics_address.empty()) return absl::OkStatus();
  HttpEndpoint::PageHandler pages;
  if (live_view_ != nullptr) {
    pages = [live = live_view_.get()](const HttpRequest& request) { return live->Handle(request); };
  }
  absl::StatusOr<std::unique_ptr<HttpEndpoint>> http = HttpEndpoint::Start(
      options_.metrics_address, HttpThreads(options_),
      {registry_, std::make_shared<ProcessMetrics>(),
       std::make_shared<CalibrationMetrics>(*sessions_)},
      [this] { return ready_.load(std::memory_order_acquire); }, std::move(pages));
  if (!http.ok()) {
    return absl::UnavailableError(absl::StrCat("cannot serve metrics: ", http.status().message()));
  }
  http_ = std::move(*http);
  metrics_port_ = http_->port();
  if (live_view_ != nullptr) service_->SetLiveViewPort(metrics_port_);
  return absl::OkStatus();
}

void LaneServer::SweepLoop() {
  const absl::Duration interval =
      std::clamp(options_.session_ttl / 4, absl::Milliseconds(10), absl::Seconds(1));
  absl::MutexLock lock(&mu_);
  while (!stopping_) {
    mu_.AwaitWithTimeout(stopping_cond_, interval);
    if (stopping_) break;
    mu_.Unlock();
    sessions_->EvictIdle();
    mu_.Lock();
  }
}

void LaneServer::BeginDrain() {
  {
    absl::MutexLock lock(&mu_);
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
    absl::MutexLock lock(&mu_);
    if (shutting_down_) {
      mu_.Await(drained_cond_);
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
    absl::MutexLock lock(&mu_);
    stopping_ = true;  // wakes the sweeper
  }
  if (sweeper_.joinable()) sweeper_.join();
  http_.reset();
  absl::MutexLock lock(&mu_);
  drained_ = true;  // wakes Wait and other Drains
}

void LaneServer::Wait() { absl::MutexLock lock(&mu_, drained_cond_); }

}  // namespace lane::server
