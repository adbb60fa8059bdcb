#include "live_view.h"

#include <openssl/evp.h>
#include <sys/random.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "absl/time/clock.h"
#include "auth.h"
#include "live_draw.h"
#include "live_pages.h"
#include "wire/detection_proto.h"

namespace lane::server {
namespace {

using LiveJson = nlohmann::ordered_json;

constexpr char kCookieName[] = "lane_live";
constexpr char kCookiePurpose[] = "lane-server live view login|v1|";
constexpr size_t kViewerIdChars = 32;

std::string RandomBytes(size_t n) {
  std::string bytes(n, '\0');
  size_t got = 0;
  while (got < n) {
    const ssize_t r = getrandom(bytes.data() + got, n - got, 0);
    if (r > 0) got += static_cast<size_t>(r);
  }
  return bytes;
}

std::string Hex(absl::string_view bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  for (const char c : bytes) {
    const auto b = static_cast<unsigned char>(c);
    out += kDigits[b >> 4];
    out += kDigits[b & 15];
  }
  return out;
}

bool IsViewerId(absl::string_view id) {
  if (id.size() != kViewerIdChars) return false;
  for (const char c : id) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

// A local path to return to after the login: "/" unless `next` is a path
// on this server made of URL characters (no scheme, no "//host", no header
// breaks).
std::string SafeNext(absl::string_view next) {
  if (next.empty() || next[0] != '/' || absl::StartsWith(next, "//") || next.size() > 1024) {
    return "/";
  }
  for (const char c : next) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    absl::string_view("-._~/%?=&:").find(c) != absl::string_view::npos;
    if (!ok) return "/";
  }
  return std::string(next);
}

HttpReply Page(int status, std::string body) {
  HttpReply reply;
  reply.status = status;
  reply.content_type = "text/html; charset=utf-8";
  reply.body = std::move(body);
  reply.headers = LivePageHeaders();
  return reply;
}

HttpReply JsonReply(int status, const LiveJson& json) {
  HttpReply reply;
  reply.status = status;
  reply.content_type = "application/json; charset=utf-8";
  reply.body = json.dump(-1, ' ', false, LiveJson::error_handler_t::replace);
  reply.headers = LivePageHeaders();
  return reply;
}

HttpReply JsonError(int status, absl::string_view message) {
  return JsonReply(status, LiveJson{{"error", std::string(message)}});
}

}  // namespace

absl::Status LiveViewOptions::Validate() const {
  if (!(fps > 0 && fps <= 60)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--live_view_fps ", fps, ": must lie in (0, 60]"));
  }
  if (max_viewers < 1 || max_viewers > 64) {
    return absl::InvalidArgumentError(
        absl::StrCat("--live_view_max_viewers ", max_viewers, ": must lie in 1..64"));
  }
  if (jpeg_quality < 1 || jpeg_quality > 100) {
    return absl::InvalidArgumentError("live view JPEG quality must lie in 1..100");
  }
  if (lease <= absl::ZeroDuration())
    return absl::InvalidArgumentError("live view lease must be positive");
  return absl::OkStatus();
}

int64_t LiveViewOptions::DrawIntervalNs() const {
  return static_cast<int64_t>(std::llround(1e9 / fps));
}

LiveView::LiveView(LiveViewOptions options, SessionRegistry& sessions)
    : options_(std::move(options)), sessions_(sessions), cookie_key_(RandomBytes(32)) {
  drawer_ = std::thread([this] { DrawLoop(); });
}

LiveView::~LiveView() {
  {
    absl::MutexLock lock(&mu_);
    stopping_ = true;
  }
  drawer_.join();
}

void LiveView::Record(const std::shared_ptr<Session>& session, const v1::FrameResponse& response,
                      LiveFrame sample) {
  if (session == nullptr || session->live == nullptr) return;
  if (!session->live->Record(response, std::move(sample), absl::GetCurrentTimeNanos())) return;
  absl::MutexLock lock(&mu_);
  posted_.push_back(session);
}

void LiveView::DrawLoop() {
  for (;;) {
    std::vector<std::weak_ptr<Session>> posted;
    {
      absl::MutexLock lock(&mu_);
      // Asleep while nothing is watched; while something is, awake at least
      // every second to drop lapsed watches.
      if (watched_.empty()) {
        mu_.Await(has_work_);
      } else {
        mu_.AwaitWithTimeout(has_work_, absl::Seconds(1));
      }
      if (stopping_) return;
      woken_ = false;
      posted.swap(posted_);
    }
    for (const std::weak_ptr<Session>& weak : posted) {
      if (std::shared_ptr<Session> session = weak.lock()) Draw(session);
    }
    ExpireWatches();
  }
}

void LiveView::Draw(const std::shared_ptr<Session>& session) {
  std::optional<LiveSample> sample = session->live->TakeSample();
  if (!sample || sample->frame.empty()) return;
  const std::shared_ptr<const lane::Detector> detector = session->CurrentDetector();
  auto pictures = std::make_shared<LivePictures>();
  try {
    const LiveDrawing drawing = DrawLiveSample(*sample, *detector);
    const std::vector<int> params = {cv::IMWRITE_JPEG_QUALITY, options_.jpeg_quality};
    std::vector<uchar> bytes;
    // Each picture at most its raw size (LivePictureBytes counts that).
    if (!drawing.frame.empty() && cv::imencode(".jpg", drawing.frame, bytes, params) &&
        bytes.size() <= drawing.frame.total() * 3) {
      pictures->frame_jpeg.assign(bytes.begin(), bytes.end());
    }
    if (!drawing.top.empty() && cv::imencode(".jpg", drawing.top, bytes, params) &&
        bytes.size() <= drawing.top.total() * 3) {
      pictures->top_jpeg.assign(bytes.begin(), bytes.end());
    }
  } catch (const cv::Exception&) {
    return;  // keeps the previous pictures
  }
  if (pictures->frame_jpeg.empty()) return;
  pictures->frame_id = sample->response.frame_id();
  pictures->drawn_unix_ns = absl::GetCurrentTimeNanos();
  absl::MutexLock lock(&mu_);
  // A watch that lapsed while this was drawn keeps nothing.
  if (watched_.count(session.get()) == 0) return;
  pictures->seq = next_picture_seq_++;
  session->live->SetPictures(std::move(pictures));
}

void LiveView::ExpireWatches() {
  const int64_t now_ns = absl::GetCurrentTimeNanos();
  absl::MutexLock lock(&mu_);
  for (auto it = watched_.begin(); it != watched_.end();) {
    std::shared_ptr<Session> session = it->second.session.lock();
    if (session != nullptr && session->live->Watched(now_ns)) {
      ++it;
      continue;
    }
    if (session != nullptr) {
      session->live->Forget();
      sessions_.ReleaseLiveView(session);
    }
    it = watched_.erase(it);
  }
  const absl::Time now = absl::FromUnixNanos(now_ns);
  for (auto it = leases_.begin(); it != leases_.end();) {
    it = it->second.expiry <= now ? leases_.erase(it) : std::next(it);
  }
}

absl::Status LiveView::Watch(const std::shared_ptr<Session>& session, const std::string& viewer) {
  const lane::CameraModel& camera = session->config.camera;
  const uint64_t frame_bytes = uint64_t(camera.image_width) * uint64_t(camera.image_height) * 3;
  absl::MutexLock lock(&mu_);
  if (watched_.count(session.get()) == 0) {
    // The mailbox's sample, the one being drawn, and the pictures.
    const uint64_t bytes =
        2 * frame_bytes +
        LivePictureBytes(camera.image_width, camera.image_height, *session->CurrentDetector());
    if (absl::Status s = sessions_.ReserveLiveView(session, bytes); !s.ok()) return s;
    watched_[session.get()] = Watched{session};
    woken_ = true;
  }
  auto lease = leases_.find(viewer);
  if (lease != leases_.end() && lease->second.camera != session.get()) {
    const Session* previous = lease->second.camera;
    lease->second.camera = session.get();
    const bool still_watched =
        std::any_of(leases_.begin(), leases_.end(),
                    [previous](const auto& entry) { return entry.second.camera == previous; });
    auto before = previous != nullptr && !still_watched ? watched_.find(previous) : watched_.end();
    if (before != watched_.end()) {
      if (std::shared_ptr<Session> old = before->second.session.lock()) old->live->Unwatch();
      woken_ = true;  // the drawer drops it
    }
  }
  session->live->Watch(absl::GetCurrentTimeNanos() + absl::ToInt64Nanoseconds(options_.lease));
  return absl::OkStatus();
}

absl::StatusOr<std::string> LiveView::AcquireViewer(const std::string& requested) {
  const absl::Time now = absl::Now();
  absl::MutexLock lock(&mu_);
  for (auto it = leases_.begin(); it != leases_.end();) {
    it = it->second.expiry <= now ? leases_.erase(it) : std::next(it);
  }
  if (IsViewerId(requested)) {
    auto it = leases_.find(requested);
    if (it != leases_.end()) {
      it->second.expiry = now + options_.lease;
      return requested;
    }
  }
  if (leases_.size() >= static_cast<size_t>(options_.max_viewers)) {
    return absl::ResourceExhaustedError(
        absl::StrCat("the live view has ", leases_.size(),
                     " viewer(s) already, its limit "
                     "(--live_view_max_viewers ",
                     options_.max_viewers, "); close a view or try again in a few seconds"));
  }
  // A page that lost its lease (a pause longer than the lease) gets it back
  // under its own id.
  const std::string id = IsViewerId(requested) ? requested : Hex(RandomBytes(kViewerIdChars / 2));
  leases_[id] = Lease{now + options_.lease};
  return id;
}

size_t LiveView::viewers() const {
  const absl::Time now = absl::Now();
  absl::MutexLock lock(&mu_);
  size_t n = 0;
  for (const auto& [id, lease] : leases_) n += lease.expiry > now;
  return n;
}

size_t LiveView::watched_cameras() const {
  absl::MutexLock lock(&mu_);
  return watched_.size();
}

std::string LiveView::SealCookie(int64_t expiry_unix_s) const {
  const std::string message = absl::StrCat(kCookiePurpose, expiry_unix_s);
  unsigned char mac[EVP_MAX_MD_SIZE];
  size_t mac_size = 0;
  if (EVP_Q_mac(nullptr, "HMAC", nullptr, "SHA256", nullptr, cookie_key_.data(), cookie_key_.size(),
                reinterpret_cast<const unsigned char*>(message.data()), message.size(), mac,
                sizeof(mac), &mac_size) == nullptr) {
    return "";
  }
  return absl::StrCat("v1.", expiry_unix_s, ".",
                      Hex(absl::string_view(reinterpret_cast<const char*>(mac), mac_size)));
}

bool LiveView::CookieValid(const std::string& cookie_header) const {
  for (absl::string_view part : absl::StrSplit(cookie_header, ';')) {
    part = absl::StripAsciiWhitespace(part);
    if (!absl::ConsumePrefix(&part, kCookieName) || !absl::ConsumePrefix(&part, "=")) continue;
    const std::vector<absl::string_view> fields = absl::StrSplit(part, '.');
    int64_t expiry = 0;
    if (fields.size() != 3 || fields[0] != "v1" || !absl::SimpleAtoi(fields[1], &expiry)) continue;
    const int64_t now = absl::ToUnixSeconds(absl::Now());
    if (expiry <= now || expiry > now + absl::ToInt64Seconds(options_.login_validity) + 60) {
      continue;
    }
    const std::string expected = SealCookie(expiry);
    if (!expected.empty() && ConstantTimeEquals(part, expected)) return true;
  }
  return false;
}

bool LiveView::Authorized(const HttpRequest& request) const {
  if (options_.auth_tokens.empty()) return true;
  if (!request.authorization.empty() &&
      CheckBearerValue(request.authorization, options_.auth_tokens).ok()) {
    return true;
  }
  return !request.cookie.empty() && CookieValid(request.cookie);
}

HttpReply LiveView::Handle(const HttpRequest& request) {
  if (request.method != "GET" && request.method != "HEAD" && request.method != "POST") {
    HttpReply reply;
    reply.status = 405;
    reply.body = "only GET, HEAD and POST (/login)\n";
    return reply;
  }
  if (request.path.empty() || request.path[0] != '/')
    return Page(404, MessagePage("Not found", ""));
  std::vector<std::string> segments;
  for (absl::string_view raw : absl::StrSplit(absl::string_view(request.path).substr(1), '/')) {
    std::string segment;
    if (!UrlDecode(raw, false, &segment)) {
      return Page(404, MessagePage("Not found", "The path is not a valid URL."));
    }
    segments.push_back(std::move(segment));
  }
  return Route(request, segments);
}

HttpReply LiveView::Route(const HttpRequest& request, const std::vector<std::string>& segments) {
  const size_t n = segments.size();
  if (n == 1 && segments[0] == "live.js") {
    HttpReply reply{200, "text/javascript; charset=utf-8", LiveScript(), LivePageHeaders()};
    return reply;
  }
  if (n == 1 && segments[0] == "live.css") {
    HttpReply reply{200, "text/css; charset=utf-8", LiveStyle(), LivePageHeaders()};
    return reply;
  }
  if (n == 1 && segments[0] == "login") return Login(request);
  if (request.method == "POST") {
    HttpReply reply;
    reply.status = 405;
    reply.body = "only GET and HEAD\n";
    return reply;
  }
  const bool api = n >= 1 && segments[0] == "api";
  const bool picture = n == 3 && segments[0] == "cameras" &&
                       (segments[2] == "frame.jpg" || segments[2] == "top.jpg");
  const bool known = (n == 1 && segments[0].empty()) || (n == 2 && segments[0] == "cameras") ||
                     picture || (api && n == 2 && segments[1] == "sessions") ||
                     (api && n == 3 && segments[1] == "cameras");
  if (!known) return Page(404, MessagePage("Not found", "There is no such page."));
  if (!Authorized(request)) {
    if (api || picture) {
      HttpReply reply = JsonError(401, "a Bearer token is needed (Authorization header or /login)");
      reply.headers.emplace_back("WWW-Authenticate", "Bearer realm=\"lane-server live view\"");
      return reply;
    }
    const std::string next =
        request.query.empty() ? request.path : absl::StrCat(request.path, "?", request.query);
    HttpReply reply =
        Page(401, LoginPage("This page needs one of the server's Bearer tokens.", SafeNext(next)));
    reply.headers.emplace_back("WWW-Authenticate", "Bearer realm=\"lane-server live view\"");
    return reply;
  }
  // An unknown camera is 404 before it costs a lease.
  const bool camera_route = n >= 2 && !(api && segments[1] == "sessions");
  if (camera_route) {
    const std::string& camera_id = api ? segments[2] : segments[1];
    if (!SessionRegistry::ValidateCameraId(camera_id).ok() ||
        sessions_.Peek(camera_id) == nullptr) {
      const std::string message = absl::StrCat("No session has the camera id '", camera_id, "'.");
      return api || picture ? JsonError(404, message)
                            : Page(404, MessagePage("No such camera", message));
    }
  }
  absl::StatusOr<std::string> viewer = AcquireViewer(QueryValue(request.query, "viewer"));
  if (!viewer.ok()) {
    HttpReply reply = api || picture
                          ? JsonError(503, viewer.status().message())
                          : Page(503, MessagePage("Too many viewers", viewer.status().message()));
    reply.headers.emplace_back("Retry-After", "5");
    return reply;
  }
  HttpReply reply;
  if (n == 1) {
    reply = Page(200, IndexPage(*viewer, 1000));
  } else if (api && segments[1] == "sessions") {
    reply = JsonReply(200, SessionsJson());
  } else {
    const std::string& camera_id = api ? segments[2] : segments[1];
    reply = CameraRoute(request, camera_id, api ? "api" : picture ? segments[2] : "page", *viewer);
  }
  reply.headers.emplace_back("X-Viewer", *viewer);
  return reply;
}

HttpReply LiveView::CameraRoute(const HttpRequest& request, const std::string& camera_id,
                                const std::string& what, const std::string& viewer) {
  const bool page = what == "page";
  std::shared_ptr<Session> session =
      SessionRegistry::ValidateCameraId(camera_id).ok() ? sessions_.Peek(camera_id) : nullptr;
  if (session == nullptr || session->live == nullptr) {
    const std::string message = absl::StrCat("No session has the camera id '", camera_id, "'.");
    return page ? Page(404, MessagePage("No such camera", message)) : JsonError(404, message);
  }
  if (absl::Status s = Watch(session, viewer); !s.ok()) {
    const int status = s.code() == absl::StatusCode::kNotFound ? 404 : 503;
    return page ? Page(status, MessagePage("Cannot show this camera", s.message()))
                : JsonError(status, s.message());
  }
  if (page) {
    const int frame_ms = static_cast<int>(std::lround(1000.0 / options_.fps));
    return Page(200, CameraPage(camera_id, viewer, 1000, frame_ms));
  }
  if (what == "api") return JsonReply(200, CameraJson(session));
  const std::shared_ptr<const LivePictures> pictures = session->live->pictures();
  uint64_t after = 0;
  if (!absl::SimpleAtoi(QueryValue(request.query, "after"), &after)) after = 0;
  HttpReply reply;
  reply.headers = LivePageHeaders();
  const bool top = what == "top.jpg";
  if (pictures == nullptr || (!top && pictures->seq <= after) ||
      (top && pictures->top_jpeg.empty())) {
    reply.status = 204;  // nothing (newer) yet
    return reply;
  }
  reply.content_type = "image/jpeg";
  reply.body = top ? pictures->top_jpeg : pictures->frame_jpeg;
  reply.headers.emplace_back("X-Picture-Seq", std::to_string(pictures->seq));
  reply.headers.emplace_back("X-Frame-Id", std::to_string(pictures->frame_id));
  return reply;
}

HttpReply LiveView::Login(const HttpRequest& request) {
  const bool post = request.method == "POST";
  const std::string& fields = post ? request.body : request.query;
  const std::string next = SafeNext(QueryValue(fields, "next"));
  HttpReply redirect;
  redirect.status = 303;
  redirect.headers = LivePageHeaders();
  redirect.headers.emplace_back("Location", next);
  if (options_.auth_tokens.empty()) return redirect;
  const std::string token = QueryValue(fields, "token");
  if (token.empty()) {
    return Page(post ? 401 : 200, LoginPage("Give one of the server's Bearer tokens.", next));
  }
  if (!IsAcceptedToken(token, options_.auth_tokens)) {
    return Page(401, LoginPage("That token is not accepted.", next));
  }
  const int64_t validity_s = absl::ToInt64Seconds(options_.login_validity);
  const std::string cookie = SealCookie(absl::ToUnixSeconds(absl::Now()) + validity_s);
  if (cookie.empty())
    return Page(500, MessagePage("Cannot log in", "The cookie could not be made."));
  redirect.headers.emplace_back("Set-Cookie",
                                absl::StrCat(kCookieName, "=", cookie, "; Max-Age=", validity_s,
                                             "; Path=/; HttpOnly; SameSite=Strict"));
  return redirect;
}

}  // namespace lane::server
