// `lane-client view`: the URL of the server's live view (lane-server
// --live_view), of one camera or of every session, printed and opened in a
// browser where there is one.
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "commands.h"
#include "common.h"
#include "lane/v1/lane_service.grpc.pb.h"

extern char** environ;

namespace lane::client {
namespace {

namespace v1 = lane::v1;

constexpr char kViewDescription[] =
    "Prints the URL of the live view of --camera (or, without it, of every session)\n"
    "and opens it with xdg-open when there is one and a display (--no-open: only\n"
    "print). The live view is on the server's metrics port (lane-server --live_view);\n"
    "the port comes from GetServerInfo and the host from --target, unless --view-url\n"
    "gives the base URL (a proxy, another host name). With Bearer tokens the URL is\n"
    "the login page, which asks for the token and then shows the camera: the token\n"
    "never goes into a URL.";

constexpr char kViewFooter[] =
    "Exit status: 0 when the URL was printed, 1 when the server could not be asked or\n"
    "its live view is off, 2 for a bad command line.";

struct ViewFlags {
  CallFlags call;
  std::string camera;
  std::string view_url;
  bool no_open = false;
};

// One URL path segment or query value, percent-encoded (a camera id's '/'
// included): the server decodes it back (lane-server's live_pages.cc).
std::string EncodeComponent(const std::string& text) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (const char c : text) {
    const bool plain = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                       c == '-' || c == '.' || c == '_' || c == '~';
    if (plain) {
      out += c;
    } else {
      const auto byte = static_cast<unsigned char>(c);
      out += '%';
      out += kHex[byte >> 4];
      out += kHex[byte & 15];
    }
  }
  return out;
}

// The host of a gRPC target ("host:port", "dns:///host:port", "[::1]:port").
std::string TargetHost(std::string target) {
  absl::string_view t = target;
  if (absl::ConsumePrefix(&t, "dns:")) {
    absl::ConsumePrefix(&t, "///");
    absl::ConsumePrefix(&t, "//");
  } else {
    absl::ConsumePrefix(&t, "ipv4:");
    absl::ConsumePrefix(&t, "ipv6:");
  }
  t = t.substr(0, t.find(','));
  if (absl::StartsWith(t, "[")) return std::string(t.substr(0, t.find(']') + 1));
  const size_t colon = t.rfind(':');
  return std::string(colon == absl::string_view::npos ? t : t.substr(0, colon));
}

// xdg-open in PATH and a display to open it on.
bool CanOpen() {
  if (std::getenv("DISPLAY") == nullptr && std::getenv("WAYLAND_DISPLAY") == nullptr) return false;
  const char* path = std::getenv("PATH");
  if (path == nullptr) return false;
  for (absl::string_view dir : absl::StrSplit(path, ':')) {
    if (!dir.empty() && access(absl::StrCat(dir, "/xdg-open").c_str(), X_OK) == 0) return true;
  }
  return false;
}

// Runs xdg-open URL (no shell) and waits for it.
bool OpenUrl(const std::string& url) {
  std::vector<std::string> args = {"xdg-open", url};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawnp(&pid, "xdg-open", nullptr, nullptr, argv.data(), environ) != 0) return false;
  int status = 0;
  return waitpid(pid, &status, 0) == pid && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

int RunView(const CLI::App& app, const ViewFlags& flags) {
  const absl::StatusOr<CallSetup> setup = ParseCallSetup(flags.call, absl::Seconds(10));
  if (!setup.ok()) return io::UsageError(app, std::string(setup.status().message()));
  const std::string& target = setup->targets.front();
  std::string base = flags.view_url;
  bool tokens = false;
  if (base.empty()) {
    const auto stub = v1::LaneService::NewStub(MakeChannel(target));
    grpc::ClientContext context;
    SetDeadline(&context, setup->timeout);
    v1::ServerInfo info;
    const grpc::Status status = stub->GetServerInfo(&context, v1::GetServerInfoRequest(), &info);
    if (!status.ok()) return Failure("view", absl::StrCat(target, ": ", StatusText(status)));
    if (info.live_view_port() == 0) {
      return Failure("view", absl::StrCat(target,
                                          ": the server's live view is off (start lane-server "
                                          "with --live_view), or it is older than the live view"));
    }
    base = absl::StrCat("http://", TargetHost(target), ":", info.live_view_port());
  }
  while (absl::EndsWith(base, "/")) base.pop_back();
  tokens = HasToken();
  const std::string page =
      flags.camera.empty() ? "/" : absl::StrCat("/cameras/", EncodeComponent(flags.camera));
  const std::string url =
      tokens ? absl::StrCat(base, "/login?next=", EncodeComponent(page)) : base + page;
  std::printf("%s\n", url.c_str());
  std::fflush(stdout);
  if (!flags.no_open && CanOpen() && !OpenUrl(url)) Note("view", "xdg-open failed");
  return kExitOk;
}

}  // namespace

Command AddViewCommand(CLI::App& client) {
  auto flags = std::make_shared<ViewFlags>();
  CLI::App* app = io::AddCommand(client, "view", "the live view's URL (and open it)",
                                 kViewDescription, kViewFooter);
  AddCallOptions(app, &flags->call, "10s");
  app->add_option("--camera", flags->camera, "the camera to show (default: every session)")
      ->type_name("ID");
  app->add_option("--view-url", flags->view_url,
                  "the live view's base URL (default: http://HOST:PORT from --target's host and "
                  "the port the server reports)")
      ->type_name("URL");
  app->add_flag("--no-open", flags->no_open, "only print the URL");
  return {app, [app, flags] { return RunView(*app, *flags); }};
}

}  // namespace lane::client
