#include "live_pages.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace lane::server {
namespace {

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// The head of every page: no inline script or style (the CSP allows only
// /live.js and /live.css), an empty icon so that the browser asks for none.
std::string PageHead(absl::string_view title) {
  return absl::StrCat(
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
      "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
      "<title>",
      HtmlEscape(title),
      "</title>\n<link rel=\"icon\" href=\"data:,\">\n"
      "<link rel=\"stylesheet\" href=\"/live.css\">\n"
      "<script src=\"/live.js\" defer></script>\n</head>\n");
}

constexpr char kLiveStyle[] = R"css(
:root { color-scheme: light dark; --bad: #c0392b; --warn: #b7791f; --muted: #777; }
body { font: 14px/1.4 system-ui, sans-serif; margin: 1rem 1.5rem; }
h1 { font-size: 1.4rem; margin: 0 0 .3rem; word-break: break-all; }
h2 { font-size: 1.05rem; margin: 1.2rem 0 .4rem; }
a { color: inherit; }
nav { margin-bottom: .6rem; color: var(--muted); }
table { border-collapse: collapse; }
th, td { padding: .25rem .6rem; border-bottom: 1px solid #8884; text-align: left; vertical-align: top; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; }
tr.stale td, tr.zero td { background: #c0392b22; }
td.marks, .warning { color: var(--bad); font-weight: 600; }
#status { color: var(--muted); font-size: .9rem; }
#status.bad { color: var(--bad); }
.pictures { display: flex; flex-wrap: wrap; gap: 1rem; align-items: flex-start; }
.pictures figure { margin: 0; }
.pictures img { display: block; max-width: 100%; background: #222; }
figcaption { color: var(--muted); font-size: .85rem; }
.swatch { display: inline-block; width: 1.6em; height: .8em; margin-right: .3em; border-radius: 2px; }
dl.state { display: grid; grid-template-columns: max-content auto; gap: .15rem 1rem; margin: 0; }
dl.state dt { color: var(--muted); }
dl.state dd { margin: 0; word-break: break-word; }
canvas { border: 1px solid #8884; max-width: 100%; }
.columns { display: flex; flex-wrap: wrap; gap: 2rem; }
form input[type=password] { width: 24rem; max-width: 100%; }
)css";

constexpr char kLiveScript[] = R"js('use strict';
// The live view of lane-server (docs/service.md, "Live view"). Data comes as
// JSON from /api/...; client strings go into the page with textContent only,
// and into links through encodeURIComponent.
(function () {
  const body = document.body;
  const page = body.dataset.page;
  const viewer = body.dataset.viewer || '';
  const refreshMs = Number(body.dataset.refreshMs) || 1000;
  const frameMs = Number(body.dataset.frameMs) || 200;
  const viewerQuery = 'viewer=' + encodeURIComponent(viewer);

  function el(tag, text, cls) {
    const e = document.createElement(tag);
    if (text !== undefined && text !== null) e.textContent = String(text);
    if (cls) e.className = cls;
    return e;
  }
  function fmt(x, digits) {
    return typeof x === 'number' && isFinite(x) ? x.toFixed(digits) : '\u2013';
  }
  function ago(unixMs, nowMs) {
    if (!unixMs) return 'never';
    const s = Math.max(0, (nowMs - unixMs) / 1000);
    if (s < 90) return s.toFixed(1) + ' s ago';
    if (s < 5400) return (s / 60).toFixed(1) + ' min ago';
    return (s / 3600).toFixed(1) + ' h ago';
  }
  function setStatus(text, bad) {
    const s = document.getElementById('status');
    if (!s) return;
    s.textContent = text;
    s.className = bad ? 'bad' : '';
  }
  async function getJson(url) {
    const r = await fetch(url, {cache: 'no-store', credentials: 'same-origin'});
    let data = null;
    try { data = await r.json(); } catch (e) { data = null; }
    if (!r.ok) throw new Error((data && data.error) || ('HTTP ' + r.status));
    return data;
  }
  function calibrationText(c) {
    if (!c) return '\u2013';
    if (c.state === 'fixed') return 'fixed';
    let t = c.state + ' (confidence ' + fmt(c.confidence, 2) + ', drift pitch ' +
        fmt(c.drift_pitch_deg, 2) + '\u00b0, yaw ' + fmt(c.drift_yaw_deg, 2) + '\u00b0)';
    if (c.last_refusal) t += '; last refusal: ' + c.last_refusal;
    return t;
  }
  function errorText(e) { return e ? e.code + ': ' + e.message : ''; }
  function marksOf(s) {
    const marks = [];
    if (s.stale) marks.push('stopped sending');
    if (s.zero_lanes) marks.push('0 lanes per frame');
    return marks;
  }

  // ---- `/`: one row per session.
  async function refreshIndex() {
    try {
      const data = await getJson('/api/sessions?' + viewerQuery);
      const rows = [];
      for (const s of data.sessions) {
        const tr = el('tr');
        tr.dataset.camera = s.camera_id;
        const marks = marksOf(s);
        if (s.stale) tr.classList.add('stale');
        if (s.zero_lanes) tr.classList.add('zero');
        const link = el('a', s.camera_id);
        link.href = '/cameras/' + encodeURIComponent(s.camera_id) + '?' + viewerQuery;
        const name = el('td');
        name.appendChild(link);
        tr.appendChild(name);
        tr.appendChild(el('td', fmt(s.fps, 1), 'num'));
        tr.appendChild(el('td', fmt(s.p50_ms, 1), 'num'));
        tr.appendChild(el('td', fmt(s.p99_ms, 1), 'num'));
        tr.appendChild(el('td', fmt(s.lanes_per_frame, 2), 'num'));
        tr.appendChild(el('td', calibrationText(s.calibration)));
        tr.appendChild(el('td', errorText(s.last_error)));
        tr.appendChild(el('td', ago(s.last_frame_unix_ms, data.now_unix_ms)));
        tr.appendChild(el('td', marks.join(', '), 'marks'));
        rows.push(tr);
      }
      if (rows.length === 0) {
        const tr = el('tr');
        const td = el('td', 'No sessions.');
        td.colSpan = 9;
        tr.appendChild(td);
        rows.push(tr);
      }
      document.getElementById('sessions-body').replaceChildren(...rows);
      setStatus('Updated ' + new Date(data.now_unix_ms).toLocaleTimeString() + '.');
    } catch (e) {
      setStatus(e.message, true);
    }
    setTimeout(refreshIndex, refreshMs);
  }

  // ---- `/cameras/{id}`: pictures, state, lanes, strip chart.
  const camera = body.dataset.camera || '';
  const cameraPath = '/cameras/' + encodeURIComponent(camera);
  let pictureSeq = 0;

  function showBlob(id, blob) {
    const img = document.getElementById(id);
    const old = img.dataset.url;
    const url = URL.createObjectURL(blob);
    img.dataset.url = url;
    img.onload = function () { if (old) URL.revokeObjectURL(old); };
    img.src = url;
  }
  async function fetchPictures() {
    try {
      const r = await fetch(cameraPath + '/frame.jpg?' + viewerQuery + '&after=' + pictureSeq,
                            {cache: 'no-store', credentials: 'same-origin'});
      if (r.status === 200) {
        const seq = Number(r.headers.get('X-Picture-Seq')) || 0;
        const frameId = r.headers.get('X-Frame-Id') || '';
        showBlob('frame', await r.blob());
        pictureSeq = seq;
        document.getElementById('frame-caption').textContent =
            'Frame ' + frameId + ' (picture ' + seq + ').';
        const t = await fetch(cameraPath + '/top.jpg?' + viewerQuery + '&seq=' + seq,
                              {cache: 'no-store', credentials: 'same-origin'});
        if (t.status === 200) showBlob('top', await t.blob());
      } else if (r.status !== 204) {
        let message = 'HTTP ' + r.status;
        try { message = (await r.json()).error || message; } catch (e) { /* not JSON */ }
        setStatus(message, true);
      }
    } catch (e) {
      setStatus(e.message, true);
    }
    setTimeout(fetchPictures, frameMs);
  }
  function addState(dl, name, value) {
    dl.appendChild(el('dt', name));
    dl.appendChild(el('dd', value));
  }
  function showState(d) {
    const dl = document.getElementById('state');
    const items = el('dl', null, 'state');
    items.id = 'state';
    addState(items, 'Frames per second', fmt(d.fps, 1));
    addState(items, 'Latency p50 / p99', fmt(d.p50_ms, 1) + ' / ' + fmt(d.p99_ms, 1) + ' ms');
    addState(items, 'Lanes per frame', fmt(d.lanes_per_frame, 2));
    addState(items, 'Last frame', ago(d.last_frame_unix_ms, d.now_unix_ms));
    addState(items, 'Frames', String(d.frames_total));
    addState(items, 'Calibration', calibrationText(d.calibration));
    addState(items, 'Horizon row', fmt(d.horizon_row, 1));
    addState(items, 'Vanishing point',
             d.vanishing_point ? fmt(d.vanishing_point[0], 1) + ', ' + fmt(d.vanishing_point[1], 1)
                               : '\u2013');
    addState(items, 'Frame size', d.width + ' \u00d7 ' + d.height);
    addState(items, 'Decoded rows', d.decoded_rows[0] + '\u2013' + (d.decoded_rows[1] - 1) +
             ' (' + d.decoded_pixels + ')');
    const ego = d.last_response && d.last_response.ego;
    addState(items, 'Ego lane', ego ? 'offset ' + fmt(ego.offset_m, 2) + ' m, width ' +
             fmt(ego.width_m, 2) + ' m, lanes #' + ego.left_lane_id + ' | #' + ego.right_lane_id +
             (ego.departing ? ', DEPARTING' : '') : '\u2013');
    addState(items, 'Last error', errorText(d.last_error) || 'none');
    dl.replaceWith(items);
    const warn = document.getElementById('warning');
    warn.textContent = marksOf(d).map(m => 'This camera: ' + m + '.').join(' ');
  }
  function showLanes(d) {
    const rows = [];
    const response = d.last_response;
    document.getElementById('lanes-caption').textContent = response
        ? 'Lanes of the last response (frame ' + response.frame_id + ').'
        : 'No response since this page opened.';
    for (const lane of (response ? response.lanes : [])) {
      const tr = el('tr');
      tr.dataset.laneId = String(lane.id);
      tr.dataset.score = String(lane.score);
      tr.dataset.offset = String(lane.offset_m);
      tr.appendChild(el('td', lane.id > 0 ? '#' + lane.id : '\u2013', 'num'));
      const colour = el('td');
      const swatch = el('span', null, 'swatch');
      swatch.style.backgroundColor = lane.draw_colour;
      colour.appendChild(swatch);
      colour.appendChild(document.createTextNode(lane.color));
      tr.appendChild(colour);
      tr.appendChild(el('td', lane.type));
      tr.appendChild(el('td', fmt(lane.score, 3), 'num'));
      tr.appendChild(el('td', fmt(lane.offset_m, 2), 'num'));
      const notes = [];
      if (lane.ego) notes.push('ego ' + lane.ego);
      if (lane.predicted) notes.push('predicted');
      if (lane.inferred) notes.push('inferred');
      if (lane.id > 0 && !lane.confirmed) notes.push('not confirmed');
      tr.appendChild(el('td', notes.join(', ')));
      rows.push(tr);
    }
    document.getElementById('lanes-body').replaceChildren(...rows);
  }
  function drawChart(d) {
    const canvas = document.getElementById('chart');
    const ctx = canvas.getContext('2d');
    const w = canvas.width, h = canvas.height, left = 40, right = 50, top = 10, bottom = 22;
    ctx.clearRect(0, 0, w, h);
    const now = d.now_unix_ms / 1000;
    const span = d.history_seconds;
    const points = d.history;  // [unix s, frames, ok frames, lanes, zero-lane frames, mean ms, max ms]
    let maxLanes = 4, maxMs = 10;
    for (const p of points) {
      if (p[2] > 0) maxLanes = Math.max(maxLanes, p[3] / p[2]);
      if (p[1] > 0) maxMs = Math.max(maxMs, p[6]);
    }
    const x = t => left + (w - left - right) * (1 - (now - t) / span);
    const yLanes = v => h - bottom - (h - top - bottom) * v / maxLanes;
    const yMs = v => h - bottom - (h - top - bottom) * v / maxMs;
    ctx.strokeStyle = '#8886';
    ctx.strokeRect(left, top, w - left - right, h - top - bottom);
    ctx.font = '11px sans-serif';
    ctx.fillStyle = '#2a9d2a';
    ctx.fillText(maxLanes.toFixed(0) + ' lanes', 2, top + 10);
    ctx.fillText('0', 2, h - bottom);
    ctx.fillStyle = '#d9822b';
    ctx.fillText(maxMs.toFixed(0) + ' ms', w - right + 4, top + 10);
    ctx.fillStyle = '#888';
    ctx.fillText('\u2212' + (span / 60).toFixed(0) + ' min', left, h - 6);
    ctx.fillText('now', w - right - 20, h - 6);
    function series(value, y, colour) {
      ctx.strokeStyle = colour;
      ctx.lineWidth = 1.5;
      ctx.beginPath();
      let started = false, last = null;
      for (const p of points) {
        const v = value(p);
        if (v === null) { started = false; continue; }
        if (!started || (last !== null && p[0] - last > 2)) ctx.moveTo(x(p[0]), y(v));
        else ctx.lineTo(x(p[0]), y(v));
        started = true;
        last = p[0];
      }
      ctx.stroke();
    }
    series(p => p[2] > 0 ? p[3] / p[2] : null, yLanes, '#2a9d2a');
    series(p => p[1] > 0 ? p[5] : null, yMs, '#d9822b');
  }
  async function refreshCamera() {
    try {
      const d = await getJson('/api' + cameraPath + '?' + viewerQuery);
      showState(d);
      showLanes(d);
      drawChart(d);
      setStatus('Updated ' + new Date(d.now_unix_ms).toLocaleTimeString() + '.');
    } catch (e) {
      setStatus(e.message, true);
    }
    setTimeout(refreshCamera, refreshMs);
  }

  if (page === 'index') refreshIndex();
  if (page === 'camera') {
    refreshCamera();
    fetchPictures();
  }
})();
)js";

}  // namespace

std::string HtmlEscape(absl::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string UrlEncodeSegment(absl::string_view text) {
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

bool UrlDecode(absl::string_view text, bool plus_is_space, std::string* out) {
  out->clear();
  for (size_t i = 0; i < text.size(); ++i) {
    char c = text[i];
    if (c == '%') {
      if (i + 2 >= text.size()) return false;
      const int hi = HexValue(text[i + 1]);
      const int lo = HexValue(text[i + 2]);
      if (hi < 0 || lo < 0) return false;
      c = static_cast<char>(hi * 16 + lo);
      i += 2;
    } else if (c == '+' && plus_is_space) {
      c = ' ';
    }
    if (c == '\0') return false;
    out->push_back(c);
  }
  return true;
}

std::string QueryValue(absl::string_view query, absl::string_view name) {
  for (absl::string_view pair : absl::StrSplit(query, '&')) {
    const size_t eq = pair.find('=');
    const absl::string_view key = pair.substr(0, eq);
    if (key != name) continue;
    std::string value;
    if (eq == absl::string_view::npos || !UrlDecode(pair.substr(eq + 1), true, &value)) return "";
    return value;
  }
  return "";
}

std::vector<std::pair<std::string, std::string>> LivePageHeaders() {
  return {{"Content-Security-Policy",
           "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' blob: data:; "
           "connect-src 'self'; form-action 'self'; base-uri 'none'; frame-ancestors 'none'"},
          {"X-Content-Type-Options", "nosniff"},
          {"X-Frame-Options", "DENY"},
          {"Referrer-Policy", "no-referrer"}};
}

std::string IndexPage(absl::string_view viewer, int refresh_ms) {
  return absl::StrCat(
      PageHead("lane-server: live view"), "<body data-page=\"index\" data-viewer=\"",
      HtmlEscape(viewer), "\" data-refresh-ms=\"", refresh_ms,
      "\">\n<h1>Live view</h1>\n"
      "<nav>Every session of this lane-server, updated every second. A camera is marked when it "
      "stopped sending (no frame for 5 s) or its lanes per frame fell to 0. Rates are over the "
      "last 10 s. Grafana and Prometheus (<a href=\"/metrics\">/metrics</a>) show the fleet "
      "over time.</nav>\n"
      "<table id=\"sessions\">\n<thead><tr><th>Camera</th><th class=\"num\">Frames/s</th>"
      "<th class=\"num\">p50 ms</th><th class=\"num\">p99 ms</th><th class=\"num\">Lanes/frame</th>"
      "<th>Calibration</th><th>Last error</th><th>Last frame</th><th>Marked</th></tr></thead>\n"
      "<tbody id=\"sessions-body\"></tbody>\n</table>\n<p id=\"status\"></p>\n</body>\n</html>\n");
}

std::string CameraPage(absl::string_view camera_id, absl::string_view viewer, int refresh_ms,
                       int frame_interval_ms) {
  const std::string id = HtmlEscape(camera_id);
  return absl::StrCat(
      PageHead(absl::StrCat("lane-server: ", camera_id)),
      "<body data-page=\"camera\" data-camera=\"", id, "\" data-viewer=\"", HtmlEscape(viewer),
      "\" data-refresh-ms=\"", refresh_ms, "\" data-frame-ms=\"", frame_interval_ms,
      "\">\n<nav><a href=\"/?viewer=", UrlEncodeSegment(viewer),
      "\">All cameras</a></nav>\n<h1 id=\"camera\">", id,
      "</h1>\n<p id=\"warning\" class=\"warning\"></p>\n"
      "<div class=\"pictures\">\n"
      "<figure><img id=\"frame\" alt=\"the latest frame with its lanes\">"
      "<figcaption id=\"frame-caption\">Waiting for a frame.</figcaption></figure>\n"
      "<figure><img id=\"top\" alt=\"the top view with its lanes\">"
      "<figcaption>Top view (the detector's channel through its IPM).</figcaption></figure>\n"
      "</div>\n<div class=\"columns\">\n<section>\n<h2>Lanes</h2>\n"
      "<p id=\"lanes-caption\"></p>\n"
      "<table id=\"lanes\"><thead><tr><th class=\"num\">Id</th><th>Colour</th><th>Type</th>"
      "<th class=\"num\">Score</th><th class=\"num\">Offset (m)</th><th>Notes</th></tr></thead>"
      "<tbody id=\"lanes-body\"></tbody></table>\n"
      "<h2>Lanes per frame and latency, last 5 minutes</h2>\n"
      "<canvas id=\"chart\" width=\"640\" height=\"170\"></canvas>\n"
      "<p>Green: lanes per frame; orange: the slowest frame of each second (ms).</p>\n"
      "</section>\n<section>\n<h2>State</h2>\n<dl id=\"state\" class=\"state\"></dl>\n"
      "</section>\n</div>\n<p id=\"status\"></p>\n</body>\n</html>\n");
}

std::string LoginPage(absl::string_view message, absl::string_view next) {
  return absl::StrCat(
      PageHead("lane-server: log in"),
      "<body data-page=\"login\">\n<h1>Live view: log in</h1>\n<p>", HtmlEscape(message),
      "</p>\n<form method=\"post\" action=\"/login\">\n"
      "<input type=\"hidden\" name=\"next\" value=\"",
      HtmlEscape(next),
      "\">\n<label>Bearer token <input type=\"password\" name=\"token\" "
      "autocomplete=\"current-password\" required></label>\n"
      "<button type=\"submit\">Log in</button>\n</form>\n"
      "<p>The token is one of lane-server's (--auth_tokens_file, LANE_AUTH_TOKENS). The "
      "server answers with a cookie that is valid for 12 hours; the token itself is not "
      "kept in the browser.</p>\n</body>\n</html>\n");
}

std::string MessagePage(absl::string_view title, absl::string_view message) {
  return absl::StrCat(PageHead(absl::StrCat("lane-server: ", title)),
                      "<body data-page=\"message\">\n<h1>", HtmlEscape(title), "</h1>\n<p>",
                      HtmlEscape(message),
                      "</p>\n<p><a href=\"/\">All cameras</a></p>\n</body>\n</html>\n");
}

const std::string& LiveScript() {
  static const std::string* script = new std::string(kLiveScript);
  return *script;
}

const std::string& LiveStyle() {
  static const std::string* style = new std::string(kLiveStyle);
  return *style;
}

}  // namespace lane::server
