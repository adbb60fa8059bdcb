// `lane-client bench --html FILE`: one self-contained page (no scripts, no
// network): run metadata, the percentiles, errors by code, the server's
// split and warnings, and per run the latency over time and its histogram as
// inline SVG.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "bench_report.h"

namespace lane::client {
namespace {

std::string Escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
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
      default:
        out += c;
    }
  }
  return out;
}

std::string Ms(double v) { return absl::StrFormat("%.2f", v); }

// A "nice" upper bound for an axis: 1, 2 or 5 times a power of ten.
double NiceCeiling(double v) {
  if (v <= 0) return 1;
  const double p = std::pow(10.0, std::floor(std::log10(v)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (v <= m * p) return m * p;
  }
  return 10 * p;
}

constexpr int kWidth = 640, kHeight = 240;
constexpr int kLeft = 56, kRight = 16, kTop = 16, kBottom = 36;
constexpr double kPlotW = kWidth - kLeft - kRight, kPlotH = kHeight - kTop - kBottom;

// The row of value v on a y axis from 0 to y_max.
double PlotY(double v, double y_max) { return kTop + kPlotH - std::min(v, y_max) / y_max * kPlotH; }

// What both charts share: the opening <svg> tag, the plot area, the y axis
// from 0 to y_max with four grid lines, and the two axis titles. The caller
// draws the x ticks and the data, then closes with "</svg>".
void OpenPlot(std::ostringstream& svg, const char* aria_label, double y_max, const char* x_title,
              const char* y_title) {
  svg << absl::StrFormat(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%d\" height=\"%d\" viewBox=\"0 0 %d %d\" "
      "role=\"img\" aria-label=\"%s\">\n",
      kWidth, kHeight, kWidth, kHeight, aria_label);
  svg << absl::StrFormat(
      "<rect x=\"%d\" y=\"%d\" width=\"%.0f\" height=\"%.0f\" fill=\"#fafafa\" "
      "stroke=\"#999\"/>\n",
      kLeft, kTop, kPlotW, kPlotH);
  for (int i = 0; i <= 4; ++i) {
    const double v = y_max * i / 4;
    const double y = PlotY(v, y_max);
    svg << absl::StrFormat(
        "<line x1=\"%d\" x2=\"%.0f\" y1=\"%.1f\" y2=\"%.1f\" stroke=\"#ddd\"/>"
        "<text x=\"%d\" y=\"%.1f\" text-anchor=\"end\" font-size=\"11\">%g</text>\n",
        kLeft, kLeft + kPlotW, y, y, kLeft - 4, y + 4, v);
  }
  svg << absl::StrFormat(
      "<text x=\"%.0f\" y=\"%d\" text-anchor=\"middle\" font-size=\"11\">%s</text>\n"
      "<text x=\"12\" y=\"%.0f\" font-size=\"11\" transform=\"rotate(-90 12 %.0f)\" "
      "text-anchor=\"middle\">%s</text>\n",
      kLeft + kPlotW / 2, kHeight - 4, x_title, kTop + kPlotH / 2, kTop + kPlotH / 2, y_title);
}

// Latency (p50, p99, max) per timeline interval.
std::string TimelineSvg(const LoadResult& run) {
  std::ostringstream svg;
  double t_max = 0, y_max = 0;
  for (const TimelinePoint& p : run.timeline) {
    t_max = std::max(t_max, p.end_s);
    if (p.ok > 0) y_max = std::max(y_max, p.latency_ms.p99);
  }
  y_max = NiceCeiling(y_max * 1.05);
  if (t_max <= 0) t_max = 1;
  const auto x = [&](double t) { return kLeft + t / t_max * kPlotW; };
  const auto y = [&](double v) { return PlotY(v, y_max); };
  OpenPlot(svg, "latency over time", y_max, "seconds into the measured window", "latency, ms");
  for (int i = 0; i <= 5; ++i) {
    const double t = t_max * i / 5;
    svg << absl::StrFormat(
        "<text x=\"%.1f\" y=\"%d\" text-anchor=\"middle\" font-size=\"11\">%.1f</text>\n", x(t),
        kHeight - kBottom + 14, t);
  }
  const struct {
    const char* name;
    const char* colour;
    double LatencySummary::*field;
  } series[] = {{"p50", "#1f77b4", &LatencySummary::p50}, {"p99", "#d62728", &LatencySummary::p99}};
  int legend = 0;
  for (const auto& s : series) {
    std::vector<std::string> points;
    for (const TimelinePoint& p : run.timeline) {
      if (p.ok == 0) continue;
      points.push_back(
          absl::StrFormat("%.1f,%.1f", x(0.5 * (p.start_s + p.end_s)), y(p.latency_ms.*(s.field))));
    }
    svg << "<polyline fill=\"none\" stroke-width=\"2\" stroke=\"" << s.colour << "\" points=\""
        << absl::StrJoin(points, " ") << "\"/>\n";
    svg << absl::StrFormat(
        "<rect x=\"%.0f\" y=\"%d\" width=\"12\" height=\"3\" fill=\"%s\"/><text x=\"%.0f\" "
        "y=\"%d\" font-size=\"11\">%s</text>\n",
        kLeft + kPlotW - 90 + legend * 45, kTop + 10, s.colour, kLeft + kPlotW - 74 + legend * 45,
        kTop + 14, s.name);
    ++legend;
  }
  svg << "</svg>\n";
  return svg.str();
}

// Frames per log-spaced latency bin.
std::string HistogramSvg(const LoadResult& run) {
  std::ostringstream svg;
  const LatencyHistogram& h = run.latency_histogram;
  // The bins that hold frames, and one either side.
  int first = kHistogramBins + 1, last = 0;
  uint64_t top = 0;
  for (int i = 0; i < static_cast<int>(h.counts.size()); ++i) {
    if (h.counts[i] == 0) continue;
    first = std::min(first, i);
    last = std::max(last, i);
    top = std::max(top, h.counts[i]);
  }
  first = std::max(1, first - 1);
  last = std::min(kHistogramBins, last + 1);
  if (last < first) last = first;
  const double y_max = NiceCeiling(static_cast<double>(top));
  const int bins = last - first + 1;
  const double bar_w = kPlotW / bins;
  OpenPlot(svg, "latency histogram", y_max, "latency, ms (log bins)", "frames");
  for (int b = first; b <= last; ++b) {
    const uint64_t n = b < static_cast<int>(h.counts.size()) ? h.counts[b] : 0;
    const double bh = static_cast<double>(n) / y_max * kPlotH;
    const double bx = kLeft + (b - first) * bar_w;
    svg << absl::StrFormat(
        "<rect x=\"%.1f\" y=\"%.1f\" width=\"%.1f\" height=\"%.1f\" fill=\"#1f77b4\">"
        "<title>%s-%s ms: %d frames</title></rect>\n",
        bx + 1, kTop + kPlotH - bh, std::max(1.0, bar_w - 2), bh, Ms(LatencyHistogram::Edge(b)),
        Ms(LatencyHistogram::Edge(b + 1)), n);
    if ((b - first) % std::max(1, bins / 8) == 0) {
      svg << absl::StrFormat(
          "<text x=\"%.1f\" y=\"%d\" text-anchor=\"middle\" font-size=\"11\">%.3g</text>\n", bx,
          kHeight - kBottom + 14, LatencyHistogram::Edge(b));
    }
  }
  svg << "</svg>\n";
  return svg.str();
}

std::string Row(const std::vector<std::string>& cells, const char* tag = "td") {
  std::string out = "<tr>";
  for (const std::string& c : cells) absl::StrAppend(&out, "<", tag, ">", c, "</", tag, ">");
  return out + "</tr>\n";
}

// The page's head (title and style) and the run's metadata table.
void WriteHeadAndMeta(std::ostringstream& html, const Report& r) {
  html
      << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
      << "<title>lane-client bench " << Escape(r.meta.date_utc) << "</title>\n"
      << "<style>body{font-family:sans-serif;margin:24px;color:#222}"
         "table{border-collapse:collapse;margin:8px 0 16px;font-size:12px}div.wide{overflow-x:auto}"
         "td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}"
         "th{background:#f0f0f0}td.l,th.l{text-align:left}"
         ".warn{color:#a40;font-weight:bold}h2{margin-top:28px}</style>\n</head>\n<body>\n";
  html << "<h1>lane-client bench</h1>\n<table>\n";
  const std::vector<std::pair<std::string, std::string>> meta = {
      {"date (UTC)", r.meta.date_utc},
      {"server", r.meta.server_version},
      {"client", r.meta.client_version},
      {"command line", r.meta.command_line},
      {"machine", r.meta.machine},
      {"targets", absl::StrJoin(r.targets, ", ")},
      {"load", r.open_loop ? absl::StrFormat("open loop, %g frames/s per camera", r.fps)
                           : absl::StrFormat("closed loop, %d in flight per camera", r.inflight)},
      {"frames", absl::StrFormat("%s, %s %dx%d, %.1f KB mean", r.frames.source, r.frames.encoding,
                                 r.frames.width, r.frames.height, r.frames.mean_bytes / 1e3)},
      {"window", absl::StrFormat("warm-up %g s, measured %g s", r.warmup_s, r.duration_s)}};
  for (const auto& [k, v] : meta) {
    html << "<tr><th class=\"l\">" << Escape(k) << "</th><td class=\"l\">" << Escape(v)
         << "</td></tr>\n";
  }
}

// The client latency table, a row per run, and the in-process reference.
void WriteLatencyTable(std::ostringstream& html, const Report& r) {
  html << "</table>\n<h2>Latency, ms (client: due or sent to answer received)</h2>\n"
       << "<div class=\"wide\"><table>\n"
       << Row({"cameras", "target/s", "achieved/s", "min", "p50", "p90", "p95", "p99", "p99.9",
               "max", "mean", "sent", "ok", "errors", "dropped", "service/in-process", "SLO"},
              "th");
  for (const LoadResult& run : r.runs) {
    const std::optional<double> ratio = r.Ratio(run);
    const LatencySummary& l = run.latency_ms;
    html << Row(
        {absl::StrCat(run.cameras), run.open_loop ? absl::StrFormat("%.1f", run.target_fps) : "max",
         absl::StrFormat("%.1f", run.achieved_fps), Ms(l.min), Ms(l.p50), Ms(l.p90), Ms(l.p95),
         Ms(l.p99), Ms(l.p999), Ms(l.max), Ms(l.mean), absl::StrCat(run.frames_sent),
         absl::StrCat(run.frames_ok), absl::StrCat(run.errors_total), absl::StrCat(run.dropped),
         ratio ? absl::StrFormat("%.1f %%", *ratio * 100) : "",
         r.slo_p99_ms ? (r.SloMet(run) ? "met" : "BREACHED") : ""});
  }
  html << "</table></div>\n";
  if (r.inprocess) {
    html << absl::StrFormat(
        "<p>In-process reference: %d workers, %.1f frames/s, decode+detect p50 %s ms, p99 %s "
        "ms.</p>\n",
        r.inprocess->workers, r.inprocess->fps, Ms(r.inprocess->latency_ms.p50),
        Ms(r.inprocess->latency_ms.p99));
  }
}

// The server's split of each run (server, queue, decode, detect) and the errors by code.
void WriteServerAndErrorTables(std::ostringstream& html, const Report& r) {
  html << "<h2>Server split, ms (from each answer's timings)</h2>\n<table>\n"
       << Row({"cameras", "server p50", "server p99", "queue p50", "queue p99", "decode p50",
               "decode p99", "detect p50", "detect p99"},
              "th");
  for (const LoadResult& run : r.runs) {
    html << Row({absl::StrCat(run.cameras), Ms(run.server_ms.p50), Ms(run.server_ms.p99),
                 Ms(run.queue_ms.p50), Ms(run.queue_ms.p99), Ms(run.decode_ms.p50),
                 Ms(run.decode_ms.p99), Ms(run.detect_ms.p50), Ms(run.detect_ms.p99)});
  }
  html << "</table>\n<h2>Errors by code</h2>\n<table>\n"
       << Row({"cameras", "code", "frames"}, "th");
  bool any_error = false;
  for (const LoadResult& run : r.runs) {
    for (const auto& [code, n] : run.errors) {
      any_error = true;
      html << Row({absl::StrCat(run.cameras), Escape(code), absl::StrCat(n)});
    }
  }
  if (!any_error) html << "<tr><td class=\"l\" colspan=\"3\">none</td></tr>\n";
  html << "</table>\n";
}

// Per run: its warnings, its latency over time and its histogram.
void WriteRunSections(std::ostringstream& html, const Report& r) {
  for (const LoadResult& run : r.runs) {
    html << "<h2>" << run.cameras << " camera(s)</h2>\n";
    for (const std::string& w : Warnings(r, run)) {
      html << "<p class=\"warn\">warning: " << Escape(w) << "</p>\n";
    }
    if (!run.timeline.empty()) {
      html << "<h3>Latency over time (per interval)</h3>\n" << TimelineSvg(run);
    }
    html << "<h3>Latency histogram</h3>\n" << HistogramSvg(run);
  }
}

}  // namespace

std::string HtmlReport(const Report& r) {
  std::ostringstream html;
  WriteHeadAndMeta(html, r);
  WriteLatencyTable(html, r);
  WriteServerAndErrorTables(html, r);
  WriteRunSections(html, r);
  html << "</body>\n</html>\n";
  return html.str();
}

}  // namespace lane::client
