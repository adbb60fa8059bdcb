// The live view (`--live_view`): web pages on the metrics port that show
// what the service sees, camera by camera (docs/service.md, "Live view").
//
//   GET /                       every session: rates, latency, lanes per
//                               frame, calibration, last error, last frame
//   GET /cameras/{id}           one camera: its latest frame and top view
//                               with the lanes, state, lanes table, chart
//   GET /cameras/{id}/frame.jpg the latest picture of the frame (204: none
//                               newer than ?after=SEQ)
//   GET /cameras/{id}/top.jpg   the top view of the same sample
//   GET /api/sessions           JSON of `/`
//   GET /api/cameras/{id}       JSON of `/cameras/{id}`
//   GET|POST /login             the token -> a sealed cookie (tokens set)
//   GET /live.js, /live.css     the pages' script and style
//
// {id} is one URL path segment, percent-encoded ('/' as %2F). Nothing else
// is served: every other path is 404, there are no files and no listings.
//
// Cost. The frame path asks the session's LiveFeed whether its camera is
// watched (one atomic load). A watched camera gives at most `fps` samples a
// second: the worker copies the decoded rows, and the response's lanes join
// them when the response is written; a size-one mailbox per camera hands
// them to this class's drawing thread, which draws and JPEG-encodes (never a
// frame worker). A camera is watched while a viewer requests its page, data
// or pictures, and for `lease` after; then the drawer drops its sample and
// pictures and returns the memory it had reserved in the session budget.
//
// Viewers. A viewer is an open page: it holds a lease that each of its
// requests renews (?viewer=ID), which lapses `lease` after its last request.
// At most `max_viewers` leases are held; a page beyond them is 503. A lease
// watches one camera at a time (the last it asked about), so at most
// `max_viewers` cameras are watched, each within the session memory budget.
//
// Tokens. With tokens set, every route but /login, /live.js and /live.css
// needs `Authorization: Bearer TOKEN` or the cookie /login sets: answered
// 401 (with the login form) otherwise. /login takes the token from a POST
// form (or, for links, GET ?token=, answered with a redirect that drops it)
// and sets `lane_live`: an expiry and an HMAC-SHA256 over it under a key
// drawn at start-up (HttpOnly, SameSite=Strict). Tokens are compared in
// constant time (auth.h) and never logged or echoed.
#ifndef LANE_SERVER_LIVE_VIEW_H_
#define LANE_SERVER_LIVE_VIEW_H_

#include <cstdint>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "http_endpoint.h"
#include "live_feed.h"
#include "session_registry.h"

namespace lane::server {

struct LiveViewOptions {
  // Pictures drawn (and JPEG-encoded) per second per watched camera, at
  // most. 5: enough to see lanes follow the paint, a fifth of a 25 fps
  // camera's frames, about 5 ms of one core a second per watched camera.
  double fps = 5;
  // Viewer leases (open pages) at once; one more is 503.
  int max_viewers = 4;
  // A viewer's lease and its camera's watch last this long after its last
  // request. The pages ask every second; 5 s rides out a slow request.
  absl::Duration lease = absl::Seconds(5);
  // JPEG quality of the pictures (1..100).
  int jpeg_quality = 80;
  // Accepted Bearer tokens; empty = the pages need none.
  std::vector<std::string> auth_tokens;
  // How long a login cookie is accepted.
  absl::Duration login_validity = absl::Hours(12);
  // A camera whose last frame is older than this is marked as stopped.
  absl::Duration stale_after = absl::Seconds(5);
  // The window of the rates and latency quantiles.
  absl::Duration window = absl::Seconds(10);

  // OK, or INVALID_ARGUMENT naming the flag.
  absl::Status Validate() const;
  int64_t DrawIntervalNs() const;
};

class LiveView {
 public:
  // Starts the drawing thread. `sessions` must outlive this.
  LiveView(LiveViewOptions options, SessionRegistry& sessions);
  // Stops the drawing thread.
  ~LiveView();

  LiveView(const LiveView&) = delete;
  LiveView& operator=(const LiveView&) = delete;

  // A response has been written for a frame of `session` (with `sample` when
  // the frame was sampled for the drawer, see ProcessFrame): counts it and,
  // when the camera is watched, keeps its lanes and hands a sample to the
  // drawer. Cheap and non-blocking (a short lock): called where responses
  // are written, under the stream's lock.
  void Record(const std::shared_ptr<Session>& session, const v1::FrameResponse& response,
              LiveFrame sample);

  // Answers one HTTP request for a page (HttpEndpoint's page handler).
  HttpReply Handle(const HttpRequest& request);

  // Leases held and cameras watched now (tests, the status line).
  size_t viewers() const;
  size_t watched_cameras() const;
  const LiveViewOptions& options() const { return options_; }

 private:
  struct Lease {
    absl::Time expiry;
    const Session* camera = nullptr;  // the camera it watches, if any
  };
  struct Watched {
    std::weak_ptr<Session> session;
  };

  // The drawing thread: draws what Record posted, drops lapsed watches.
  void DrawLoop();
  void Draw(const std::shared_ptr<Session>& session);
  void ExpireWatches();
  bool HasWork() const ABSL_SHARED_LOCKS_REQUIRED(mu_) {
    return stopping_ || woken_ || !posted_.empty();
  }

  // Routing and answers (live_view.cc).
  HttpReply Route(const HttpRequest& request, const std::vector<std::string>& segments);
  HttpReply Login(const HttpRequest& request);
  // `what`: "page", "api", "frame.jpg" or "top.jpg".
  HttpReply CameraRoute(const HttpRequest& request, const std::string& camera_id,
                        const std::string& what, const std::string& viewer);
  // A viewer lease for `requested` (renewed when alive, else a new one): its
  // id, or RESOURCE_EXHAUSTED at the limit.
  absl::StatusOr<std::string> AcquireViewer(const std::string& requested);
  // `viewer` watches the session's camera (reserving its memory on the
  // first watch), and no longer the camera it watched before: a viewer
  // watches one camera at a time, so at most max_viewers are watched.
  absl::Status Watch(const std::shared_ptr<Session>& session, const std::string& viewer);
  bool Authorized(const HttpRequest& request) const;
  std::string SealCookie(int64_t expiry_unix_s) const;
  bool CookieValid(const std::string& cookie_header) const;
  // The JSON of the pages' scripts (live_view_json.cc).
  using Json = nlohmann::ordered_json;
  Json SummaryJson(const Session& session, int64_t now_ns) const;
  Json SessionsJson() const;
  Json CameraJson(const std::shared_ptr<Session>& session) const;

  const LiveViewOptions options_;
  SessionRegistry& sessions_;
  std::string cookie_key_;  // 32 random bytes, drawn at start-up

  mutable absl::Mutex mu_;
  const absl::Condition has_work_{this, &LiveView::HasWork};
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;
  // A watch began: the drawer, asleep without a timeout while nothing was
  // watched, starts checking for lapsed watches.
  bool woken_ ABSL_GUARDED_BY(mu_) = false;
  // Sessions with a sample to draw.
  std::vector<std::weak_ptr<Session>> posted_ ABSL_GUARDED_BY(mu_);
  // Cameras being watched, by session.
  std::map<const Session*, Watched> watched_ ABSL_GUARDED_BY(mu_);
  std::map<std::string, Lease> leases_ ABSL_GUARDED_BY(mu_);
  uint64_t next_picture_seq_ ABSL_GUARDED_BY(mu_) = 1;

  std::thread drawer_;
};

}  // namespace lane::server

#endif  // LANE_SERVER_LIVE_VIEW_H_
