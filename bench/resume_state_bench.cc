// What the resume state (issue 37) costs the server per response that
// carries it: the tracker's state saved and encoded (BM_ResumeStateSave), and
// on a resumed stream's first frame, decoded, checked and restored
// (BM_ResumeStateRestore). Six tracked lanes, as on a road with five lanes.
// Sealing (issue 47): the encoded state bound and tagged with HMAC-SHA-256
// (BM_ResumeStateSeal), its tag checked and its binding read back
// (BM_ResumeStateOpen); the server does both beside Save and Restore, and
// each must stay under 20 us.
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <vector>

#include "lane/track/frame_tracker.h"
#include "lane/track/lane_tracker.h"
#include "resume_seal.h"
#include "wire/tracker_state_proto.h"

namespace {

// A tracker's state after 30 frames of six straight lanes 3.6 m apart.
lane::TrackerState SixLanes() {
  lane::LaneTracker tracker;
  std::vector<lane::Lane> lanes;
  for (int i = 0; i < 6; ++i) {
    const double x = -9.0 + 3.6 * i;
    lane::Lane lane;
    lane.ground = {Eigen::Vector2d(x, 5), Eigen::Vector2d(x, 12), Eigen::Vector2d(x, 19),
                   Eigen::Vector2d(x, 26)};
    lanes.push_back(lane);
  }
  for (int f = 0; f < 30; ++f) tracker.Update(lanes, f / 30.0);
  return tracker.Snapshot();
}

void BM_ResumeStateSave(benchmark::State& state) {
  lane::FrameTracker tracker{lane::CameraModel()};
  if (!tracker.Resume(SixLanes()).ok()) state.SkipWithError("resume failed");
  size_t bytes = 0;
  for (auto _ : state) {
    const std::string encoded = lane::wire::EncodeTrackerState(tracker.Save());
    bytes = encoded.size();
    benchmark::DoNotOptimize(encoded.data());
  }
  state.counters["bytes"] = static_cast<double>(bytes);
}
BENCHMARK(BM_ResumeStateSave)->Unit(benchmark::kMicrosecond);

void BM_ResumeStateRestore(benchmark::State& state) {
  const std::string encoded = lane::wire::EncodeTrackerState(SixLanes());
  for (auto _ : state) {
    lane::FrameTracker tracker{lane::CameraModel()};
    absl::StatusOr<lane::TrackerState> decoded = lane::wire::DecodeTrackerState(encoded);
    if (!decoded.ok() || !tracker.Resume(*decoded).ok()) state.SkipWithError("restore failed");
    benchmark::DoNotOptimize(tracker);
  }
}
BENCHMARK(BM_ResumeStateRestore)->Unit(benchmark::kMicrosecond);

lane::server::ResumeBinding BenchBinding() {
  return {"cam0", lane::server::ConfigFingerprint("{}"), 42};
}

void BM_ResumeStateSeal(benchmark::State& state) {
  const lane::server::ResumeStateSeal seal{
      lane::server::ResumeStateKeys(std::string(lane::server::ResumeStateKeys::kMinKeyBytes, 'k'))};
  const std::string encoded = lane::wire::EncodeTrackerState(SixLanes());
  size_t bytes = 0;
  for (auto _ : state) {
    const std::string sealed = seal.Seal(BenchBinding(), encoded);
    bytes = sealed.size();
    benchmark::DoNotOptimize(sealed.data());
  }
  state.counters["bytes"] = static_cast<double>(bytes);
}
BENCHMARK(BM_ResumeStateSeal)->Unit(benchmark::kMicrosecond);

void BM_ResumeStateOpen(benchmark::State& state) {
  const lane::server::ResumeStateSeal seal{
      lane::server::ResumeStateKeys(std::string(lane::server::ResumeStateKeys::kMinKeyBytes, 'k'))};
  const std::string sealed = seal.Seal(BenchBinding(), lane::wire::EncodeTrackerState(SixLanes()));
  for (auto _ : state) {
    absl::StatusOr<lane::server::OpenedResumeState> opened = seal.Open(sealed);
    if (!opened.ok()) state.SkipWithError("open failed");
    benchmark::DoNotOptimize(opened);
  }
}
BENCHMARK(BM_ResumeStateOpen)->Unit(benchmark::kMicrosecond);

}  // namespace
