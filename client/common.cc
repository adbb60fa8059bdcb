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

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "wire/status_map.h"

namespace lane_client {

int UsageError(const std::string& command, const std::string& message, const char* usage) {
  std::fprintf(stderr, "lane-client %s: %s\n\n%s", command.c_str(), message.c_str(), usage);
  return kExitUsage;
}

int Failure(const std::string& command, const std::string& message) {
  Note(command, message);
  return kExitFailure;
}

void Note(const std::string& command, const std::string& message) {
  std::fprintf(stderr, "lane-client %s: %s\n", command.c_str(), message.c_str());
}

absl::StatusOr<std::optional<absl::Duration>> GetDuration(const lane_tools::Args& args,
                                                          const std::string& name) {
  const std::optional<std::string> text = args.Get(name);
  if (!text) return std::optional<absl::Duration>();
  absl::Duration d;
  double seconds = 0;
  if (absl::SimpleAtod(*text, &seconds) && std::isfinite(seconds)) {
    d = absl::Seconds(seconds);
  } else if (!absl::ParseDuration(*text, &d)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--", name, " must be a duration such as 500ms, 10s or 2.5, got \"", *text, "\""));
  }
  if (d < absl::ZeroDuration()) {
    return absl::InvalidArgumentError(absl::StrCat("--", name, " must not be negative"));
  }
  return std::optional<absl::Duration>(d);
}

absl::StatusOr<std::optional<double>> GetNumber(const lane_tools::Args& args,
                                                const std::string& name) {
  const std::optional<std::string> text = args.Get(name);
  if (!text) return std::optional<double>();
  double v = 0;
  if (!absl::SimpleAtod(*text, &v) || !std::isfinite(v) || v < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("--", name, " must be a non-negative number, got \"", *text, "\""));
  }
  return std::optional<double>(v);
}

absl::StatusOr<std::vector<int>> ParseIntList(const std::string& text, const std::string& name) {
  std::vector<int> out;
  for (absl::string_view part : absl::StrSplit(text, ',')) {
    int v = 0;
    if (!absl::SimpleAtoi(part, &v) || v <= 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--", name, " must be a comma-separated list of positive integers, got \"", text, "\""));
    }
    out.push_back(v);
  }
  return out;
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

const char kSecurityUsage[] =
    "security options (every command):\n"
    "  --ca FILE            PEM CA certificates: connect with TLS, verify the server\n"
    "  --cert FILE          PEM client certificate for mutual TLS (with --key, --ca)\n"
    "  --key FILE           PEM private key of --cert\n"
    "  --token-file FILE    Bearer token sent with every call (first line of FILE);\n"
    "                       default: the environment variable LANE_TOKEN\n";

absl::StatusOr<Security> TakeSecurityOptions(std::vector<std::string>& args) {
  static const char* const kNames[] = {"ca", "cert", "key", "token-file"};
  std::string paths[4];
  std::vector<std::string> rest;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "--") {
      rest.insert(rest.end(), args.begin() + static_cast<std::ptrdiff_t>(i), args.end());
      break;
    }
    bool taken = false;
    for (int k = 0; k < 4 && !taken; ++k) {
      const std::string flag = absl::StrCat("--", kNames[k]);
      if (arg == flag) {
        if (i + 1 >= args.size()) {
          return absl::InvalidArgumentError(absl::StrCat(flag, " needs a value"));
        }
        paths[k] = args[++i];
        taken = true;
      } else if (absl::StartsWith(arg, flag + "=")) {
        paths[k] = arg.substr(flag.size() + 1);
        taken = true;
      }
    }
    if (!taken) rest.push_back(arg);
  }
  Security security;
  std::string* const targets[] = {&security.ca_pem, &security.cert_pem, &security.key_pem,
                                  &security.token};
  for (int k = 0; k < 4; ++k) {
    if (paths[k].empty()) continue;
    absl::StatusOr<std::string> text = ReadFileText(kNames[k], paths[k]);
    if (!text.ok()) return text.status();
    *targets[k] = *std::move(text);
  }
  if (paths[3].empty()) {
    if (const char* env = std::getenv("LANE_TOKEN"); env != nullptr) security.token = env;
  }
  // The token: its first line, without surrounding whitespace.
  security.token = std::string(absl::StripAsciiWhitespace(
      absl::string_view(security.token).substr(0, security.token.find('\n'))));
  if (!paths[3].empty() && security.token.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("--token-file ", paths[3], " is empty"));
  }
  if (security.cert_pem.empty() != security.key_pem.empty()) {
    return absl::InvalidArgumentError("--cert and --key go together");
  }
  if (!security.cert_pem.empty() && security.ca_pem.empty()) {
    return absl::InvalidArgumentError("--cert/--key need --ca (TLS)");
  }
  args = std::move(rest);
  return security;
}

void SetSecurity(Security security) { CurrentSecurity() = std::move(security); }

std::shared_ptr<grpc::Channel> MakeChannel(const std::string& target, int connection) {
  grpc::ChannelArguments args;
  args.SetLoadBalancingPolicyName("round_robin");
  args.SetMaxReceiveMessageSize(64 * 1024 * 1024);
  args.SetMaxSendMessageSize(-1);
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 100);
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 100);
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

}  // namespace lane_client
