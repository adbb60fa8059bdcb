// Decoding benchmarks (lane_decode), BM_Decode*: the full decode against the
// region a lane detector reads, on four sets of JPEGs (the Arg):
//   0 caltech-synth  16 rendered 640x480 frames of the Caltech camera, q90;
//                    the region configs/caltech.json's detector reads (rows
//                    149..435, BGR: Detector::Needs)
//   1 culane-synth   16 rendered 1640x590 frames of the CULane clip's camera,
//                    q90; the region of configs/culane-driver161.json (rows
//                    295..590, BGR)
//   2 culane-clip    ../shared/data/culane-driver161-a as they are (1640x590,
//                    the dataset's own JPEGs); the region of 1
//   3 cordova1       ../shared/data/caltech-cordova1 (640x480 PNGs) as q90
//                    JPEGs; the region of 0
// 2 and 3 only when the folders are present. Part of detector_bench (its
// main() is in detector_bench.cc).
#include <benchmark/benchmark.h>

#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "bench_frames.h"
#include "lane/config/config.h"
#include "lane/decode/detector_region.h"
#include "lane/decode/image_decoder.h"
#include "lane/detector/detector.h"
#include "lane/synthetic.h"

namespace {

using lane::CameraModel;
using lane::Detector;
using lane::bench::FilesWithExtension;
using lane::bench::SharedDataDir;

struct DecodeSet {
  std::string name;
  cv::Size size;
  std::vector<std::string> jpegs;
  lane::decode::DecodeRegion region;  // what the detector reads
};

std::string EncodeJpeg(const cv::Mat& bgr, int quality) {
  std::vector<uchar> buf;
  cv::imencode(".jpg", bgr, buf, {cv::IMWRITE_JPEG_QUALITY, quality});
  return std::string(buf.begin(), buf.end());
}

// What the shipped config's detector reads of a frame (Detector::Needs): the
// region the service and `lane detect` decode.
lane::decode::DecodeRegion ShippedRegion(const std::string& config) {
  const auto parsed = lane::LoadConfigFile(std::string(LANE_SOURCE_DIR) + "/configs/" + config);
  if (!parsed.ok()) return lane::decode::DecodeRegion{};
  const auto detector = Detector::Create(parsed->camera, parsed->ipm, parsed->detector);
  if (!detector.ok()) return lane::decode::DecodeRegion{};
  return lane::decode::RegionFor(detector->Needs());
}

lane::decode::DecodeRegion CaltechRegion() { return ShippedRegion("caltech.json"); }

lane::decode::DecodeRegion CulaneRegion() { return ShippedRegion("culane-driver161.json"); }

DecodeSet* RenderedDecodeSet(const CameraModel& camera, const std::string& name,
                             const lane::decode::DecodeRegion& region) {
  auto* set = new DecodeSet;
  set->name = name;
  set->size = cv::Size(camera.image_width, camera.image_height);
  set->region = region;
  for (int i = 0; i < 16; ++i) {
    auto f = lane::RenderSyntheticFrame(camera, lane::SyntheticOptions{}, 7000 + i);
    if (f.ok()) set->jpegs.push_back(EncodeJpeg(f->bgr, 90));
  }
  return set;
}

DecodeSet* GetDecodeSet(int which) {
  static DecodeSet* caltech_synth =
      RenderedDecodeSet(CameraModel{}, "caltech-synth", CaltechRegion());
  static DecodeSet* culane_synth = [] {
    CameraModel camera;  // configs/culane-driver161.json
    camera.fu = 1000;
    camera.fv = 1000;
    camera.cu = 820;
    camera.cv = 295;
    camera.pitch_deg = -4.858;
    camera.yaw_deg = 3.706;
    camera.height_m = 1.3;
    camera.image_width = 1640;
    camera.image_height = 590;
    return RenderedDecodeSet(camera, "culane-synth", CulaneRegion());
  }();
  static DecodeSet* culane_clip = []() -> DecodeSet* {
    const std::string dir = SharedDataDir("culane-driver161-a");
    if (dir.empty()) return nullptr;
    auto* set = new DecodeSet{"culane-clip", cv::Size(1640, 590), {}, CulaneRegion()};
    for (const std::string& f : FilesWithExtension(dir, ".jpg")) {
      std::ifstream in(f, std::ios::binary);
      set->jpegs.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    return set;
  }();
  static DecodeSet* cordova = []() -> DecodeSet* {
    const std::string dir = SharedDataDir("caltech-cordova1");
    if (dir.empty()) return nullptr;
    auto* set = new DecodeSet{"cordova1-q90", cv::Size(640, 480), {}, CaltechRegion()};
    const std::vector<std::string> files = FilesWithExtension(dir, ".png");
    for (size_t i = 0; i < files.size() && set->jpegs.size() < 64; i += 4) {
      const cv::Mat img = cv::imread(files[i]);
      if (!img.empty() && img.size() == set->size) set->jpegs.push_back(EncodeJpeg(img, 90));
    }
    return set;
  }();
  DecodeSet* sets[] = {caltech_synth, culane_synth, culane_clip, cordova};
  DecodeSet* set = which >= 0 && which < 4 ? sets[which] : nullptr;
  return set != nullptr && !set->jpegs.empty() ? set : nullptr;
}

bool SkipDecode(benchmark::State& state, DecodeSet* set) {
  if (set != nullptr) {
    size_t bytes = 0;
    for (const std::string& j : set->jpegs) bytes += j.size();
    state.SetLabel(set->name + " " + std::to_string(bytes / set->jpegs.size() / 1024) + " KiB");
    return false;
  }
  state.SkipWithError("frame set not present (../shared/data)");
  return true;
}

lane::decode::DecodeOptions DecodeOptionsFor(const DecodeSet& set, bool gray = false) {
  lane::decode::DecodeOptions options;
  options.width = set.size.width;
  options.height = set.size.height;
  options.gray = gray;
  return options;
}

// What the service and `lane detect` pay today: the whole frame, BGR.
void BM_DecodeFull(benchmark::State& state) {
  DecodeSet* set = GetDecodeSet(static_cast<int>(state.range(0)));
  if (SkipDecode(state, set)) return;
  const lane::decode::DecodeOptions options = DecodeOptionsFor(*set);
  size_t i = 0;
  for (auto _ : state) {
    auto image = lane::decode::DecodeImage(set->jpegs[i++ % set->jpegs.size()], options);
    if (!image.ok()) state.SkipWithError(std::string(image.status().message()).c_str());
    benchmark::DoNotOptimize(image);
  }
}

// The whole frame, grey (Y only).
void BM_DecodeFullGray(benchmark::State& state) {
  DecodeSet* set = GetDecodeSet(static_cast<int>(state.range(0)));
  if (SkipDecode(state, set)) return;
  const lane::decode::DecodeOptions options = DecodeOptionsFor(*set, true);
  size_t i = 0;
  for (auto _ : state) {
    auto image = lane::decode::DecodeImage(set->jpegs[i++ % set->jpegs.size()], options);
    if (!image.ok()) state.SkipWithError(std::string(image.status().message()).c_str());
    benchmark::DoNotOptimize(image);
  }
}

// The timed loop of the region decodes: `region` of the set's frames in turn.
void TimeRegionDecode(benchmark::State& state, const DecodeSet& set,
                      const lane::decode::DecodeRegion& region) {
  const lane::decode::DecodeOptions options = DecodeOptionsFor(set);
  size_t i = 0;
  for (auto _ : state) {
    auto decoded =
        lane::decode::DecodeImageRegion(set.jpegs[i++ % set.jpegs.size()], options, region);
    if (!decoded.ok()) state.SkipWithError(std::string(decoded.status().message()).c_str());
    benchmark::DoNotOptimize(decoded);
  }
}

// The region and channel the detector reads.
void BM_DecodeRegion(benchmark::State& state) {
  DecodeSet* set = GetDecodeSet(static_cast<int>(state.range(0)));
  if (SkipDecode(state, set)) return;
  TimeRegionDecode(state, *set, set->region);
}

// The same region, BGR: what the channel choice is worth.
void BM_DecodeRegionBgr(benchmark::State& state) {
  DecodeSet* set = GetDecodeSet(static_cast<int>(state.range(0)));
  if (SkipDecode(state, set)) return;
  lane::decode::DecodeRegion region = set->region;
  region.output = lane::decode::DecodeRegion::Output::kBgr;
  TimeRegionDecode(state, *set, region);
}

// The floor of any region decode: only the frame's last 16 rows, grey. A
// baseline JPEG has no index into its entropy-coded data, so libjpeg-turbo
// still Huffman-decodes every row above them (jpeg_skip_scanlines skips
// only the inverse DCT, upsampling and colour conversion of what it skips);
// what this costs against BM_DecodeFull is the least any row or channel
// choice can reach on the same files.
void BM_DecodeFloor(benchmark::State& state) {
  DecodeSet* set = GetDecodeSet(static_cast<int>(state.range(0)));
  if (SkipDecode(state, set)) return;
  lane::decode::DecodeRegion region;
  region.top = set->size.height - 16;
  region.output = lane::decode::DecodeRegion::Output::kGray;
  TimeRegionDecode(state, *set, region);
}

// The detector's region at 1/2, 1/4 and 1/8 of the frame's size (the second
// Arg): libjpeg's DCT scaling, which issue 14 asked to use where the top view
// needs less resolution than the frame has. It shrinks the inverse DCT,
// upsampling and colour conversion, not the entropy decoding, so it cannot
// go below BM_DecodeFloor: what it is worth on a set is BM_DecodeRegion
// against these. (The detector does not use it: see README, Performance.)
void BM_DecodeRegionScaled(benchmark::State& state) {
  DecodeSet* set = GetDecodeSet(static_cast<int>(state.range(0)));
  if (SkipDecode(state, set)) return;
  lane::decode::DecodeRegion region = set->region;
  region.scale_denom = static_cast<int>(state.range(1));
  TimeRegionDecode(state, *set, region);
}
BENCHMARK(BM_DecodeRegionScaled)
    ->ArgsProduct({{0, 1, 2, 3}, {2, 4, 8}})
    ->Unit(benchmark::kMicrosecond);

// For reference: OpenCV's decode of the whole frame (the same libjpeg-turbo).
void BM_DecodeOpenCv(benchmark::State& state) {
  DecodeSet* set = GetDecodeSet(static_cast<int>(state.range(0)));
  if (SkipDecode(state, set)) return;
  size_t i = 0;
  for (auto _ : state) {
    const std::string& jpeg = set->jpegs[i++ % set->jpegs.size()];
    const cv::Mat buffer(1, static_cast<int>(jpeg.size()), CV_8UC1, const_cast<char*>(jpeg.data()));
    cv::Mat img = cv::imdecode(buffer, cv::IMREAD_COLOR);
    benchmark::DoNotOptimize(img.data);
  }
}

#define LANE_DECODE_BENCH(fn) \
  BENCHMARK(fn)->Arg(0)->Arg(1)->Arg(2)->Arg(3)->Unit(benchmark::kMicrosecond)
LANE_DECODE_BENCH(BM_DecodeFull);
LANE_DECODE_BENCH(BM_DecodeFullGray);
LANE_DECODE_BENCH(BM_DecodeRegion);
LANE_DECODE_BENCH(BM_DecodeRegionBgr);
LANE_DECODE_BENCH(BM_DecodeFloor);
LANE_DECODE_BENCH(BM_DecodeOpenCv);

}  // namespace
