// The live view's pages: HTML, CSS and JavaScript served from the binary
// (raw string literals in live_pages.cc: no framework, no build step, nothing
// fetched from elsewhere), and the escaping every client string goes
// through on its way into them.
//
// Client strings (camera ids, error messages) reach a page in two ways only:
// server-rendered into HTML text and attributes through HtmlEscape (ids in
// URLs through UrlEncodeSegment first), or as JSON that live.js puts into
// the page with textContent (never innerHTML) and into links with
// encodeURIComponent. Pages carry a Content-Security-Policy that allows only
// the server's own script file, so that even an escaping bug would not run
// an injected script.
#ifndef LANE_SERVER_LIVE_PAGES_H_
#define LANE_SERVER_LIVE_PAGES_H_

#include <string>
#include <utility>
#include <vector>

#include "absl/strings/string_view.h"

namespace lane::server {

// & < > " ' as entities: safe in HTML text and in quoted attribute values.
std::string HtmlEscape(absl::string_view text);
// Percent-encodes every byte but A-Z a-z 0-9 - . _ ~ : one URL path segment
// or query value ('/' becomes %2F, so a camera id stays one segment).
std::string UrlEncodeSegment(absl::string_view text);
// Decodes %XX (and '+' as a space when `plus_is_space`, for query strings
// and form bodies). False for a malformed escape or a decoded NUL.
bool UrlDecode(absl::string_view text, bool plus_is_space, std::string* out);
// The value of `name` in a query string or form body ("a=1&b=2"), decoded;
// "" when absent or malformed.
std::string QueryValue(absl::string_view query, absl::string_view name);

// The headers every page and API answer carries (CSP, no sniffing, no
// framing, no referrer).
std::vector<std::pair<std::string, std::string>> LivePageHeaders();

// `/`: the table of sessions (filled by live.js from /api/sessions).
std::string IndexPage(absl::string_view viewer, int refresh_ms);
// `/cameras/{id}`: one camera (filled by live.js from /api/cameras/{id} and
// the pictures). `camera_id` is the decoded id.
std::string CameraPage(absl::string_view camera_id, absl::string_view viewer, int refresh_ms,
                       int frame_interval_ms);
// 401: the login form (POST /login), with `message` (plain text) above it
// and `next` (a local path) to return to.
std::string LoginPage(absl::string_view message, absl::string_view next);
// An error page: status line text and a message (plain text).
std::string MessagePage(absl::string_view title, absl::string_view message);

// /live.js and /live.css.
const std::string& LiveScript();
const std::string& LiveStyle();

}  // namespace lane::server

#endif  // LANE_SERVER_LIVE_PAGES_H_
