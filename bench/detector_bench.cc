// Detector benchmarks: each stage and the whole detection on 640x480 frames
// (decoded BGR in, image-space splines out), plus JPEG decoding of the same
// frames. Run: build/bench/detector_bench --benchmark_repetitions=5
//   --benchmark_report_aggregates_only=true   (medians are the figures to quote)
//
// Frame sets:
//   synthetic  64 rendered frames of the Caltech camera (always)
//   culane     ../shared/data/culane-driver161-a resized to 640x480, with the
//              camera scaled to match (only when the folder is present)
//
// The decoding benchmarks (BM_Decode*) are in decode_bench.cc, in the same
// binary.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "bench_frames.h"
#include "lane/config/config.h"
#include "lane/decode/detector_region.h"
#include "lane/decode/image_decoder.h"
#include "lane/detector/detector.h"
#include "lane/synthetic.h"
#include "lane/track/frame_tracker.h"

namespace {

using lane::CameraModel;
using lane::Detector;
using lane::bench::FilesWithExtension;
using lane::bench::SharedDataDir;

struct FrameSet {
  CameraModel camera;
  lane::IpmOptions ipm;
  std::vector<cv::Mat> frames;            // decoded BGR, 640x480
  std::vector<std::vector<uchar>> jpegs;  // the same frames as JPEG
  std::unique_ptr<Detector> detector;
  std::vector<lane::Intermediates> inter;  // per-frame intermediates
};

std::string DataDir() { return SharedDataDir("culane-driver161-a"); }

void Finish(FrameSet& set) {
  auto det = Detector::Create(set.camera, set.ipm, lane::DetectorOptions{});
  if (!det.ok()) return;
  set.detector = std::make_unique<Detector>(*std::move(det));
  lane::DetectorOptions keep;
  keep.keep_intermediates = true;
  auto dbg = Detector::Create(set.camera, set.ipm, keep);
  for (const auto& f : set.frames) {
    std::vector<uchar> buf;
    cv::imencode(".jpg", f, buf, {cv::IMWRITE_JPEG_QUALITY, 90});
    set.jpegs.push_back(std::move(buf));
    set.inter.push_back(*dbg->Detect(f)->debug);
  }
}

FrameSet* Synthetic() {
  static FrameSet* set = [] {
    auto* s = new FrameSet;
    for (int i = 0; i < 64; ++i) {
      auto f = lane::RenderSyntheticFrame(s->camera, lane::SyntheticOptions{}, 9000 + i);
      if (f.ok()) s->frames.push_back(f->bgr);
    }
    Finish(*s);
    return s;
  }();
  return set;
}

FrameSet* Culane() {
  static FrameSet* set = []() -> FrameSet* {
    const std::string dir = DataDir();
    if (dir.empty()) return nullptr;
    auto* s = new FrameSet;
    // The clip's camera (see configs/culane-driver161.json), scaled from
    // 1640x590 to 640x480.
    const double sx = 640.0 / 1640.0, sy = 480.0 / 590.0;
    s->camera.fu = 1000 * sx;
    s->camera.fv = 1000 * sy;
    s->camera.cu = 820 * sx;
    s->camera.cv = 295 * sy;
    s->camera.pitch_deg = -4.858;
    s->camera.yaw_deg = 3.706;
    s->camera.height_m = 1.3;
    s->ipm.roi = {250 * sx, 1250 * sx, 420 * sy, 550 * sy};
    for (const auto& f : FilesWithExtension(dir, ".jpg")) {
      cv::Mat img = cv::imread(f);
      if (img.empty()) continue;
      cv::resize(img, img, cv::Size(640, 480), 0, 0, cv::INTER_AREA);
      s->frames.push_back(img);
    }
    if (s->frames.empty()) return nullptr;
    Finish(*s);
    return s;
  }();
  return set;
}

FrameSet* Get(const benchmark::State& state) {
  return state.range(0) == 0 ? Synthetic() : Culane();
}

bool Skip(benchmark::State& state, FrameSet* set) {
  if (set && set->detector) return false;
  state.SkipWithError("../shared/data/culane-driver161-a not present: culane frame set skipped");
  return true;
}

void SetLabel(benchmark::State& state) {
  state.SetLabel(state.range(0) == 0 ? "synthetic" : "culane");
}

// Detects the frames in turn; the mean time of each stage and the mean lane
// count are the run's counters.
void RunDetect(benchmark::State& state, const Detector& detector,
               const std::vector<cv::Mat>& frames) {
  size_t i = 0;
  std::map<std::string, double> stage;
  for (auto _ : state) {
    auto r = detector.Detect(frames[i++ % frames.size()]);
    benchmark::DoNotOptimize(r);
    const auto& t = r->timings;
    for (size_t k = 0; k < lane::DetectorStageCount(); ++k) {
      if (t.ran[k]) stage[absl::StrCat(lane::DetectorStageName(k), "_ms")] += t.stage_ms[k];
    }
    stage["lanes"] += r->lanes.size();
  }
  for (const auto& [k, v] : stage) state.counters[k] = v / state.iterations();
}

void BM_Detect(benchmark::State& state) {
  FrameSet* set = Get(state);
  if (Skip(state, set)) return;
  RunDetect(state, *set->detector, set->frames);
  SetLabel(state);
}

void BM_JpegDecode(benchmark::State& state) {
  FrameSet* set = Get(state);
  if (Skip(state, set)) return;
  size_t i = 0;
  for (auto _ : state) {
    cv::Mat img = cv::imdecode(set->jpegs[i++ % set->jpegs.size()], cv::IMREAD_COLOR);
    benchmark::DoNotOptimize(img.data);
  }
  SetLabel(state);
}

void BM_DecodeAndDetect(benchmark::State& state) {
  FrameSet* set = Get(state);
  if (Skip(state, set)) return;
  size_t i = 0;
  for (auto _ : state) {
    cv::Mat img = cv::imdecode(set->jpegs[i++ % set->jpegs.size()], cv::IMREAD_COLOR);
    auto r = set->detector->Detect(img);
    benchmark::DoNotOptimize(r);
  }
  SetLabel(state);
}

void BM_StageIpm(benchmark::State& state) {
  FrameSet* set = Get(state);
  if (Skip(state, set)) return;
  size_t i = 0;
  for (auto _ : state) {
    cv::Mat top = set->detector->ipm().Apply(set->frames[i++ % set->frames.size()], 2);
    benchmark::DoNotOptimize(top.data);
  }
  SetLabel(state);
}

void BM_StageFilter(benchmark::State& state) {
  FrameSet* set = Get(state);
  if (Skip(state, set)) return;
  size_t i = 0;
  for (auto _ : state) {
    cv::Mat f = lane::FilterTopView(set->inter[i++ % set->inter.size()].ipm,
                                    set->detector->kernels(), set->detector->options().filter);
    benchmark::DoNotOptimize(f.data);
  }
  SetLabel(state);
}

void BM_StageThreshold(benchmark::State& state) {
  FrameSet* set = Get(state);
  if (Skip(state, set)) return;
  size_t i = 0;
  cv::Mat work;
  for (auto _ : state) {
    // As the detector calls it: from the filtered view into a second image.
    benchmark::DoNotOptimize(
        lane::ApplyQuantileThreshold(set->inter[i++ % set->inter.size()].filtered, work, 0.975));
  }
  SetLabel(state);
}

void BM_StageHoughAndLines(benchmark::State& state) {
  FrameSet* set = Get(state);
  if (Skip(state, set)) return;
  const auto& o = set->detector->options();
  const double mpp = set->detector->ipm().metres_per_px_x();
  std::mt19937_64 rng(1);
  size_t i = 0;
  for (auto _ : state) {
    const cv::Mat& th = set->inter[i++ % set->inter.size()].thresholded;
    const auto peaks = lane::FindColumnPeaks(lane::ColumnProfile(th, o.hough.smooth_sigma_px),
                                             o.hough.min_peak, o.hough.group_distance_m / mpp);
    for (const auto& p : peaks) {
      auto line = lane::FitLineInWindow(th, p.x, o.line_ransac.window_half_width_m / mpp,
                                        o.line_ransac, rng);
      benchmark::DoNotOptimize(line);
    }
  }
  SetLabel(state);
}

void BM_StageSplines(benchmark::State& state) {
  FrameSet* set = Get(state);
  if (Skip(state, set)) return;
  const auto& o = set->detector->options();
  const double mpp = set->detector->ipm().metres_per_px_x();
  std::mt19937_64 rng(1);
  size_t i = 0;
  for (auto _ : state) {
    const auto& in = set->inter[i++ % set->inter.size()];
    for (const auto& line : in.lines) {
      auto fit = lane::FitSplineAroundLine(
          in.thresholded, line, o.spline_ransac.window_half_width_m / mpp, o.spline_ransac, rng);
      benchmark::DoNotOptimize(fit);
    }
  }
  SetLabel(state);
}

// ---- Real clips on the shipped configs ---------------------------------------------
//
// What users run: the frames at their own size with the config shipped for
// their camera (Arg 0: cordova1, 640x480, configs/caltech.json; Arg 1:
// driver161, 1640x590, configs/culane-driver161.json). The issue 14 targets
// are the medians of BM_DetectClip.

struct ClipSet {
  std::string name;
  std::unique_ptr<Detector> detector;
  std::vector<cv::Mat> frames;  // decoded BGR, full size
  // The frames as JPEG: the clip's own files, or its PNGs encoded at q90.
  std::vector<std::string> jpegs;
};

ClipSet* LoadClip(const std::string& name, const std::string& config, const std::string& ext,
                  size_t max_frames) {
  const std::string dir = SharedDataDir(name);
  if (dir.empty()) return nullptr;
  auto parsed = lane::LoadConfigFile(std::string(LANE_SOURCE_DIR) + "/configs/" + config);
  if (!parsed.ok()) return nullptr;
  auto det = Detector::Create(parsed->camera, parsed->ipm, parsed->detector);
  if (!det.ok()) return nullptr;
  auto* set = new ClipSet;
  set->name = name + " " + config;
  set->detector = std::make_unique<Detector>(*std::move(det));
  const std::vector<std::string> files = FilesWithExtension(dir, ext);
  // Spread over the clip: every k-th frame.
  const size_t step = std::max<size_t>(1, files.size() / max_frames);
  for (size_t i = 0; i < files.size() && set->frames.size() < max_frames; i += step) {
    cv::Mat img = cv::imread(files[i]);
    if (img.empty()) continue;
    set->frames.push_back(img);
    if (ext == ".jpg") {
      std::ifstream in(files[i], std::ios::binary);
      set->jpegs.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    } else {
      std::vector<uchar> buf;
      cv::imencode(".jpg", img, buf, {cv::IMWRITE_JPEG_QUALITY, 90});
      set->jpegs.emplace_back(buf.begin(), buf.end());
    }
  }
  return set;
}

ClipSet* GetClip(int which) {
  static ClipSet* cordova = LoadClip("caltech-cordova1", "caltech.json", ".png", 64);
  static ClipSet* driver161 = LoadClip("culane-driver161-a", "culane-driver161.json", ".jpg", 60);
  ClipSet* set = which == 0 ? cordova : driver161;
  return set != nullptr && !set->frames.empty() ? set : nullptr;
}

void BM_DetectClip(benchmark::State& state) {
  ClipSet* set = GetClip(static_cast<int>(state.range(0)));
  if (set == nullptr) {
    state.SkipWithError("clip not present (../shared/data)");
    return;
  }
  RunDetect(state, *set->detector, set->frames);
  state.SetLabel(set->name);
}
BENCHMARK(BM_DetectClip)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// A tracked frame (docs/tracking.md), as lane detect --track and the service's streams
// process one (lane::FrameTracker): detection with the tracker's predicted lanes searched,
// each lane's colour and type read from the image, then the tracker, the lanes drawn from it
// and the ego lane, over the clip's frames in order (restarted at the clip's start). The
// counter detect_ms is the mean untracked detection time of the same frames, measured in the
// same run: the benchmark's time over it is what tracking costs a frame.
void BM_TrackClip(benchmark::State& state) {
  ClipSet* set = GetClip(static_cast<int>(state.range(0)));
  if (set == nullptr) {
    state.SkipWithError("clip not present (../shared/data)");
    return;
  }
  double detect_ms = 0;
  for (const cv::Mat& f : set->frames) detect_ms += set->detector->Detect(f)->timings.total_ms;
  detect_ms /= static_cast<double>(set->frames.size());
  std::optional<lane::FrameTracker> tracker;
  size_t i = 0;
  double t = 0;
  for (auto _ : state) {
    const size_t k = i++ % set->frames.size();
    if (k == 0) tracker.emplace(set->detector->ipm().camera());
    auto tracked = tracker->Process(*set->detector, set->frames[k], t += 1.0 / 15);
    benchmark::DoNotOptimize(tracked);
  }
  state.counters["detect_ms"] = detect_ms;
  state.SetLabel(set->name);
}
BENCHMARK(BM_TrackClip)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// ---- Tracked against untracked, frame by frame (issue 36) -------------------------
//
// A camera's frames in order: all 250 of cordova1 (configs/caltech.json;
// Arg 0, when ../shared/data is present) or the rendered 300-frame drive of
// the drive test (seed 7, configs/caltech.json; Arg 1). Each iteration runs
// the sequence untracked (Detector::Detect) and tracked (FrameTracker::
// Process from a fresh tracker), and the counters are per-frame medians over
// all iterations: untracked_ms and tracked_ms (the detection's total, as
// lane detect reports it), ratio (their ratio), process_ms (the tracked
// frame whole: detection, marking colour and type, tracker), and the share
// of the tracked frames' lanes that were refitted (refit_share) and of the
// refits tried that failed and were searched (refit_failed_share). Arg 1 is
// LaneTrackingOptions::refit_frames: the default, or 0 (no refits: every
// tracked frame searched, the path before issue 36).
struct Sequence {
  std::string name;
  std::unique_ptr<Detector> detector;
  std::vector<cv::Mat> frames;
  std::vector<double> times_s;
};

Sequence* LoadSequence(int which) {
  auto config = lane::LoadConfigFile(std::string(LANE_SOURCE_DIR) + "/configs/caltech.json");
  if (!config.ok()) return nullptr;
  auto det = Detector::Create(config->camera, config->ipm, config->detector);
  if (!det.ok()) return nullptr;
  auto* seq = new Sequence;
  seq->detector = std::make_unique<Detector>(*std::move(det));
  if (which == 0) {
    const std::string dir = SharedDataDir("caltech-cordova1");
    if (dir.empty()) return nullptr;
    seq->name = "caltech-cordova1, 250 frames in order";
    for (const std::string& f : FilesWithExtension(dir, ".png")) {
      cv::Mat img = cv::imread(f);
      if (img.empty()) continue;
      seq->times_s.push_back(static_cast<double>(seq->frames.size()) / 15.0);
      seq->frames.push_back(img);
    }
  } else {
    seq->name = "rendered drive, 300 frames (seed 7)";
    const lane::SyntheticDriveOptions options;
    for (int i = 0; i < options.count; ++i) {
      auto f = lane::RenderSyntheticDriveFrame(config->camera, options, 7, i);
      if (!f.ok()) return nullptr;
      seq->frames.push_back(f->bgr);
      seq->times_s.push_back(f->time_s);
    }
  }
  return seq->frames.empty() ? nullptr : seq;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

void BM_TrackedVsUntracked(benchmark::State& state) {
  static Sequence* cordova = LoadSequence(0);
  static Sequence* drive = LoadSequence(1);
  Sequence* seq = state.range(0) == 0 ? cordova : drive;
  if (seq == nullptr) {
    state.SkipWithError("caltech-cordova1 not present (../shared/data)");
    return;
  }
  std::vector<double> untracked, tracked, process;
  double refit = 0, lanes = 0, failed = 0;
  for (auto _ : state) {
    for (const cv::Mat& f : seq->frames) {
      auto d = seq->detector->Detect(f);
      untracked.push_back(d->timings.total_ms);
    }
    lane::LaneTrackingOptions tracking;
    tracking.refit_frames = static_cast<int>(state.range(1));
    lane::FrameTracker tracker(seq->detector->ipm().camera(), tracking);
    for (size_t i = 0; i < seq->frames.size(); ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      auto frame = tracker.Process(*seq->detector, seq->frames[i], seq->times_s[i]);
      process.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      const lane::Detection& d = frame->detection;
      tracked.push_back(d.timings.total_ms);
      refit += d.refit_lanes;
      failed += d.refit_failed;
      // Lanes found, refitted or searched (as lane detect --track counts).
      const lane::LanePathCounts paths = lane::CountLanePaths(d);
      lanes += paths.refit + paths.searched;
    }
  }
  const double u = Median(untracked), t = Median(tracked);
  state.counters["untracked_ms"] = u;
  state.counters["tracked_ms"] = t;
  state.counters["ratio"] = t / u;
  state.counters["process_ms"] = Median(process);
  state.counters["refit_share"] = lanes > 0 ? refit / lanes : 0;
  state.counters["refit_failed_share"] = refit + failed > 0 ? failed / (refit + failed) : 0;
  state.SetLabel(seq->name);
}
BENCHMARK(BM_TrackedVsUntracked)
    ->Args({0, lane::LaneTrackingOptions{}.refit_frames})
    ->Args({0, 0})
    ->Args({1, lane::LaneTrackingOptions{}.refit_frames})
    ->Args({1, 0})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);

// Decode + detect of the clips' frames as JPEGs (driver161's own files,
// cordova1's PNGs encoded at q90), the whole frame (range(1) = 0, DecodeImage:
// what the service did before issue 14) or only what the detector reads
// (range(1) = 1, DecodeForDetector: the service's and `lane detect`'s
// default now).
void BM_DecodeDetectClip(benchmark::State& state) {
  ClipSet* set = GetClip(static_cast<int>(state.range(0)));
  if (set == nullptr) {
    state.SkipWithError("clip not present (../shared/data)");
    return;
  }
  const std::vector<std::string>& encoded = set->jpegs;
  const bool fast = state.range(1) == 1;
  lane::decode::DecodeOptions options;
  options.width = set->frames[0].cols;
  options.height = set->frames[0].rows;
  size_t i = 0;
  for (auto _ : state) {
    const std::string& bytes = encoded[i++ % encoded.size()];
    auto frame = fast ? lane::decode::DecodeForDetector(bytes, options, set->detector->Needs())
                      : lane::decode::DecodeImage(bytes, options);
    if (!frame.ok()) {
      state.SkipWithError(std::string(frame.status().message()).c_str());
      return;
    }
    auto r = set->detector->Detect(*frame);
    benchmark::DoNotOptimize(r);
  }
  state.SetLabel(set->name + (fast ? " fast" : " full"));
}
BENCHMARK(BM_DecodeDetectClip)
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({1, 0})
    ->Args({1, 1})
    ->Unit(benchmark::kMicrosecond);

// Arg 0 = synthetic frames, 1 = culane frames.
#define LANE_BENCH(fn) BENCHMARK(fn)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond)
LANE_BENCH(BM_Detect);
LANE_BENCH(BM_JpegDecode);
LANE_BENCH(BM_DecodeAndDetect);
LANE_BENCH(BM_StageIpm);
LANE_BENCH(BM_StageFilter);
LANE_BENCH(BM_StageThreshold);
LANE_BENCH(BM_StageHoughAndLines);
LANE_BENCH(BM_StageSplines);

}  // namespace

int main(int argc, char** argv) {
  // One frame per thread: OpenCV's own threads only add overhead on a 160x120 view.
  cv::setNumThreads(0);
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
