// What a `lane-client bench` run is asked to do (LoadSpec) and with which
// frames (BenchFrame): the types the load generator (bench.h) and each of
// its cameras (bench_camera.h) share.
#ifndef LANE_CLIENT_LOAD_SPEC_H_
#define LANE_CLIENT_LOAD_SPEC_H_

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/time/time.h"
#include "lane/v1/lane_service.pb.h"
#include "reconnect_backoff.h"

namespace lane::client {

// One frame of the benchmark, prepared once.
struct BenchFrame {
  std::string name;
  // The frame as a request: only its image (`encoded` or `raw`).
  lane::v1::FrameRequest request;
  // `request` serialized. A message on the wire is a small header (camera id,
  // frame id, capture time) followed by these bytes, which are never copied
  // by the client.
  std::string image_part;
};

struct Progress {
  const char* phase = "";  // "warm-up", "run", "drain"
  double elapsed_s = 0;
  double total_s = 0;
  uint64_t ok = 0;      // measured frames answered OK so far
  uint64_t errors = 0;  // measured frames failed or dropped so far
  double fps = 0;       // OK responses per second over the last interval
  double mean_ms = 0;   // their mean latency
};
using ProgressFn = std::function<void(const Progress&)>;

// One run: the cameras, their sessions, the load and how long.
struct LoadSpec {
  // Cameras are spread over the channels: camera i uses channels[i % size].
  std::vector<std::shared_ptr<grpc::Channel>> channels;
  std::vector<std::string> channel_targets;  // the target of each channel
  int cameras = 1;
  std::string camera_prefix = "bench-";  // camera i is camera_prefix + i
  lane::v1::SessionConfig session;
  bool replace = false;
  bool open_loop = false;
  int inflight = 1;  // closed loop: frames in flight per camera
  double fps = 0;    // open loop: frames per second per camera
  absl::Duration warmup = absl::Seconds(2);
  absl::Duration duration = absl::Seconds(10);
  // After the run, how long the answers of the frames sent are waited for.
  absl::Duration drain_timeout = absl::Seconds(10);
  // Above zero: also summarize the measured window in consecutive intervals
  // of this length (LoadResult::timeline), e.g. for a soak test.
  absl::Duration timeline_interval = absl::ZeroDuration();
  const std::vector<BenchFrame>* frames = nullptr;
  ProgressFn progress;  // about every 0.5 s, from the calling thread
  // A camera stops reconnecting after this many reconnections in a row that
  // failed with the same status code and no frame answered (reconnect_backoff.h);
  // nullopt: never. When every camera has stopped, the run ends early.
  std::optional<int> max_reconnects = kDefaultMaxReconnects;
};

}  // namespace lane::client

#endif  // LANE_CLIENT_LOAD_SPEC_H_
