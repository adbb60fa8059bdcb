#include "common.h"

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "wire/status_map.h"

namespace lane::client {

int Failure(const std::string& command, const std::string& message) {
  Note(command, message);
  return kExitFailure;
}

void Note(const std::string& command, const std::string& message) {
  io::PrintMessage("lane-client " + command, message);
}

CLI::Option* AddTargetOption(CLI::App* app, std::string* target, const std::string& description) {
  *target = kDefaultTarget;
  return app->add_option("--target", *target, description)->type_name("T");
}

void AddCallOptions(CLI::App* app, CallFlags* flags, const std::string& default_timeout) {
  AddTargetOption(app, &flags->target, "server address, or a comma list: every target is asked");
  io::AddDuration(app, "--timeout", &flags->timeout, "deadline of each call", default_timeout);
}

absl::StatusOr<CallSetup> ParseCallSetup(const CallFlags& flags, absl::Duration default_timeout) {
  CallSetup setup;
  absl::StatusOr<std::vector<std::string>> targets = SplitTargets(flags.target);
  if (!targets.ok()) return targets.status();
  setup.targets = *std::move(targets);
  setup.timeout = flags.timeout.value_or(default_timeout);
  return setup;
}

absl::StatusOr<std::vector<std::string>> SplitTargets(const std::string& spec) {
  if (absl::StartsWith(spec, "ipv4:") || absl::StartsWith(spec, "ipv6:") ||
      absl::StartsWith(spec, "unix:")) {
    return std::vector<std::string>{spec};
  }
  std::vector<std::string> targets;
  for (absl::string_view part : absl::StrSplit(spec, ',')) {
    part = absl::StripAsciiWhitespace(part);
    if (part.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat("--target has an empty entry: \"", spec, "\""));
    }
    targets.emplace_back(part);
  }
  return targets;
}

namespace {

Security& CurrentSecurity() {
  static Security* security = new Security();
  return *security;
}

absl::StatusOr<std::string> ReadFileText(const std::string& option, const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  if (!in || !(text << in.rdbuf())) {
    return absl::InvalidArgumentError(absl::StrCat("--", option, ": cannot read ", path));
  }
  return text.str();
}

// Adds "authorization: Bearer TOKEN" to every call of the channel.
class BearerInterceptor final : public grpc::experimental::Interceptor {
 public:
  explicit BearerInterceptor(const std::string* value) : value_(value) {}
  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(
            grpc::experimental::InterceptionHookPoints::PRE_SEND_INITIAL_METADATA)) {
      methods->GetSendInitialMetadata()->insert({"authorization", *value_});
    }
    methods->Proceed();
  }

 private:
  const std::string* const value_;
};

class BearerInterceptorFactory final
    : public grpc::experimental::ClientInterceptorFactoryInterface {
 public:
  explicit BearerInterceptorFactory(const std::string& token) : value_("Bearer " + token) {}
  grpc::experimental::Interceptor* CreateClientInterceptor(
      grpc::experimental::ClientRpcInfo* /*info*/) override {
    return new BearerInterceptor(&value_);
  }

 private:
  const std::string value_;
};

}  // namespace

void AddSecurityOptions(CLI::App& app, SecurityFlags* flags) {
  const std::string group = "Security (every command)";
  app.add_option("--ca", flags->ca, "PEM CA certificates: connect with TLS, verify the server")
      ->type_name("FILE")
      ->group(group);
  app.add_option("--cert", flags->cert, "PEM client certificate for mutual TLS (with --key, --ca)")
      ->type_name("FILE")
      ->group(group);
  app.add_option("--key", flags->key, "PEM private key of --cert")->type_name("FILE")->group(group);
  app.add_option("--token-file", flags->token_file,
                 "Bearer token sent with every call (first line of FILE); default: the "
                 "environment variable LANE_TOKEN")
      ->type_name("FILE")
      ->group(group);
  app.fallthrough();
}

absl::StatusOr<Security> LoadSecurity(const SecurityFlags& flags) {
  Security security;
  const std::pair<const char*, std::pair<const std::string*, std::string*>> files[] = {
      {"ca", {&flags.ca, &security.ca_pem}},
      {"cert", {&flags.cert, &security.cert_pem}},
      {"key", {&flags.key, &security.key_pem}},
      {"token-file", {&flags.token_file, &security.token}}};
  for (const auto& [option, paths] : files) {
    if (paths.first->empty()) continue;
    absl::StatusOr<std::string> text = ReadFileText(option, *paths.first);
    if (!text.ok()) return text.status();
    *paths.second = *std::move(text);
  }
  if (flags.token_file.empty()) {
    if (const char* env = std::getenv("LANE_TOKEN"); env != nullptr) security.token = env;
  }
  // The token: its first line, without surrounding whitespace.
  security.token = std::string(absl::StripAsciiWhitespace(
      absl::string_view(security.token).substr(0, security.token.find('\n'))));
  if (!flags.token_file.empty() && security.token.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("--token-file ", flags.token_file, " is empty"));
  }
  if (security.cert_pem.empty() != security.key_pem.empty()) {
    return absl::InvalidArgumentError("--cert and --key go together");
  }
  if (!security.cert_pem.empty() && security.ca_pem.empty()) {
    return absl::InvalidArgumentError("--cert/--key need --ca (TLS)");
  }
  return security;
}

absl::StatusOr<Security> TakeSecurityOptions(std::vector<std::string>& args) {
  CLI::App app;
  SecurityFlags flags;
  AddSecurityOptions(app, &flags);
  app.allow_extras();
  try {
    app.parse(std::vector<std::string>(args.rbegin(), args.rend()));
  } catch (const CLI::Error& e) {
    return absl::InvalidArgumentError(e.what());
  }
  absl::StatusOr<Security> security = LoadSecurity(flags);
  if (security.ok()) args = app.remaining();
  return security;
}

void SetSecurity(Security security) { CurrentSecurity() = std::move(security); }

bool HasToken() { return !CurrentSecurity().token.empty(); }

std::shared_ptr<grpc::Channel> MakeChannel(const std::string& target, int connection) {
  grpc::ChannelArguments args;
  args.SetLoadBalancingPolicyName("round_robin");
  args.SetMaxReceiveMessageSize(64 * 1024 * 1024);
  args.SetMaxSendMessageSize(-1);
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 100);
  // Despite its name, gRPC core takes this as the shortest deadline of one
  // connection attempt (TCP, TLS and the HTTP/2 settings): at 100 ms an
  // attempt on a busy machine, or to a proxy that is reloading, timed out
  // again and again ("tcp handshaker shutdown") and a stream stalled for a
  // minute behind nginx -s reload. The waits between attempts are the
  // initial and maximum backoffs.
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 2000);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 2000);
  // The server accepts pings every 10 s at most (--keepalive_min_client_interval).
  args.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, 20000);
  args.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 10000);
  // Channels otherwise share subchannels (and so TCP connections) process-wide.
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  args.SetInt("lane.client.connection", connection);
  const Security& security = CurrentSecurity();
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (!security.ca_pem.empty()) {
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = security.ca_pem;
    ssl.pem_cert_chain = security.cert_pem;
    ssl.pem_private_key = security.key_pem;
    credentials = grpc::SslCredentials(ssl);
  }
  std::vector<std::unique_ptr<grpc::experimental::ClientInterceptorFactoryInterface>> interceptors;
  if (!security.token.empty()) {
    interceptors.push_back(std::make_unique<BearerInterceptorFactory>(security.token));
  }
  return grpc::experimental::CreateCustomChannelWithInterceptors(target, credentials, args,
                                                                 std::move(interceptors));
}

void SetDeadline(grpc::ClientContext* context, absl::Duration timeout) {
  context->set_deadline(std::chrono::system_clock::now() + absl::ToChronoMilliseconds(timeout));
}

std::string StatusText(const grpc::Status& status) {
  const char* name = lane::wire::GrpcCodeName(status.error_code());
  if (status.ok() || status.error_message().empty()) return name;
  return absl::StrCat(name, ": ", status.error_message());
}

}  // namespace lane::client
