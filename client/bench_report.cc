#include "bench_report.h"

#include <sys/utsname.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/strip.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "io/command_line.h"
#include "wire/frame_decoder.h"

namespace lane::client {
namespace {

using Json = nlohmann::ordered_json;

double Round3(double v) { return std::round(v * 1e3) / 1e3; }

Json LatencyJson(const LatencySummary& s) {
  Json j = Json::object();
  j["count"] = s.count;
  j["min"] = Round3(s.min);
  j["p50"] = Round3(s.p50);
  j["p90"] = Round3(s.p90);
  j["p95"] = Round3(s.p95);
  j["p99"] = Round3(s.p99);
  j["p999"] = Round3(s.p999);
  j["max"] = Round3(s.max);
  j["mean"] = Round3(s.mean);
  return j;
}

std::string ErrorsText(const std::map<std::string, uint64_t>& errors) {
  std::vector<std::string> parts;
  for (const auto& [code, n] : errors) parts.push_back(absl::StrCat(code, ":", n));
  return absl::StrJoin(parts, ";");
}

// The flat CSV columns of a summary: PREFIX_count, PREFIX_min_ms, ...
constexpr const char* kSummaryFields[] = {"min", "p50", "p90", "p95", "p99", "p999", "max", "mean"};

std::string SummaryHeader(const std::string& prefix) {
  std::string out = prefix + "_count";
  for (const char* f : kSummaryFields) absl::StrAppend(&out, ",", prefix, "_", f, "_ms");
  return out;
}

std::string SummaryCells(const LatencySummary& s) {
  return absl::StrFormat("%d,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f", s.count, s.min, s.p50, s.p90,
                         s.p95, s.p99, s.p999, s.max, s.mean);
}

// A CSV cell: quoted when it holds a comma, a quote or a newline.
std::string CsvCell(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

std::string ReadSmallFile(const char* path) {
  std::ifstream in(path, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return text;
}

}  // namespace

RunMetadata LocalMetadata() {
  RunMetadata m;
  m.date_utc = absl::FormatTime("%Y-%m-%dT%H:%M:%SZ", absl::Now(), absl::UTCTimeZone());
  m.client_version = io::VersionString();
  std::string cmdline = ReadSmallFile("/proc/self/cmdline");
  for (char& c : cmdline) {
    if (c == '\0') c = ' ';
  }
  m.command_line = std::string(absl::StripTrailingAsciiWhitespace(cmdline));
  char host[256] = {};
  gethostname(host, sizeof(host) - 1);
  utsname uts{};
  uname(&uts);
  m.machine = absl::StrCat(host, ", ", std::thread::hardware_concurrency(), " cores, ", uts.sysname,
                           " ", uts.release, " ", uts.machine);
  m.server_version = "unknown";
  return m;
}

std::vector<std::string> Warnings(const Report& r, const LoadResult& run) {
  std::vector<std::string> out;
  if (!run.gave_up.empty()) {
    out.push_back(absl::StrCat(
        run.gave_up.size(), " of ", run.cameras, " camera(s) gave up reconnecting",
        run.gave_up.size() == static_cast<size_t>(run.cameras) ? " and the run ended early" : "",
        ", so the load was not what was asked; ", run.gave_up.front()));
  }
  if (const std::optional<double> ratio = r.Ratio(run); ratio && *ratio > 1.0) {
    out.push_back(absl::StrFormat(
        "service/in-process is %.0f %%, over 100 %%: the in-process reference ran slower than the "
        "service, so the machine was busy with other work during one of them",
        *ratio * 100));
  }
  if (r.inprocess && r.inprocess->fps_before > 0 && r.inprocess->fps_after > 0) {
    const double lo = std::min(r.inprocess->fps_before, r.inprocess->fps_after);
    const double hi = std::max(r.inprocess->fps_before, r.inprocess->fps_after);
    if (hi > 1.25 * lo) {
      out.push_back(absl::StrFormat(
          "the in-process reference ran at %.1f frames/s before the service and %.1f after: the "
          "machine's speed changed during the bench, and service/in-process is uncertain by as "
          "much",
          r.inprocess->fps_before, r.inprocess->fps_after));
    }
  }
  // Full intervals with answers (the last one also holds the drain).
  std::vector<const TimelinePoint*> full;
  for (size_t i = 0; i + 1 < run.timeline.size(); ++i) {
    if (run.timeline[i].ok > 0) full.push_back(&run.timeline[i]);
  }
  if (full.size() >= 3) {
    uint64_t lo = full[0]->ok, hi = full[0]->ok;
    double p50_lo = full[0]->latency_ms.p50, p50_hi = p50_lo;
    for (const TimelinePoint* p : full) {
      lo = std::min(lo, p->ok);
      hi = std::max(hi, p->ok);
      p50_lo = std::min(p50_lo, p->latency_ms.p50);
      p50_hi = std::max(p50_hi, p->latency_ms.p50);
    }
    if (static_cast<double>(hi) > 1.5 * static_cast<double>(lo)) {
      out.push_back(
          absl::StrFormat("throughput moved between intervals: %d to %d OK frames per %.1f s", lo,
                          hi, full[0]->end_s - full[0]->start_s));
    }
    if (p50_hi > 2 * p50_lo && p50_hi - p50_lo > 1) {
      out.push_back(absl::StrFormat("median latency moved between intervals: %.2f to %.2f ms",
                                    p50_lo, p50_hi));
    }
  }
  if (run.latency_ms.count > 0 && run.latency_ms.count < 1000) {
    out.push_back(
        absl::StrFormat("%d frames measured: p99.9 is their maximum; measure longer for the tail",
                        run.latency_ms.count));
  }
  return out;
}

FramesInfo DescribeFrames(const std::vector<BenchFrame>& frames, const std::string& source) {
  FramesInfo info;
  info.source = source;
  double bytes = 0;
  for (const BenchFrame& frame : frames) {
    std::string kind = "raw";
    if (frame.request.has_raw()) {
      info.width = static_cast<int>(frame.request.raw().width());
      info.height = static_cast<int>(frame.request.raw().height());
    } else if (auto header = lane::wire::ReadEncodedHeader(frame.request.encoded()); header.ok()) {
      kind = header->format == lane::wire::EncodedFormat::kJpeg ? "jpeg" : "png";
      info.width = header->width;
      info.height = header->height;
    }
    if (info.encoding.empty()) info.encoding = kind;
    if (info.encoding != kind) info.encoding = "mixed";
    bytes += static_cast<double>(frame.image_part.size());
  }
  info.mean_bytes = frames.empty() ? 0 : bytes / static_cast<double>(frames.size());
  return info;
}

namespace {

// The frames sent: source, encoding, size and mean bytes.
Json FramesJson(const FramesInfo& info) {
  Json frames = Json::object();
  frames["source"] = info.source;
  frames["encoding"] = info.encoding;
  frames["width"] = info.width;
  frames["height"] = info.height;
  frames["mean_bytes"] = std::round(info.mean_bytes);
  return frames;
}

// A run's timeline: per interval its answers, errors and latency.
Json TimelineJson(const std::vector<TimelinePoint>& points) {
  Json timeline = Json::array();
  for (const TimelinePoint& point : points) {
    Json t = Json::object();
    t["start_s"] = Round3(point.start_s);
    t["end_s"] = Round3(point.end_s);
    t["frames_ok"] = point.ok;
    t["errors"] = point.errors;
    t["latency_ms"] = LatencyJson(point.latency_ms);
    timeline.push_back(std::move(t));
  }
  return timeline;
}

// One run (one camera count): throughput, errors, latencies, ratio and warnings.
Json RunJson(const Report& r, const LoadResult& run) {
  Json x = Json::object();
  x["cameras"] = run.cameras;
  x["target_fps"] = run.open_loop ? Json(run.target_fps) : Json();
  x["achieved_fps"] = Round3(run.achieved_fps);
  x["measured_s"] = Round3(run.measured_s);
  x["frames_scheduled"] = run.frames_scheduled;
  x["frames_sent"] = run.frames_sent;
  x["frames_ok"] = run.frames_ok;
  x["errors_total"] = run.errors_total;
  x["errors"] = Json::object();
  for (const auto& [code, n] : run.errors) x["errors"][code] = n;
  x["dropped"] = run.dropped;
  x["unsent"] = run.unsent;
  x["latency_ms"] = LatencyJson(run.latency_ms);
  x["server_ms"] = LatencyJson(run.server_ms);
  x["server_queue_ms"] = LatencyJson(run.queue_ms);
  x["server_decode_ms"] = LatencyJson(run.decode_ms);
  x["server_detect_ms"] = LatencyJson(run.detect_ms);
  x["max_send_lag_ms"] = Round3(run.max_send_lag_ms);
  x["stream_failures"] = run.stream_failures;
  x["ok_by_target"] = Json::object();
  for (const auto& [target, n] : run.ok_by_target) x["ok_by_target"][target] = n;
  const std::optional<double> ratio = r.Ratio(run);
  x["service_vs_inprocess"] = ratio ? Json(Round3(*ratio)) : Json();
  // CPU per frame: the servers' (over the measured window and the drain, per
  // frame sent in the window) against the in-process reference's. Unlike the
  // throughput ratio, it does not depend on the client sharing the cores.
  x["server_cpu_ms_per_frame"] =
      run.server_cpu_ms_per_frame >= 0 ? Json(Round3(run.server_cpu_ms_per_frame)) : Json();
  const std::optional<double> cpu_ratio = r.CpuRatio(run);
  x["server_cpu_vs_inprocess"] = cpu_ratio ? Json(Round3(*cpu_ratio)) : Json();
  x["slo_met"] = r.slo_p99_ms ? Json(r.SloMet(run)) : Json();
  x["warnings"] = Warnings(r, run);
  if (r.show_timeline && !run.timeline.empty()) x["timeline"] = TimelineJson(run.timeline);
  return x;
}

// The in-process reference's throughput and latency.
Json InprocessJson(const InprocessResult& in) {
  Json x = Json::object();
  x["workers"] = in.workers;
  x["fps"] = Round3(in.fps);
  x["frames"] = in.frames;
  x["tracked"] = in.tracked;
  x["tracked_frames"] = in.tracked_frames;
  x["fps_before"] = Round3(in.fps_before);
  x["fps_after"] = Round3(in.fps_after);
  x["cpu_ms_per_frame"] = Round3(in.cpu_ms_per_frame);
  x["latency_ms"] = LatencyJson(in.latency_ms);
  return x;
}

// When, by what and on what the bench ran.
Json MetaJson(const RunMetadata& m) {
  Json meta = Json::object();
  meta["date_utc"] = m.date_utc;
  meta["client_version"] = m.client_version;
  meta["server_version"] = m.server_version;
  meta["command_line"] = m.command_line;
  meta["machine"] = m.machine;
  return meta;
}

}  // namespace

std::string JsonReport(const Report& r) {
  Json j = Json::object();
  j["schema"] = kBenchReportSchema;
  j["targets"] = r.targets;
  j["connections_per_target"] = r.connections;
  j["mode"] = r.open_loop ? "open" : "closed";
  j["inflight_per_camera"] = r.open_loop ? Json() : Json(r.inflight);
  j["fps_per_camera"] = r.open_loop ? Json(r.fps) : Json();
  j["warmup_s"] = r.warmup_s;
  j["duration_s"] = r.duration_s;
  j["frames"] = FramesJson(r.frames);
  Json runs = Json::array();
  for (const LoadResult& run : r.runs) runs.push_back(RunJson(r, run));
  j["runs"] = std::move(runs);
  j["inprocess"] = r.inprocess ? InprocessJson(*r.inprocess) : Json();
  j["slo_p99_ms"] = r.slo_p99_ms ? Json(*r.slo_p99_ms) : Json();
  j["slo_met"] = r.slo_p99_ms ? Json(r.AllSloMet()) : Json();
  j["meta"] = MetaJson(r.meta);
  return j.dump(2) + "\n";
}

std::string CsvReport(const Report& r) {
  std::ostringstream out;
  out << "mode,cameras,inflight_per_camera,fps_per_camera,target_fps,achieved_fps,measured_s,"
         "frames_scheduled,frames_sent,frames_ok,errors_total,errors,dropped,unsent,"
      << SummaryHeader("latency") << ',' << SummaryHeader("server") << ','
      << SummaryHeader("server_queue") << ',' << SummaryHeader("server_decode") << ','
      << SummaryHeader("server_detect")
      << ",max_send_lag_ms,stream_failures,ok_by_target,inprocess_fps,service_vs_inprocess,"
         "server_cpu_ms_per_frame,server_cpu_vs_inprocess,"
         "slo_p99_ms,slo_met,warnings,date_utc,client_version,server_version,machine\n";
  for (const LoadResult& run : r.runs) {
    const std::optional<double> ratio = r.Ratio(run);
    const std::optional<double> cpu_ratio = r.CpuRatio(run);
    std::vector<std::string> by_target;
    for (const auto& [target, n] : run.ok_by_target)
      by_target.push_back(absl::StrCat(target, ":", n));
    out << (r.open_loop ? "open" : "closed") << ',' << run.cameras << ','
        << (r.open_loop ? std::string() : absl::StrCat(r.inflight)) << ','
        << (r.open_loop ? absl::StrCat(r.fps) : std::string()) << ','
        << (r.open_loop ? absl::StrFormat("%.3f", run.target_fps) : std::string()) << ','
        << absl::StrFormat("%.3f,%.3f", run.achieved_fps, run.measured_s) << ','
        << run.frames_scheduled << ',' << run.frames_sent << ',' << run.frames_ok << ','
        << run.errors_total << ',' << CsvCell(ErrorsText(run.errors)) << ',' << run.dropped << ','
        << run.unsent << ',' << SummaryCells(run.latency_ms) << ',' << SummaryCells(run.server_ms)
        << ',' << SummaryCells(run.queue_ms) << ',' << SummaryCells(run.decode_ms) << ','
        << SummaryCells(run.detect_ms) << ',' << absl::StrFormat("%.3f", run.max_send_lag_ms) << ','
        << run.stream_failures << ',' << CsvCell(absl::StrJoin(by_target, ";")) << ','
        << (r.inprocess ? absl::StrFormat("%.3f", r.inprocess->fps) : std::string()) << ','
        << (ratio ? absl::StrFormat("%.3f", *ratio) : std::string()) << ','
        << (run.server_cpu_ms_per_frame >= 0 ? absl::StrFormat("%.3f", run.server_cpu_ms_per_frame)
                                             : std::string())
        << ',' << (cpu_ratio ? absl::StrFormat("%.3f", *cpu_ratio) : std::string()) << ','
        << (r.slo_p99_ms ? absl::StrCat(*r.slo_p99_ms) : std::string()) << ','
        << (r.slo_p99_ms ? (r.SloMet(run) ? "true" : "false") : "") << ','
        << CsvCell(absl::StrJoin(Warnings(r, run), "; ")) << ',' << CsvCell(r.meta.date_utc) << ','
        << CsvCell(r.meta.client_version) << ',' << CsvCell(r.meta.server_version) << ','
        << CsvCell(r.meta.machine) << '\n';
  }
  return out.str();
}

namespace {

// A run's line in the text report, after the table: errors, unsent frames,
// the server's split, targets, the ratios to the in-process reference.
std::vector<std::string> TextRunNotes(const Report& r, const LoadResult& run) {
  std::vector<std::string> notes;
  if (!run.errors.empty()) notes.push_back("errors " + ErrorsText(run.errors));
  if (run.unsent > 0) notes.push_back(absl::StrCat(run.unsent, " frames unsent"));
  if (run.stream_failures > 0) {
    notes.push_back(absl::StrCat(run.stream_failures, " stream failures"));
  }
  if (run.open_loop && run.max_send_lag_ms > 1) {
    notes.push_back(absl::StrFormat("sender up to %.1f ms behind schedule", run.max_send_lag_ms));
  }
  notes.push_back(absl::StrFormat(
      "server p50 %.2f ms p99 %.2f ms (p50: queue %.2f, decode %.2f, detect %.2f ms)",
      run.server_ms.p50, run.server_ms.p99, run.queue_ms.p50, run.decode_ms.p50,
      run.detect_ms.p50));
  if (run.ok_by_target.size() > 1) {
    std::vector<std::string> parts;
    for (const auto& [target, n] : run.ok_by_target) parts.push_back(absl::StrCat(target, " ", n));
    notes.push_back("ok by target: " + absl::StrJoin(parts, ", "));
  }
  if (const std::optional<double> ratio = r.Ratio(run)) {
    notes.push_back(absl::StrFormat("service/in-process %.1f %%", *ratio * 100));
  }
  if (run.server_cpu_ms_per_frame >= 0) {
    std::string cpu = absl::StrFormat("server CPU %.2f ms/frame", run.server_cpu_ms_per_frame);
    if (const std::optional<double> cpu_ratio = r.CpuRatio(run)) {
      absl::StrAppend(&cpu, absl::StrFormat(" (in-process %.2f ms, %.2fx)",
                                            r.inprocess->cpu_ms_per_frame, *cpu_ratio));
    }
    notes.push_back(cpu);
  }
  return notes;
}

}  // namespace

std::string TextReport(const Report& r) {
  std::ostringstream out;
  out << "lane-client bench: " << absl::StrJoin(r.targets, ",");
  out << (r.connections_given ? absl::StrCat(" (", r.connections, " connection(s) per target)")
                              : std::string(" (a connection per camera)"));
  out << ", "
      << (r.open_loop ? absl::StrFormat("open loop at %g fps per camera", r.fps)
                      : absl::StrFormat("closed loop, %d in flight per camera", r.inflight))
      << "\n  frames: " << r.frames.source << ", " << r.frames.encoding << " " << r.frames.width
      << "x" << r.frames.height << absl::StrFormat(", %.1f KB mean", r.frames.mean_bytes / 1e3)
      << absl::StrFormat("; warm-up %g s, measured %g s\n\n", r.warmup_s, r.duration_s);
  out << absl::StrFormat("%7s %10s %10s %8s %8s %8s %8s %8s %8s %8s %8s %8s %8s %8s\n", "cameras",
                         "target/s", "achieved/s", "min ms", "p50 ms", "p90 ms", "p95 ms", "p99 ms",
                         "p99.9 ms", "max ms", "sent", "ok", "errors", "dropped");
  for (const LoadResult& run : r.runs) {
    out << absl::StrFormat(
        "%7d %10s %10.1f %8.2f %8.2f %8.2f %8.2f %8.2f %8.2f %8.2f %8d %8d %8d %8d\n", run.cameras,
        run.open_loop ? absl::StrFormat("%.1f", run.target_fps) : std::string("max"),
        run.achieved_fps, run.latency_ms.min, run.latency_ms.p50, run.latency_ms.p90,
        run.latency_ms.p95, run.latency_ms.p99, run.latency_ms.p999, run.latency_ms.max,
        run.frames_sent, run.frames_ok, run.errors_total, run.dropped);
  }
  for (const LoadResult& run : r.runs) {
    const std::vector<std::string> notes = TextRunNotes(r, run);
    out << absl::StrFormat("  %d cameras: ", run.cameras) << absl::StrJoin(notes, "; ") << "\n";
    for (const std::string& warning : Warnings(r, run)) {
      out << "  warning: " << warning << "\n";
    }
    if (r.show_timeline && !run.timeline.empty()) {
      out << absl::StrFormat("    %15s %8s %8s %8s %8s %8s\n", "interval s", "ok", "errors",
                             "p50 ms", "p99 ms", "max ms");
      for (const TimelinePoint& p : run.timeline) {
        out << absl::StrFormat("    %7.0f-%-7.0f %8d %8d %8.2f %8.2f %8.2f\n", p.start_s, p.end_s,
                               p.ok, p.errors, p.latency_ms.p50, p.latency_ms.p99,
                               p.latency_ms.max);
      }
    }
  }
  if (r.inprocess) {
    out << absl::StrFormat(
        "in-process: %d workers, %.1f frames/s (%.1f before the service, %.1f after), "
        "decode+detect%s p50 %.2f ms p99 %.2f ms\n",
        r.inprocess->workers, r.inprocess->fps, r.inprocess->fps_before, r.inprocess->fps_after,
        r.inprocess->tracked ? "+track" : "", r.inprocess->latency_ms.p50,
        r.inprocess->latency_ms.p99);
  }
  if (r.slo_p99_ms) {
    out << absl::StrFormat("SLO p99 <= %g ms: %s\n", *r.slo_p99_ms,
                           r.AllSloMet() ? "met" : "BREACHED");
  }
  out << "server " << r.meta.server_version << "; client " << r.meta.client_version << "; "
      << r.meta.machine << "; " << r.meta.date_utc << "\n";
  return out.str();
}

}  // namespace lane::client
