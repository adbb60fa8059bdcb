// A session's side of the live view (`--live_view`, live_view.h): what the
// frames of a camera leave for people who look at it.
//
// Always (with --live_view): per-second counts over the last minutes and the
// latencies of the last frames, for the status page and the strip chart
// (fixed size, kFixedBytes, counted in the session's memory).
//
// Only while a viewer watches the camera (Watch, renewed by each of its
// requests): the last response's lanes, one sample (a frame and its lanes)
// waiting for the drawer, and the latest pictures drawn from it. When the
// watch lapses the drawer drops them (Forget): a camera nobody watches keeps
// no frame, and its frames cost one atomic load on the frame path.
#ifndef LANE_SERVER_LIVE_FEED_H_
#define LANE_SERVER_LIVE_FEED_H_

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "lane/v1/lane_service.pb.h"

namespace lane::server {

// A frame kept for the live view: a copy of the rows the server decoded.
// With region decoding (lane::Detector::Needs, the default) only the rows the
// detector reads hold the frame (the decoder leaves the others undefined),
// and a session that reads the red channel alone is decoded as that one
// channel (CV_8UC1); raw frames and `decode.full_decode` sessions have every
// row.
struct LiveFrame {
  cv::Mat rows;   // rows top .. top + rows.rows - 1 of the frame: CV_8UC3 (BGR) or CV_8UC1
  int top = 0;    // the first row held
  int width = 0;  // the whole frame's size
  int height = 0;

  bool empty() const { return rows.empty(); }
  // Copies rows [top, bottom) of `frame` (clipped to it).
  static LiveFrame Copy(const cv::Mat& frame, int top, int bottom);
};

// What the drawer draws: a frame and the response written for it.
struct LiveSample {
  LiveFrame frame;
  v1::FrameResponse response;  // the frame's lanes, ego lane, id and times
};

// The pictures of a camera's latest drawn sample (JPEG files).
struct LivePictures {
  uint64_t seq = 0;  // 1, 2, ... per camera
  uint64_t frame_id = 0;
  int64_t drawn_unix_ns = 0;
  std::string frame_jpeg;  // the frame (its size) with the lanes, horizon, vanishing point
  std::string top_jpeg;    // the top view with the lanes
};

// One second of a camera's frames, for the strip chart.
struct LiveSecond {
  int64_t second = -1;  // unix seconds; -1: unused
  uint32_t frames = 0;  // answered after processing (OK or not)
  uint32_t ok_frames = 0;
  uint32_t lanes = 0;  // lanes found in the OK frames (neither predicted nor inferred)
  uint32_t zero_lane_frames = 0;
  float latency_sum_ms = 0;
  float latency_max_ms = 0;
};

// A camera's figures over a recent window (LiveFeed::Summarize).
struct LiveSummary {
  uint64_t frames_total = 0;  // since the session was created
  double window_s = 0;        // the window the rates cover
  double fps = 0;
  double p50_ms = 0;  // frame latency (receive to send), over the window's
  double p99_ms = 0;  // last frames (at most kLatencySamples)
  double lanes_per_frame = 0;
  uint64_t window_frames = 0;
  uint64_t window_ok_frames = 0;
  int64_t last_frame_unix_ns = 0;  // 0: none yet
  std::string last_error;          // "" when no frame has failed
  std::string last_error_code;
  int64_t last_error_unix_ns = 0;
};

class LiveFeed {
 public:
  static constexpr int kHistorySeconds = 300;  // the strip chart: 5 minutes
  static constexpr int kLatencySamples = 1024;
  // What the fixed parts hold, counted in the session's memory.
  static constexpr uint64_t kFixedBytes =
      sizeof(LiveSecond) * kHistorySeconds + (sizeof(int64_t) + sizeof(float)) * kLatencySamples;

  // At most one sample per `draw_interval_ns` while watched.
  explicit LiveFeed(int64_t draw_interval_ns);

  LiveFeed(const LiveFeed&) = delete;
  LiveFeed& operator=(const LiveFeed&) = delete;

  // The frame path, on a worker: true when the camera is watched and its
  // interval has passed since the last sample; the caller then copies the
  // frame. Claims the turn (one frame per interval). Lock-free: a camera
  // that nobody watches pays one relaxed atomic load.
  bool ClaimDrawTurn(int64_t now_ns);
  bool Watched(int64_t now_ns) const {
    return now_ns < watched_until_ns_.load(std::memory_order_relaxed);
  }

  // Every response written after processing, OK or not, with `frame` when
  // the frame was sampled (ClaimDrawTurn): counts it; while watched keeps the
  // response's lanes; with a frame, leaves the sample for the drawer in
  // place of one not yet drawn. True when a sample was left where none was
  // waiting (the drawer must be told).
  bool Record(const v1::FrameResponse& response, LiveFrame frame, int64_t now_ns);

  // The live view's side.
  void Watch(int64_t until_ns);
  // Ends the watch now (its viewer went to another camera).
  void Unwatch() { watched_until_ns_.store(0, std::memory_order_relaxed); }
  std::optional<LiveSample> TakeSample();
  void SetPictures(std::shared_ptr<const LivePictures> pictures);
  std::shared_ptr<const LivePictures> pictures() const;
  // The response of the last frame while watched (its lanes), if any.
  std::optional<v1::FrameResponse> LastResponse() const;
  // The watch has lapsed: drops the sample, the pictures and the response.
  void Forget();
  // A sample or pictures are held (tests: nothing is kept unwatched).
  bool HoldsFrame() const;

  LiveSummary Summarize(int64_t now_ns, int64_t window_ns) const;
  // The seconds of the last kHistorySeconds that had frames, oldest first.
  std::vector<LiveSecond> History(int64_t now_ns) const;

  // Live-view bytes counted against the session memory budget while the
  // camera is watched; changed by SessionRegistry under its lock only.
  std::atomic<uint64_t> reserved_bytes{0};

 private:
  const int64_t draw_interval_ns_;
  std::atomic<int64_t> watched_until_ns_{0};
  std::atomic<int64_t> next_draw_ns_{0};

  mutable absl::Mutex mu_;
  std::array<LiveSecond, kHistorySeconds> seconds_ ABSL_GUARDED_BY(mu_);
  std::array<int64_t, kLatencySamples> latency_at_ns_ ABSL_GUARDED_BY(mu_){};
  std::array<float, kLatencySamples> latency_ms_ ABSL_GUARDED_BY(mu_){};
  uint64_t frames_total_ ABSL_GUARDED_BY(mu_) = 0;
  int64_t last_frame_unix_ns_ ABSL_GUARDED_BY(mu_) = 0;
  std::string last_error_ ABSL_GUARDED_BY(mu_);
  std::string last_error_code_ ABSL_GUARDED_BY(mu_);
  int64_t last_error_unix_ns_ ABSL_GUARDED_BY(mu_) = 0;
  std::optional<v1::FrameResponse> last_response_ ABSL_GUARDED_BY(mu_);
  std::optional<LiveSample> sample_ ABSL_GUARDED_BY(mu_);
  std::shared_ptr<const LivePictures> pictures_ ABSL_GUARDED_BY(mu_);
};

}  // namespace lane::server

#endif  // LANE_SERVER_LIVE_FEED_H_
