// lane-server: the lane-marker detection service. See docs/service.md.
//
//   lane-server --default_config=configs/synthetic.json
#include <grpc/support/log.h>
#include <malloc.h>
#include <pthread.h>
#include <signal.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/flags/usage_config.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "auth.h"
#include "server.h"

ABSL_FLAG(std::string, address, "0.0.0.0:50051", "gRPC listening address (host:port).");
ABSL_FLAG(std::string, metrics_address, "0.0.0.0:9464",
          "Prometheus /metrics listening address (host:port); empty = no endpoint.");
ABSL_FLAG(int, workers, 0, "Worker threads that decode and detect; 0 = one per core.");
ABSL_FLAG(int, max_queued_tasks, 1024,
          "Unary Detect/CreateSession calls beyond this many queued tasks get "
          "RESOURCE_EXHAUSTED.");
ABSL_FLAG(int, max_inflight_frames, 8,
          "Default bound on a stream's frames received and not yet answered.");
ABSL_FLAG(int, max_sessions, 64, "Most sessions held; more is RESOURCE_EXHAUSTED.");
ABSL_FLAG(absl::Duration, session_ttl, absl::Hours(1),
          "Idle sessions are evicted after this long; 'inf' = never.");
ABSL_FLAG(int64_t, max_frame_pixels, int64_t{3840} * 2160,
          "Largest frame accepted, width * height (checked before decoding).");
ABSL_FLAG(absl::Duration, decode_cpu_budget, absl::Milliseconds(500),
          "CPU time one frame's decode may use (the worker thread's own CPU time: waiting for a "
          "core does not count, so a busy server never refuses a valid frame); beyond it the "
          "frame gets FRAME_CODE_RESOURCE_EXHAUSTED and the worker is free again (a noisy 4K "
          "progressive JPEG takes about 300 ms).");
ABSL_FLAG(absl::Duration, decode_deadline, absl::ZeroDuration(),
          "Old name of --decode_cpu_budget, kept as an alias: when set (not 0) it is used in "
          "its place. It is CPU time now, no longer wall-clock time.");
ABSL_FLAG(int, max_receive_message_bytes, 32 * 1024 * 1024,
          "gRPC maximum receive message size, bytes (a raw 1920x1080 BGR frame is 6220800, a "
          "3840x2160 one 24883200). Sessions whose camera's raw frame cannot fit are refused.");
ABSL_FLAG(int64_t, max_session_memory_mib, 1024,
          "Memory all sessions' detectors may hold together, MiB (a 160x120 top view holds "
          "about 0.5 MiB, a 2048x2048 one about 105 MiB); CreateSession beyond it is "
          "RESOURCE_EXHAUSTED. 0 = no budget.");
ABSL_FLAG(absl::Duration, keepalive_time, absl::Seconds(30), "Ping an idle connection this often.");
ABSL_FLAG(absl::Duration, keepalive_timeout, absl::Seconds(10),
          "Close a connection whose keepalive ping is not answered within this.");
ABSL_FLAG(absl::Duration, keepalive_min_client_interval, absl::Seconds(10),
          "Shortest interval between client pings the server accepts.");
ABSL_FLAG(bool, keepalive_permit_without_calls, true,
          "Allow keepalive pings on connections without calls.");
ABSL_FLAG(absl::Duration, max_connection_age, absl::InfiniteDuration(),
          "Rebalancing: connections older than this get a GOAWAY, and streams older than this "
          "(90-100 % of it, drawn per stream) answer what they received and end with "
          "UNAVAILABLE, so that clients reconnect and spread over the replicas there are now "
          "('inf': never).");
ABSL_FLAG(absl::Duration, max_connection_age_grace, absl::Seconds(30),
          "Time a draining stream of an aged connection gets to answer its frames before the "
          "transport cancels it.");
ABSL_FLAG(uint32_t, resume_state_every, 15,
          "Tracked streams: put the camera tracker's resume state into a response every this "
          "many frames (and into every response while draining); 0 = never.");
ABSL_FLAG(std::string, resume_state_key_file, "",
          "File of the key resume states are sealed with (HMAC-SHA-256), shared by every "
          "replica: one line of hex digits (`openssl rand -hex 32`), the current key, and "
          "optionally a second line, the previous key, still accepted while keys rotate "
          "(docs/deployment.md). The keys may instead come from the environment variable "
          "LANE_RESUME_STATE_KEYS (current[,previous], hex). Without either the server makes a "
          "random key at start, and a state resumes only on the replica that made it.");
ABSL_FLAG(absl::Duration, shutdown_deadline, absl::Seconds(10),
          "On SIGTERM/SIGINT: time for open streams to answer their frames before "
          "Shutdown cancels what remains.");
ABSL_FLAG(std::string, default_config, "",
          "JSON config file (format of configs/*.json) for a session created at start-up.");
ABSL_FLAG(std::string, default_camera_id, "default", "Camera id of the --default_config session.");
ABSL_FLAG(std::string, tls_cert, "",
          "PEM certificate chain of the server; with --tls_key, the server speaks TLS only.");
ABSL_FLAG(std::string, tls_key, "", "PEM private key of --tls_cert.");
ABSL_FLAG(std::string, tls_client_ca, "",
          "PEM CA certificates; when set, clients must present a certificate it signed "
          "(mutual TLS). Needs --tls_cert/--tls_key.");
ABSL_FLAG(std::string, auth_tokens_file, "",
          "File of accepted Bearer tokens, one per line ('#' comments). Tokens may also come "
          "from the environment variable LANE_AUTH_TOKENS (comma-separated); with neither, no "
          "token is needed. The health service never needs one.");
ABSL_FLAG(int, max_concurrent_streams, 0,
          "Calls (HTTP/2 streams) open at once per client connection; 0 = gRPC's default.");
ABSL_FLAG(int, opencv_threads, 1,
          "OpenCV's own threads per call; 1 because the worker pool already uses every core.");
ABSL_FLAG(int, malloc_keep_mib, 64,
          "Memory (MiB) glibc's allocator keeps for reuse instead of returning it to the "
          "kernel, and the size below which blocks come from its heaps. A raw frame's message "
          "is about 1 MB per 640x480 BGR frame; glibc's defaults map and unmap such blocks "
          "for every frame, and the page faults cost more than the detection (raw throughput "
          "x2-3). 0 keeps glibc's defaults.");

ABSL_FLAG(int, metrics_camera_labels, 0,
          "Per-camera metrics (lanesvc_camera_frames_total{camera,result}, "
          "lanesvc_camera_zero_lane_frames_total{camera}) for the first N camera ids seen; later "
          "ones share camera=\"_other\". 0 = off: camera ids come from clients, and every id is "
          "a series in Prometheus.");
ABSL_FLAG(bool, live_view, false,
          "Serve the live view on the metrics port: a page of every session (/) and of each "
          "camera (/cameras/ID: its latest frame and top view with the lanes, its lanes, a strip "
          "chart), with the Bearer-token check when tokens are set. Frames are kept and drawn "
          "only while someone watches. See docs/service.md, \"Live view\".");
ABSL_FLAG(double, live_view_fps, 5,
          "Live view: pictures drawn and JPEG-encoded per second per watched camera, at most "
          "(on the live view's own thread, never a frame worker).");
ABSL_FLAG(int, live_view_max_viewers, 4,
          "Live view: open pages at once (each holds a lease its requests renew, for 5 s after "
          "the last); one more is answered 503.");
ABSL_FLAG(std::string, log_format, "text",
          "How the server logs to stderr: text (one line per event, for people) or json (one "
          "JSON object per line with ts, level, logger, msg and the event's fields, for log "
          "pipelines).");

namespace {

// The server's log: a few events (start, signals, stop, fatal errors) on
// stderr, as text or as JSON lines. Fields are (name, value) pairs; a value
// is a string or a number.
class Log {
 public:
  using Field = std::pair<std::string, nlohmann::json>;
  explicit Log(bool json) : json_(json) {}

  void Info(const std::string& text, const std::string& msg, std::vector<Field> fields = {}) {
    Write("info", text, msg, std::move(fields));
  }
  // gRPC core's own log lines (json only: in text format gRPC prints its own).
  void Grpc(const char* level, const std::string& msg, std::vector<Field> fields) {
    Write(level, msg, msg, std::move(fields), "grpc");
  }
  void Error(const std::string& text, const std::string& msg, std::vector<Field> fields = {}) {
    Write("error", text, msg, std::move(fields));
  }

 private:
  // `text` is the line in text format; `msg` and `fields` the JSON event.
  void Write(const char* level, const std::string& text, const std::string& msg,
             std::vector<Field> fields, const char* logger = "lane-server") {
    absl::MutexLock lock(&mu_);
    if (!json_) {
      std::cerr << text << std::endl;
      return;
    }
    nlohmann::ordered_json event;
    event["ts"] = absl::FormatTime("%Y-%m-%dT%H:%M:%E3SZ", absl::Now(), absl::UTCTimeZone());
    event["level"] = level;
    event["logger"] = logger;
    event["msg"] = msg;
    for (auto& [name, value] : fields) event[name] = std::move(value);
    // Invalid UTF-8 (a path) is replaced, never a throw.
    std::cerr << event.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) << std::endl;
  }

  const bool json_;
  absl::Mutex mu_;  // one event at a time on stderr
};

// "--max-inflight-frames=8" -> "--max_inflight_frames=8": lane and
// lane-client spell flags with dashes, absl with underscores; the server takes
// both, so one spelling works on all three binaries. Only the name before '='
// changes; values are left alone, and so is everything after "--".
std::vector<std::string> NormalizeFlagNames(int argc, char** argv) {
  std::vector<std::string> args(argv, argv + argc);
  for (size_t i = 1; i < args.size(); ++i) {
    std::string& arg = args[i];
    if (arg == "--") break;
    if (arg.size() < 3 || arg[0] != '-') continue;
    const size_t start = arg[1] == '-' ? 2 : 1;
    const size_t end = std::min(arg.find('='), arg.size());
    for (size_t k = start; k < end; ++k) {
      if (arg[k] == '-') arg[k] = '_';
    }
  }
  return args;
}

Log* grpc_log_target = nullptr;  // set once before gRPC starts

void GrpcLogToJson(gpr_log_func_args* args) {
  const char* level = args->severity == GPR_LOG_SEVERITY_ERROR  ? "error"
                      : args->severity == GPR_LOG_SEVERITY_INFO ? "info"
                                                                : "debug";
  grpc_log_target->Grpc(level, args->message != nullptr ? args->message : "",
                        {{"file", args->file != nullptr ? args->file : ""}, {"line", args->line}});
}

// --decode_cpu_budget, or its old name --decode_deadline when that is set.
absl::Duration DecodeCpuBudgetFlag() {
  const absl::Duration old_name = absl::GetFlag(FLAGS_decode_deadline);
  return old_name != absl::ZeroDuration() ? old_name : absl::GetFlag(FLAGS_decode_cpu_budget);
}

// --help lists the flags of this file (the default filter expects a file
// named after the program); --version prints the build.
void ConfigureUsage(const lane::server::BuildInfo& build) {
  absl::FlagsUsageConfig usage;
  usage.contains_help_flags = [](absl::string_view file) {
    return absl::EndsWith(file, "server/main.cc");
  };
  // "Flags from server/main.cc", not the build machine's path.
  usage.normalize_filename = [](absl::string_view file) {
    const size_t at = file.rfind("server/main.cc");
    return std::string(at == absl::string_view::npos ? file : file.substr(at));
  };
  usage.version_string = [build] {
    return "lane-server " + build.version + " (git " + build.git_revision + ", " +
           build.build_type + ")\n";
  };
  absl::SetFlagsUsageConfig(usage);
  // absl prints the program's name before this.
  absl::SetProgramUsageMessage("lane-marker detection over gRPC. See docs/service.md.");
}

// The flags, read once, as the server's options; nothing is clamped here
// (ServerOptions::Validate says what is wrong). Errors: the token file.
absl::StatusOr<lane::server::ServerOptions> ServerOptionsFromFlags(
    const lane::server::BuildInfo& build) {
  lane::server::ServerOptions options;
  options.address = absl::GetFlag(FLAGS_address);
  options.metrics_address = absl::GetFlag(FLAGS_metrics_address);
  options.workers = absl::GetFlag(FLAGS_workers);
  options.max_queued_tasks =
      static_cast<size_t>(std::max(0, absl::GetFlag(FLAGS_max_queued_tasks)));
  options.max_inflight_frames =
      static_cast<uint32_t>(std::max(0, absl::GetFlag(FLAGS_max_inflight_frames)));
  options.max_sessions = static_cast<size_t>(std::max(0, absl::GetFlag(FLAGS_max_sessions)));
  options.session_ttl = absl::GetFlag(FLAGS_session_ttl);
  options.max_frame_pixels = absl::GetFlag(FLAGS_max_frame_pixels);
  options.decode_cpu_budget = DecodeCpuBudgetFlag();
  options.max_receive_message_bytes = absl::GetFlag(FLAGS_max_receive_message_bytes);
  const int64_t memory_mib = absl::GetFlag(FLAGS_max_session_memory_mib);
  if (memory_mib < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("--max_session_memory_mib ", memory_mib, ": must not be negative"));
  }
  options.max_session_memory_bytes = static_cast<uint64_t>(memory_mib) * 1024 * 1024;
  options.keepalive_time = absl::GetFlag(FLAGS_keepalive_time);
  options.keepalive_timeout = absl::GetFlag(FLAGS_keepalive_timeout);
  options.keepalive_min_client_interval = absl::GetFlag(FLAGS_keepalive_min_client_interval);
  options.keepalive_permit_without_calls = absl::GetFlag(FLAGS_keepalive_permit_without_calls);
  options.shutdown_deadline = absl::GetFlag(FLAGS_shutdown_deadline);
  options.max_connection_age = absl::GetFlag(FLAGS_max_connection_age);
  options.max_connection_age_grace = absl::GetFlag(FLAGS_max_connection_age_grace);
  options.resume_state_every = absl::GetFlag(FLAGS_resume_state_every);
  options.default_config_path = absl::GetFlag(FLAGS_default_config);
  options.default_camera_id = absl::GetFlag(FLAGS_default_camera_id);
  options.tls_cert_path = absl::GetFlag(FLAGS_tls_cert);
  options.tls_key_path = absl::GetFlag(FLAGS_tls_key);
  options.tls_client_ca_path = absl::GetFlag(FLAGS_tls_client_ca);
  options.max_concurrent_streams = absl::GetFlag(FLAGS_max_concurrent_streams);
  options.metrics_camera_labels =
      static_cast<size_t>(std::max(0, absl::GetFlag(FLAGS_metrics_camera_labels)));
  options.live_view = absl::GetFlag(FLAGS_live_view);
  options.live_view_fps = absl::GetFlag(FLAGS_live_view_fps);
  options.live_view_max_viewers = absl::GetFlag(FLAGS_live_view_max_viewers);
  // Tokens: never a command-line literal (visible in ps), never logged.
  if (const std::string path = absl::GetFlag(FLAGS_auth_tokens_file); !path.empty()) {
    absl::StatusOr<std::vector<std::string>> tokens = lane::server::ReadTokenFile(path);
    if (!tokens.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("--auth_tokens_file: ", tokens.status().message()));
    }
    options.auth_tokens = *std::move(tokens);
  }
  if (const char* env = std::getenv("LANE_AUTH_TOKENS"); env != nullptr) {
    for (std::string& token : lane::server::ParseTokenList(env)) {
      options.auth_tokens.push_back(std::move(token));
    }
  }
  if (const std::string path = absl::GetFlag(FLAGS_resume_state_key_file); !path.empty()) {
    absl::StatusOr<lane::server::ResumeStateKeys> keys =
        lane::server::ResumeStateKeys::ReadFile(path);
    if (!keys.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("--resume_state_key_file: ", keys.status().message()));
    }
    options.resume_state_keys = *std::move(keys);
  }
  // Keys: never a command-line literal (visible in ps), never logged.
  if (const char* env = std::getenv("LANE_RESUME_STATE_KEYS"); env != nullptr && *env != '\0') {
    if (options.resume_state_keys) {
      return absl::InvalidArgumentError(
          "both --resume_state_key_file and LANE_RESUME_STATE_KEYS are set; give one");
    }
    absl::StatusOr<lane::server::ResumeStateKeys> keys =
        lane::server::ResumeStateKeys::Parse(absl::StrReplaceAll(env, {{",", "\n"}}));
    if (!keys.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("LANE_RESUME_STATE_KEYS: ", keys.status().message()));
    }
    options.resume_state_keys = *std::move(keys);
  }
  options.build = build;
  return options;
}

// OpenCV's threads and glibc's allocator for a server of worker threads.
void ConfigureProcess() {
  cv::setNumThreads(absl::GetFlag(FLAGS_opencv_threads));
  if (const int keep = absl::GetFlag(FLAGS_malloc_keep_mib); keep > 0) {
    const int bytes = std::min(keep, 1024) * 1024 * 1024;
    // Blocks up to half of it (a raw 3840x2160 BGR frame, 24.9 MB, fits at
    // the default) come from the heaps and are reused; freed memory up to it
    // stays mapped; heaps grow a quarter of it at a time.
    mallopt(M_MMAP_THRESHOLD, std::min(bytes / 2, 32 * 1024 * 1024));  // glibc's maximum
    mallopt(M_TRIM_THRESHOLD, bytes);
    mallopt(M_TOP_PAD, bytes / 4);
  }
}

// The start-up event: ports, default session, security, workers.
void LogStarted(Log& log, const lane::server::LaneServer& server,
                const lane::server::ServerOptions& options) {
  std::string text =
      absl::StrCat("lane-server ", options.build.version, ": gRPC on port ", server.port());
  std::vector<Log::Field> fields = {{"version", options.build.version},
                                    {"git_revision", options.build.git_revision},
                                    {"grpc_port", server.port()}};
  if (server.metrics_port() >= 0) {
    absl::StrAppend(&text, ", metrics on port ", server.metrics_port());
    fields.emplace_back("metrics_port", server.metrics_port());
  }
  if (options.live_view) {
    absl::StrAppend(&text, ", live view on port ", server.metrics_port());
    fields.emplace_back("live_view", true);
  }
  if (!options.default_config_path.empty()) {
    absl::StrAppend(&text, ", session '", options.default_camera_id, "' from ",
                    options.default_config_path);
    fields.emplace_back("default_session", options.default_camera_id);
    fields.emplace_back("default_config", options.default_config_path);
  }
  const char* tls = options.tls_cert_path.empty()        ? "off"
                    : options.tls_client_ca_path.empty() ? "tls"
                                                         : "mutual_tls";
  if (!options.tls_cert_path.empty()) {
    absl::StrAppend(&text, options.tls_client_ca_path.empty() ? ", TLS" : ", mutual TLS");
  }
  fields.emplace_back("tls", tls);
  if (!options.auth_tokens.empty()) {
    absl::StrAppend(&text, ", ", options.auth_tokens.size(), " Bearer token(s)");
  }
  fields.emplace_back("bearer_tokens", options.auth_tokens.size());
  fields.emplace_back("workers", options.workers);
  if (!options.resume_state_keys) {
    absl::StrAppend(&text,
                    ", resume states sealed under a random key of this process (they resume "
                    "only on this replica: give every replica --resume_state_key_file)");
    fields.emplace_back("resume_state_key", "random");
  } else {
    absl::StrAppend(&text, ", shared resume-state key",
                    options.resume_state_keys->previous() ? " (with a previous key)" : "");
    fields.emplace_back("resume_state_key",
                        options.resume_state_keys->previous() ? "shared+previous" : "shared");
  }
  log.Info(text, "started", std::move(fields));
}

// SIGTERM and SIGINT are taken by a thread of ours (sigwait), so they are
// blocked before any other thread exists: every thread inherits the mask.
sigset_t BlockDrainSignals() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  return signals;
}

// First signal: drain. Second signal: exit at once.
void HandleDrainSignals(lane::server::LaneServer& server, Log& log, sigset_t signals) {
  std::thread([&server, &log, signals] {
    int signal = 0;
    sigwait(&signals, &signal);
    log.Info(absl::StrCat("lane-server: signal ", signal, ", draining"), "draining",
             {{"signal", signal}});
    std::thread([&server] { server.Drain(); }).detach();
    sigwait(&signals, &signal);
    log.Info("lane-server: second signal, exiting now", "exiting without draining",
             {{"signal", signal}});
    std::_Exit(1);
  }).detach();
}

}  // namespace

int main(int argc, char** argv) {
  const lane::server::BuildInfo build = lane::server::CurrentBuildInfo();
  ConfigureUsage(build);
  std::vector<std::string> normalized = NormalizeFlagNames(argc, argv);
  std::vector<char*> normalized_argv;
  for (std::string& arg : normalized) normalized_argv.push_back(arg.data());
  absl::ParseCommandLine(static_cast<int>(normalized_argv.size()), normalized_argv.data());
  const std::string log_format = absl::GetFlag(FLAGS_log_format);
  if (log_format != "text" && log_format != "json") {
    std::cerr << "lane-server: --log_format must be text or json, got '" << log_format << "'\n";
    return 2;
  }
  Log log(log_format == "json");
  if (log_format == "json") {
    grpc_log_target = &log;
    gpr_set_log_function(GrpcLogToJson);
  }
  const sigset_t signals = BlockDrainSignals();
  ConfigureProcess();

  absl::StatusOr<lane::server::ServerOptions> options = ServerOptionsFromFlags(build);
  if (options.ok()) {
    if (absl::Status s = options->Validate(); !s.ok()) options = s;
  }
  if (!options.ok()) {
    const std::string message(options.status().message());
    log.Error("lane-server: " + message, message);
    return 2;
  }
  auto registry = std::make_shared<prometheus::Registry>();
  absl::StatusOr<std::unique_ptr<lane::server::LaneServer>> started =
      lane::server::LaneServer::Start(*options, registry);
  if (!started.ok()) {
    const std::string message(started.status().message());
    log.Error(absl::StrCat("lane-server: ", started.status().ToString()), message,
              {{"code", absl::StatusCodeToString(started.status().code())}});
    return 1;
  }
  lane::server::LaneServer& server = **started;
  LogStarted(log, server, *options);
  HandleDrainSignals(server, log, signals);
  server.Wait();
  log.Info("lane-server: stopped", "stopped");
  return 0;
}
