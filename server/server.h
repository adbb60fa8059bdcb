// lane-server: the gRPC server (lane service, health, reflection), its worker
// pool, session registry, TTL sweeper and Prometheus endpoint, with the
// start-up and drain sequences.
#ifndef LANE_SERVER_SERVER_H_
#define LANE_SERVER_SERVER_H_

#include <grpcpp/grpcpp.h>
#include <prometheus/registry.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "http_endpoint.h"
#include "lane_service.h"
#include "live_view.h"
#include "metrics.h"
#include "resume_seal.h"
#include "session_registry.h"
#include "worker_pool.h"

namespace lane::server {

struct ServerOptions {
  // gRPC listening address; port 0 picks a free port (see LaneServer::port).
  std::string address = "0.0.0.0:50051";
  // HTTP listening address of /metrics (Prometheus), /healthz and /readyz;
  // empty = none. Port 0 picks a free port (see LaneServer::metrics_port).
  std::string metrics_address = "0.0.0.0:9464";
  // Worker threads for decoding and detection; 0 = one per core.
  int workers = 0;
  // Unary Detect / CreateSession calls beyond this many queued tasks are
  // RESOURCE_EXHAUSTED (streams are bounded by their in-flight limit).
  size_t max_queued_tasks = 1024;
  // Default bound on a stream's frames in flight (sessions may set theirs).
  uint32_t max_inflight_frames = 8;
  size_t max_sessions = 64;
  // Idle sessions are evicted after this; absl::InfiniteDuration() = never.
  absl::Duration session_ttl = absl::Hours(1);
  // Largest frame, width * height.
  int64_t max_frame_pixels = int64_t{3840} * 2160;
  // CPU-time budget of one frame's decode (the decoding thread's own CPU
  // time, not waiting); beyond it the frame is FRAME_CODE_RESOURCE_EXHAUSTED
  // (a backstop behind the decoder's limits).
  absl::Duration decode_cpu_budget = absl::Milliseconds(500);
  // 32 MiB: room for a raw BGR frame of max_frame_pixels (3840x2160 is
  // 24.9 MB). Sessions whose camera's raw frame cannot fit are refused.
  int max_receive_message_bytes = 32 * 1024 * 1024;
  // Memory all sessions' detectors may hold together, bytes; 0 = no budget.
  uint64_t max_session_memory_bytes = uint64_t{1} << 30;
  // HTTP/2 keepalive: ping an idle connection every keepalive_time, drop it
  // when a ping is not answered within keepalive_timeout; accept client pings
  // every keepalive_min_client_interval at most (also without calls when
  // keepalive_permit_without_calls).
  absl::Duration keepalive_time = absl::Seconds(30);
  absl::Duration keepalive_timeout = absl::Seconds(10);
  absl::Duration keepalive_min_client_interval = absl::Seconds(10);
  bool keepalive_permit_without_calls = true;
  // Rebalancing (docs/deployment.md): a connection older than
  // max_connection_age gets an HTTP/2 GOAWAY (its client opens a new one,
  // through the resolver or the proxy), and a stream older than it (drawn
  // within -10 %..+0 % per stream) stops reading at its next frame,
  // answers every frame it received and ends with UNAVAILABLE, so that its
  // client reconnects with its resume state. The transport cancels a call
  // still open max_connection_age + max_connection_age_grace after its
  // connection's GOAWAY (a stream drains within max_connection_age of its
  // start, so only a stream that needs longer than the grace to answer what
  // it received is cut). Infinite = never (the default).
  absl::Duration max_connection_age = absl::InfiniteDuration();
  absl::Duration max_connection_age_grace = absl::Seconds(30);
  // A tracked stream's responses carry the tracker's resume state every
  // this many frames (StreamOptions::resume_state_every); 0 = never.
  uint32_t resume_state_every = 15;
  // The keys resume states are sealed and opened with (resume_seal.h), the
  // same on every replica of a cluster (--resume_state_key_file). Unset: a
  // random key made at start, so states resume only on this process.
  std::optional<ResumeStateKeys> resume_state_keys;
  // Drain budget: streams get until this deadline to answer what they have
  // received, then Shutdown cancels whatever remains at the same deadline.
  absl::Duration shutdown_deadline = absl::Seconds(10);
  // Optional session created at start-up: a JSON config file (format of
  // lane::ParseConfig) under default_camera_id.
  std::string default_config_path;
  std::string default_camera_id = "default";
  // TLS: PEM files of the server's certificate chain and private key; both
  // empty = plaintext. With tls_client_ca, clients must present a
  // certificate signed by that CA (mutual TLS).
  std::string tls_cert_path;
  std::string tls_key_path;
  std::string tls_client_ca_path;
  // Accepted Bearer tokens; empty = no token needed. Health stays open.
  std::vector<std::string> auth_tokens;
  // HTTP/2 streams (calls) open at once per connection; 0 = gRPC's default.
  int max_concurrent_streams = 0;
  // Camera ids with series of their own in the per-camera metrics; 0 = no
  // per-camera metrics (see Metrics::CountCameraFrame).
  size_t metrics_camera_labels = 0;
  // The live view: web pages of every camera on the metrics port
  // (live_view.h). Off by default; needs metrics_address. Its tokens are
  // auth_tokens.
  bool live_view = false;
  // Pictures per second per watched camera, at most (--live_view_fps).
  double live_view_fps = 5;
  // Open pages at once (--live_view_max_viewers).
  int live_view_max_viewers = 4;
  // A viewer's lease and its camera's watch after its last request (no
  // flag: tests shorten it).
  absl::Duration live_view_lease = absl::Seconds(5);
  BuildInfo build;

  // OK, or INVALID_ARGUMENT naming the first option that makes no sense (by
  // its lane-server flag). LaneServer::Start refuses options that fail it;
  // nothing is clamped.
  absl::Status Validate() const;
};

class LaneServer {
 public:
  // Builds and starts everything. Health is NOT_SERVING, /readyz 503 (and
  // the lane service answers UNAVAILABLE) until the default session exists
  // and the metrics endpoint listens; then SERVING and 200.
  static absl::StatusOr<std::unique_ptr<LaneServer>> Start(
      const ServerOptions& options, std::shared_ptr<prometheus::Registry> registry);

  // Drain() if it has not run.
  ~LaneServer();

  LaneServer(const LaneServer&) = delete;
  LaneServer& operator=(const LaneServer&) = delete;

  // The first steps of the drain, without waiting: health NOT_SERVING and
  // /readyz 503; new
  // calls and streams refused with UNAVAILABLE; open streams stop reading,
  // answer every frame they have received and end with UNAVAILABLE. Starts
  // the shutdown deadline. Idempotent.
  void BeginDrain();
  // The whole drain: BeginDrain; wait for the open streams until the
  // deadline; grpc::Server::Shutdown with the same deadline (what is still
  // open then is cancelled); then the workers, the sweeper and the metrics
  // endpoint stop. Thread-safe and idempotent; returns when the server is
  // down.
  void Drain();
  // Blocks until a Drain (from another thread) has completed.
  void Wait();

  int port() const { return port_; }
  // Whether resume states are sealed under a random key of this process
  // (no ServerOptions::resume_state_keys): they resume only here.
  bool random_resume_key() const;
  // -1 without a metrics endpoint.
  int metrics_port() const { return metrics_port_; }
  SessionRegistry& sessions() { return *sessions_; }
  // Null without --live_view.
  LiveView* live_view() { return live_view_.get(); }
  LaneServiceImpl& service() { return *service_; }
  Metrics& metrics() { return *metrics_; }
  grpc::Server& grpc_server() { return *server_; }

 private:
  explicit LaneServer(const ServerOptions& options);
  // Start's steps: metrics, sessions, workers and the service; the gRPC
  // server (not yet serving); the HTTP endpoint, if any.
  void BuildService();
  absl::Status StartGrpc(const std::shared_ptr<grpc::ServerCredentials>& credentials);
  absl::Status StartHttp();
  void SweepLoop();

  const ServerOptions options_;
  std::shared_ptr<prometheus::Registry> registry_;
  std::unique_ptr<Metrics> metrics_;
  std::unique_ptr<SessionRegistry> sessions_;
  // After sessions_ (it holds a reference), before the service, the gRPC
  // server and the HTTP endpoint that call it (destroyed after them).
  std::unique_ptr<LiveView> live_view_;
  std::unique_ptr<WorkerPool> pool_;
  std::unique_ptr<LaneServiceImpl> service_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<HttpEndpoint> http_;
  int port_ = 0;
  int metrics_port_ = -1;
  std::atomic<bool> ready_{false};  // /readyz: serving and not draining

  std::thread sweeper_;
  bool Stopping() const ABSL_SHARED_LOCKS_REQUIRED(mu_) { return stopping_; }
  bool Drained() const ABSL_SHARED_LOCKS_REQUIRED(mu_) { return drained_; }
  mutable absl::Mutex mu_;
  // Conditions that other threads evaluate are members, not temporaries on
  // the waiter's stack: absl evaluates a waiter's Condition on the thread
  // that unlocks, inside its (uninstrumented) lock code, so TSan saw that
  // thread read the waiter's stack after the waiter had returned and reused
  // it (a loaded run of the suite, issue 40).
  const absl::Condition stopping_cond_{this, &LaneServer::Stopping};
  const absl::Condition drained_cond_{this, &LaneServer::Drained};
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;       // the sweeper stops
  bool draining_ ABSL_GUARDED_BY(mu_) = false;       // BeginDrain has run
  bool shutting_down_ ABSL_GUARDED_BY(mu_) = false;  // a Drain is past BeginDrain
  bool drained_ ABSL_GUARDED_BY(mu_) = false;
  absl::Time drain_deadline_ ABSL_GUARDED_BY(mu_);
};

// The build described by compile-time constants (version, build type,
// library versions).
BuildInfo CurrentBuildInfo();

// The live view's options from the server's (its flags, its tokens).
LiveViewOptions LiveViewOptionsOf(const ServerOptions& options);

}  // namespace lane::server

#endif  // LANE_SERVER_SERVER_H_
