// The live view (--live_view) of a real server on loopback: only its routes,
// client strings escaped, tokens (header and login cookie), the viewer
// limit, nothing kept while nobody watches, the memory it counts, pictures
// of the stream's size with the last response's lanes, and a stalled viewer
// that does not slow a stream. The browser test (live_view_browser_test.py)
// looks at the same pages in Chromium.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "live_pages.h"
#include "test_util.h"

namespace lane::server::testing {
namespace {

struct LiveReply {
  int status = 0;
  std::string headers;
  std::string body;

  // The value of header `name` (case as sent), or "".
  std::string Header(const std::string& name) const {
    const std::string key = "\r\n" + name + ": ";
    const size_t at = headers.find(key);
    if (at == std::string::npos) return "";
    const size_t start = at + key.size();
    return headers.substr(start, headers.find("\r\n", start) - start);
  }
};

int LiveConnect(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  timeval timeout{10, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

// One HTTP/1.0 request with extra header lines ("Name: value\r\n"...).
LiveReply LiveFetch(int port, const std::string& method, const std::string& path,
                    const std::string& header_lines = "", const std::string& body = "") {
  LiveReply reply;
  const int fd = LiveConnect(port);
  if (fd < 0) return reply;
  std::string request = method + " " + path + " HTTP/1.0\r\nHost: 127.0.0.1\r\n" + header_lines;
  if (!body.empty()) request += "Content-Length: " + std::to_string(body.size()) + "\r\n";
  request += "\r\n" + body;
  send(fd, request.data(), request.size(), MSG_NOSIGNAL);
  std::string text;
  char buffer[8192];
  for (;;) {
    const ssize_t n = recv(fd, buffer, sizeof(buffer), 0);
    if (n <= 0) break;
    text.append(buffer, static_cast<size_t>(n));
  }
  close(fd);
  const size_t end = text.find("\r\n\r\n");
  if (end == std::string::npos || text.compare(0, 5, "HTTP/") != 0) return reply;
  reply.status = std::atoi(text.c_str() + text.find(' ') + 1);
  reply.headers = text.substr(0, end + 2);
  reply.body = text.substr(end + 4);
  return reply;
}

// A viewer that keeps asking for a camera's data (every 100 ms) until it is
// destroyed: its camera stays watched however slow the machine is.
class LiveWatcher {
 public:
  LiveWatcher(int port, const std::string& camera, const std::string& viewer)
      : thread_([this, port, camera, viewer] {
          while (!stop_.load()) {
            LiveFetch(port, "GET", "/api/cameras/" + camera + "?viewer=" + viewer);
            std::this_thread::sleep_for(std::chrono::milliseconds(100));
          }
        }) {}
  ~LiveWatcher() {
    stop_.store(true);
    thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

ServerOptions LiveOptions() {
  ServerOptions options = TestServer::DefaultOptions();
  options.metrics_address = "127.0.0.1:0";
  options.live_view = true;
  return options;
}

// Frames of a 320x240 camera with four painted lines.
std::vector<v1::FrameRequest> LiveFrames(const std::string& camera_id, int count,
                                         uint64_t first_id = 1) {
  const lane::CameraModel camera = ScaledCamera(0.5);
  std::vector<v1::FrameRequest> requests;
  std::vector<std::string> jpegs;
  for (int seed = 0; seed < 5; ++seed)
    jpegs.push_back(EncodeJpeg(RoadFrame(camera, kLineOffsets, seed)));
  for (int i = 0; i < count; ++i) {
    requests.push_back(
        JpegRequest(camera_id, first_id + static_cast<uint64_t>(i), jpegs[size_t(i) % 5]));
  }
  return requests;
}

TEST(LivePagesTest, EscapesAndEncodesClientStrings) {
  EXPECT_EQ(HtmlEscape("<script>alert('x')</script>"),
            "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;");
  EXPECT_EQ(HtmlEscape("\"><img onerror>&"), "&quot;&gt;&lt;img onerror&gt;&amp;");
  EXPECT_EQ(UrlEncodeSegment("../../etc/passwd"), "..%2F..%2Fetc%2Fpasswd");
  EXPECT_EQ(UrlEncodeSegment("cam 0:a?b#c"), "cam%200%3Aa%3Fb%23c");
  std::string decoded;
  ASSERT_TRUE(UrlDecode("..%2F..%2Fetc%2Fpasswd", false, &decoded));
  EXPECT_EQ(decoded, "../../etc/passwd");
  EXPECT_FALSE(UrlDecode("%2", false, &decoded));
  EXPECT_FALSE(UrlDecode("%zz", false, &decoded));
  EXPECT_FALSE(UrlDecode("a%00b", false, &decoded));
  EXPECT_EQ(QueryValue("a=1&token=x%2By+z&b=", "token"), "x+y z");
  EXPECT_EQ(QueryValue("a=1", "token"), "");

  const std::string hostile = "\"><img src=x onerror=alert(1)><script>alert(2)</script>";
  const std::string page = CameraPage(hostile, "0123", 1000, 200);
  EXPECT_EQ(page.find("<img src=x"), std::string::npos);
  EXPECT_EQ(page.find("<script>alert"), std::string::npos);
  EXPECT_NE(page.find("&quot;&gt;&lt;img src=x onerror=alert(1)&gt;"), std::string::npos);
  // The only script is the server's own file.
  EXPECT_NE(page.find("<script src=\"/live.js\" defer></script>"), std::string::npos);
  const std::string login = LoginPage("x", "/cameras/a\"b");
  EXPECT_EQ(login.find("a\"b"), std::string::npos);
}

TEST(LiveViewTest, IsOffByDefault) {
  ServerOptions options = TestServer::DefaultOptions();
  options.metrics_address = "127.0.0.1:0";
  TestServer server(options);
  ASSERT_FALSE(HasFailure());
  const int port = server.server().metrics_port();
  EXPECT_EQ(LiveFetch(port, "GET", "/").status, 404);
  EXPECT_EQ(LiveFetch(port, "GET", "/api/sessions").status, 404);
  EXPECT_EQ(server.server().live_view(), nullptr);
  grpc::ClientContext context;
  v1::ServerInfo info;
  ASSERT_TRUE(server.stub().GetServerInfo(&context, v1::GetServerInfoRequest(), &info).ok());
  EXPECT_EQ(info.live_view_port(), 0u);
}

TEST(LiveViewTest, NeedsTheMetricsPortAndSaneFlags) {
  ServerOptions options = LiveOptions();
  options.metrics_address = "";
  EXPECT_FALSE(options.Validate().ok());
  options = LiveOptions();
  options.live_view_max_viewers = 0;
  EXPECT_NE(options.Validate().message().find("--live_view_max_viewers"), absl::string_view::npos);
  options = LiveOptions();
  options.live_view_fps = 0;
  EXPECT_NE(options.Validate().message().find("--live_view_fps"), absl::string_view::npos);
}

TEST(LiveViewTest, ServesOnlyItsRoutes) {
  ServerOptions options = LiveOptions();
  options.live_view_max_viewers = 64;  // every request below is a viewer of its own
  TestServer server(options);
  ASSERT_FALSE(HasFailure());
  const int port = server.server().metrics_port();
  const LiveReply index = LiveFetch(port, "GET", "/");
  EXPECT_EQ(index.status, 200);
  EXPECT_NE(index.Header("Content-Security-Policy").find("script-src 'self'"), std::string::npos);
  EXPECT_EQ(index.Header("X-Content-Type-Options"), "nosniff");
  EXPECT_NE(index.body.find("<table id=\"sessions\">"), std::string::npos);
  EXPECT_EQ(LiveFetch(port, "GET", "/live.js").status, 200);
  EXPECT_EQ(LiveFetch(port, "GET", "/live.css").status, 200);
  EXPECT_EQ(LiveFetch(port, "GET", "/api/sessions").status, 200);
  // Beside the pages, the metrics port still serves what it served.
  EXPECT_EQ(LiveFetch(port, "GET", "/healthz").body, "ok\n");
  EXPECT_NE(LiveFetch(port, "GET", "/metrics").body.find("lanesvc_frames_received_total"),
            std::string::npos);
  // Nothing else: no files, no listings.
  for (const std::string path :
       {"/nothing", "/cameras/", "/cameras/nope", "/cameras/nope/frame.jpg", "/api/cameras/nope",
        "/../../etc/passwd", "/cameras/..%2F..%2Fetc%2Fpasswd", "/%2e%2e/%2e%2e/etc/passwd",
        "/etc/passwd", "/live.js/", "/api/", "/index.html", "/server/"}) {
    const LiveReply reply = LiveFetch(port, "GET", path);
    EXPECT_EQ(reply.status, 404) << path;
    EXPECT_EQ(reply.body.find("root:"), std::string::npos) << path;
  }
  EXPECT_EQ(LiveFetch(port, "POST", "/").status, 405);
  EXPECT_EQ(LiveFetch(port, "DELETE", "/cameras/nope").status, 405);
  grpc::ClientContext context;
  v1::ServerInfo info;
  ASSERT_TRUE(server.stub().GetServerInfo(&context, v1::GetServerInfoRequest(), &info).ok());
  EXPECT_EQ(static_cast<int>(info.live_view_port()), port);
}

TEST(LiveViewTest, RefusesOrEscapesHostileCameraIds) {
  TestServer server(LiveOptions());
  ASSERT_FALSE(HasFailure());
  const int port = server.server().metrics_port();
  const v1::SessionConfig config = SessionConfigFor(ScaledCamera(0.5));
  for (const std::string id : {"<script>", "\"><img onerror>", "<script>alert(1)</script>"}) {
    EXPECT_EQ(CreateSessionStatus(server.stub(), id, config).error_code(),
              grpc::StatusCode::INVALID_ARGUMENT)
        << id;
  }
  // A valid id that looks like a path: a session, never a file.
  server.CreateSession("../../etc/passwd", config);
  const LiveReply page = LiveFetch(port, "GET", "/cameras/..%2F..%2Fetc%2Fpasswd");
  EXPECT_EQ(page.status, 200);
  EXPECT_NE(page.body.find("<h1 id=\"camera\">../../etc/passwd</h1>"), std::string::npos);
  EXPECT_EQ(page.body.find("root:"), std::string::npos);
  const LiveReply api = LiveFetch(port, "GET", "/api/cameras/..%2F..%2Fetc%2Fpasswd");
  EXPECT_EQ(api.status, 200);
  EXPECT_EQ(nlohmann::json::parse(api.body)["camera_id"], "../../etc/passwd");
  // Ids in the URL that no session can have are not echoed unescaped.
  const LiveReply reflected =
      LiveFetch(port, "GET", "/cameras/%3Cscript%3Ealert(1)%3C%2Fscript%3E");
  EXPECT_EQ(reflected.status, 404);
  EXPECT_EQ(reflected.body.find("<script>alert"), std::string::npos);
  const LiveReply attribute = LiveFetch(port, "GET", "/cameras/%22%3E%3Cimg%20onerror%3E");
  EXPECT_EQ(attribute.status, 404);
  EXPECT_EQ(attribute.body.find("<img onerror>"), std::string::npos);
}

TEST(LiveViewTest, TokensGuardEveryPage) {
  const std::string token = "live-token-7f3a9c";
  ServerOptions options = LiveOptions();
  options.auth_tokens = {token};
  options.live_view_max_viewers = 64;
  options.default_config_path = std::string(LANE_SOURCE_DIR) + "/configs/synthetic.json";
  options.default_camera_id = "cam0";
  TestServer server(options);
  ASSERT_FALSE(HasFailure());
  const int port = server.server().metrics_port();
  for (const std::string path : {"/", "/cameras/cam0", "/cameras/cam0/frame.jpg",
                                 "/cameras/cam0/top.jpg", "/api/sessions", "/api/cameras/cam0"}) {
    const LiveReply none = LiveFetch(port, "GET", path);
    EXPECT_EQ(none.status, 401) << path;
    EXPECT_EQ(none.body.find(token), std::string::npos);
    EXPECT_EQ(LiveFetch(port, "GET", path, "Authorization: Bearer wrong-token\r\n").status, 401)
        << path;
    EXPECT_EQ(LiveFetch(port, "GET", path, "Cookie: lane_live=v1.99999999999.00\r\n").status, 401)
        << path;
    EXPECT_NE(LiveFetch(port, "GET", path, "Authorization: Bearer " + token + "\r\n").status, 401)
        << path;
  }
  EXPECT_NE(LiveFetch(port, "GET", "/").body.find("<form method=\"post\" action=\"/login\">"),
            std::string::npos);
  // The script and style hold no data: no token needed.
  EXPECT_EQ(LiveFetch(port, "GET", "/live.js").status, 200);

  // The login step: a sealed cookie, a redirect that drops the token, and
  // only local paths to go back to.
  const LiveReply login =
      LiveFetch(port, "GET", "/login?token=" + token + "&next=%2Fcameras%2Fcam0");
  EXPECT_EQ(login.status, 303);
  EXPECT_EQ(login.Header("Location"), "/cameras/cam0");
  const std::string set_cookie = login.Header("Set-Cookie");
  EXPECT_NE(set_cookie.find("HttpOnly"), std::string::npos);
  EXPECT_NE(set_cookie.find("SameSite=Strict"), std::string::npos);
  EXPECT_EQ(set_cookie.find(token), std::string::npos);
  const std::string cookie = set_cookie.substr(0, set_cookie.find(';'));
  EXPECT_EQ(LiveFetch(port, "GET", "/cameras/cam0", "Cookie: " + cookie + "\r\n").status, 200);
  std::string tampered = cookie;
  tampered.back() = tampered.back() == '0' ? '1' : '0';
  EXPECT_EQ(LiveFetch(port, "GET", "/", "Cookie: " + tampered + "\r\n").status, 401);
  EXPECT_EQ(LiveFetch(port, "GET", "/login?token=" + token + "&next=%2F%2Fevil.example")
                .Header("Location"),
            "/");
  const std::string form = "Content-Type: application/x-www-form-urlencoded\r\n";
  EXPECT_EQ(LiveFetch(port, "POST", "/login", form, "token=nope&next=%2F").status, 401);
  const LiveReply posted = LiveFetch(port, "POST", "/login", form, "token=" + token + "&next=%2F");
  EXPECT_EQ(posted.status, 303);
  EXPECT_FALSE(posted.Header("Set-Cookie").empty());
}

TEST(LiveViewTest, LimitsViewers) {
  ServerOptions options = LiveOptions();
  options.live_view_max_viewers = 1;
  TestServer server(options);
  ASSERT_FALSE(HasFailure());
  const int port = server.server().metrics_port();
  const LiveReply first = LiveFetch(port, "GET", "/");
  ASSERT_EQ(first.status, 200);
  const std::string viewer = first.Header("X-Viewer");
  ASSERT_EQ(viewer.size(), 32u);
  EXPECT_NE(first.body.find("data-viewer=\"" + viewer + "\""), std::string::npos);
  const LiveReply second = LiveFetch(port, "GET", "/");
  EXPECT_EQ(second.status, 503);
  EXPECT_NE(second.body.find("--live_view_max_viewers 1"), std::string::npos);
  EXPECT_EQ(second.Header("Retry-After"), "5");
  EXPECT_EQ(LiveFetch(port, "GET", "/api/sessions").status, 503);
  // The viewer that holds the lease goes on.
  EXPECT_EQ(LiveFetch(port, "GET", "/?viewer=" + viewer).status, 200);
  EXPECT_EQ(LiveFetch(port, "GET", "/api/sessions?viewer=" + viewer).status, 200);
  EXPECT_EQ(server.server().live_view()->viewers(), 1u);
}

TEST(LiveViewTest, AViewerWatchesOneCameraAtATime) {
  TestServer server(LiveOptions());
  ASSERT_FALSE(HasFailure());
  const int port = server.server().metrics_port();
  const v1::SessionConfig config = SessionConfigFor(ScaledCamera(0.5));
  server.CreateSession("cam0", config);
  server.CreateSession("cam1", config);
  const LiveReply first = LiveFetch(port, "GET", "/cameras/cam0");
  ASSERT_EQ(first.status, 200);
  const std::string viewer = first.Header("X-Viewer");
  EXPECT_EQ(server.server().live_view()->watched_cameras(), 1u);
  ASSERT_EQ(LiveFetch(port, "GET", "/api/cameras/cam1?viewer=" + viewer).status, 200);
  const std::shared_ptr<Session> cam0 = server.server().sessions().Peek("cam0");
  const std::shared_ptr<Session> cam1 = server.server().sessions().Peek("cam1");
  EXPECT_FALSE(cam0->live->Watched(absl::GetCurrentTimeNanos()));
  EXPECT_TRUE(cam1->live->Watched(absl::GetCurrentTimeNanos()));
  EXPECT_TRUE(PollUntil([&] { return server.server().live_view()->watched_cameras() == 1; }, 10));
}

TEST(LiveViewTest, KeepsNothingUnwatchedAndDrawsWhatIsWatched) {
  ServerOptions options = LiveOptions();
  options.live_view_lease = absl::Milliseconds(500);
  options.live_view_fps = 20;
  TestServer server(options);
  ASSERT_FALSE(HasFailure());
  const int port = server.server().metrics_port();
  const lane::CameraModel camera = ScaledCamera(0.5);
  server.CreateSession("cam0", SessionConfigFor(camera));
  const std::shared_ptr<Session> session = server.server().sessions().Peek("cam0");
  ASSERT_NE(session, nullptr);
  ASSERT_NE(session->live, nullptr);
  const uint64_t unwatched_bytes = server.server().sessions().memory_bytes();

  // Nobody watches: counted, nothing kept, nothing drawn.
  StreamResult unwatched = RunStream(server.stub(), LiveFrames("cam0", 10));
  ASSERT_TRUE(unwatched.status.ok()) << unwatched.status.error_message();
  EXPECT_FALSE(session->live->HoldsFrame());
  EXPECT_FALSE(session->live->LastResponse().has_value());
  EXPECT_EQ(server.server().live_view()->watched_cameras(), 0u);
  EXPECT_EQ(server.server().sessions().memory_bytes(), unwatched_bytes);
  const nlohmann::json sessions =
      nlohmann::json::parse(LiveFetch(port, "GET", "/api/sessions").body);
  ASSERT_EQ(sessions["sessions"].size(), 1u);
  EXPECT_EQ(sessions["sessions"][0]["frames_total"], 10);

  // Watched: the memory is counted, frames are drawn at the stream's size,
  // and the lanes table is the last response's.
  const LiveReply page = LiveFetch(port, "GET", "/cameras/cam0");
  ASSERT_EQ(page.status, 200);
  const std::string viewer = page.Header("X-Viewer");
  EXPECT_GT(server.server().sessions().memory_bytes(), unwatched_bytes);
  auto watcher = std::make_unique<LiveWatcher>(port, "cam0", viewer);
  StreamResult watched = RunStream(server.stub(), LiveFrames("cam0", 20, 100));
  ASSERT_TRUE(watched.status.ok());
  ASSERT_EQ(watched.responses.size(), 20u);
  ASSERT_TRUE(PollUntil([&] { return session->live->pictures() != nullptr; }, 10));
  const LiveReply jpeg = LiveFetch(port, "GET", "/cameras/cam0/frame.jpg?viewer=" + viewer);
  ASSERT_EQ(jpeg.status, 200);
  EXPECT_EQ(jpeg.Header("Content-Type"), "image/jpeg");
  const cv::Mat picture = cv::imdecode(
      cv::Mat(1, static_cast<int>(jpeg.body.size()), CV_8UC1, const_cast<char*>(jpeg.body.data())),
      cv::IMREAD_COLOR);
  EXPECT_EQ(picture.cols, camera.image_width);
  EXPECT_EQ(picture.rows, camera.image_height);
  const std::string seq = jpeg.Header("X-Picture-Seq");
  EXPECT_EQ(
      LiveFetch(port, "GET", "/cameras/cam0/frame.jpg?viewer=" + viewer + "&after=" + seq).status,
      204);
  EXPECT_EQ(LiveFetch(port, "GET", "/cameras/cam0/top.jpg?viewer=" + viewer).status, 200);
  const nlohmann::json data =
      nlohmann::json::parse(LiveFetch(port, "GET", "/api/cameras/cam0?viewer=" + viewer).body);
  const v1::FrameResponse& last = watched.responses.back();
  ASSERT_FALSE(data["last_response"].is_null());
  EXPECT_EQ(data["last_response"]["frame_id"], last.frame_id());
  ASSERT_EQ(data["last_response"]["lanes"].size(), static_cast<size_t>(last.lanes_size()));
  ASSERT_GT(last.lanes_size(), 0);
  for (int i = 0; i < last.lanes_size(); ++i) {
    EXPECT_EQ(data["last_response"]["lanes"][i]["id"], last.lanes(i).id());
    EXPECT_DOUBLE_EQ(data["last_response"]["lanes"][i]["score"].get<double>(),
                     last.lanes(i).score());
  }
  EXPECT_EQ(data["width"], camera.image_width);

  // The viewer leaves, the watch lapses: the pictures and the memory go.
  watcher.reset();
  EXPECT_TRUE(PollUntil(
      [&] {
        return server.server().live_view()->watched_cameras() == 0 &&
               !session->live->HoldsFrame() &&
               server.server().sessions().memory_bytes() == unwatched_bytes;
      },
      10));
}

TEST(LiveViewTest, AStalledViewerDoesNotSlowTheStream) {
  ServerOptions options = LiveOptions();
  options.live_view_max_viewers = 8;
  TestServer server(options);
  ASSERT_FALSE(HasFailure());
  const int port = server.server().metrics_port();
  server.CreateSession("cam0", SessionConfigFor(ScaledCamera(0.5)));
  const std::vector<v1::FrameRequest> frames = LiveFrames("cam0", 400);
  const auto timed = [&] {
    const auto start = std::chrono::steady_clock::now();
    StreamResult result = RunStream(server.stub(), frames);
    EXPECT_TRUE(result.status.ok());
    EXPECT_EQ(result.responses.size(), frames.size());
    for (const v1::FrameResponse& r : result.responses) {
      EXPECT_EQ(r.status().code(), v1::FRAME_CODE_OK);
    }
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  // A viewer watches throughout (the camera is drawn in both runs).
  const LiveReply page = LiveFetch(port, "GET", "/cameras/cam0");
  ASSERT_EQ(page.status, 200);
  LiveWatcher watcher(port, "cam0", page.Header("X-Viewer"));
  timed();  // warm-up
  const double before = timed();

  // Another viewer stalls: its sockets ask for pictures and never read (a
  // receive buffer of 1 KiB), and more connect and send nothing.
  std::vector<int> stalled;
  for (int i = 0; i < 6; ++i) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    const int small = 1024;
    setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof(small));
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
    if (i % 2 == 0) {
      const std::string request = "GET /cameras/cam0/frame.jpg HTTP/1.0\r\n\r\n";
      send(fd, request.data(), request.size(), MSG_NOSIGNAL);
    }
    stalled.push_back(fd);
  }
  const double during = timed();
  for (const int fd : stalled) close(fd);
  // Generous bounds for a shared machine: the stream is not held up by the
  // stalled viewer (a stream that waited for it would take the 10 s request
  // timeout).
  EXPECT_LT(during, 1.5 * before + 1.0) << "before " << before << " s";
  std::printf("400 frames: %.3f s before, %.3f s with a stalled viewer\n", before, during);
}

}  // namespace
}  // namespace lane::server::testing
