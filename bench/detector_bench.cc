// Detector benchmarks: each stage and the whole detection on 640x480 frames
// (decoded BGR in, image-space splines out), plus JPEG decoding of the same
// frames. Run: build/bench/detector_bench --benchmark_repetitions=5
//   --benchmark_report_aggregates_only=true   (medians are the figures to quote)
//
// Frame sets:
//   synthetic  64 rendered frames of the Caltech camera (always)
//   culane     ../shared/data/culane-driver161-a resized to 640x480, with the
//              camera scaled to match (only when the folder is present)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "lane/detector.h"
#include "lane/synthetic.h"

namespace {

namespace fs = std::filesystem;
using lane::CameraModel;
using lane::Detector;

struct FrameSet {
  CameraModel camera;
  lane::IpmOptions ipm;
  std::vector<cv::Mat> frames;            // decoded BGR, 640x480
  std::vector<std::vector<uchar>> jpegs;  // the same frames as JPEG
  std::unique_ptr<Detector> detector;
  std::vector<lane::Intermediates> inter;  // per-frame intermediates
};

std::string DataDir() {
  for (const char* p : {"../shared/data/culane-driver161-a", "../../shared/data/culane-driver161-a",
                        "/work/shared/data/culane-driver161-a"}) {
    if (fs::is_directory(p)) return p;
  }
  if (const char* env = std::getenv("LANE_DATA_DIR"))
    return std::string(env) + "/culane-driver161-a";
  return "";
}

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
    std::vector<std::string> files;
    for (const auto& e : fs::directory_iterator(dir)) {
      if (e.path().extension() == ".jpg") files.push_back(e.path().string());
    }
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
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

void BM_Detect(benchmark::State& state) {
  FrameSet* set = Get(state);
  if (Skip(state, set)) return;
  size_t i = 0;
  std::map<std::string, double> stage;
  for (auto _ : state) {
    auto r = set->detector->Detect(set->frames[i++ % set->frames.size()]);
    benchmark::DoNotOptimize(r);
    const auto& t = r->timings;
    stage["ipm_ms"] += t.ipm_ms;
    stage["filter_ms"] += t.filter_ms;
    stage["threshold_ms"] += t.threshold_ms;
    stage["lines_ms"] += t.lines_ms;
    stage["splines_ms"] += t.splines_ms;
    stage["postprocess_ms"] += t.postprocess_ms;
    stage["lanes"] += r->lanes.size();
  }
  for (const auto& [k, v] : stage) state.counters[k] = v / state.iterations();
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
    set->inter[i++ % set->inter.size()].filtered.copyTo(work);
    benchmark::DoNotOptimize(lane::ApplyQuantileThreshold(work, 0.975));
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
