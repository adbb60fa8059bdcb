#include "live_feed.h"

#include <algorithm>
#include <utility>

namespace lane::server {
namespace {

constexpr int64_t kNanosPerSecond = 1000000000;
// The longest error message kept (the status page shows it).
constexpr size_t kMaxErrorBytes = 300;

int64_t FloorSecond(int64_t unix_ns) {
  return unix_ns >= 0 ? unix_ns / kNanosPerSecond : (unix_ns + 1) / kNanosPerSecond - 1;
}

// Lanes the frame shows: neither a tracked lane's prediction nor inferred.
uint32_t FoundLanes(const v1::FrameResponse& response) {
  uint32_t n = 0;
  for (const v1::Lane& lane : response.lanes()) n += !lane.predicted() && !lane.inferred();
  return n;
}

double Quantile(std::vector<float>& values, double q) {
  if (values.empty()) return 0;
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * (values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace

LiveFrame LiveFrame::Copy(const cv::Mat& frame, int top, int bottom) {
  LiveFrame out;
  out.width = frame.cols;
  out.height = frame.rows;
  top = std::clamp(top, 0, frame.rows);
  bottom = std::clamp(bottom, top, frame.rows);
  out.top = top;
  if (bottom > top) out.rows = frame.rowRange(top, bottom).clone();
  return out;
}

LiveFeed::LiveFeed(int64_t draw_interval_ns) : draw_interval_ns_(draw_interval_ns) {}

bool LiveFeed::ClaimDrawTurn(int64_t now_ns) {
  if (!Watched(now_ns)) return false;
  int64_t due = next_draw_ns_.load(std::memory_order_relaxed);
  if (now_ns < due) return false;
  return next_draw_ns_.compare_exchange_strong(due, now_ns + draw_interval_ns_,
                                               std::memory_order_relaxed);
}

bool LiveFeed::Record(const v1::FrameResponse& response, LiveFrame frame, int64_t now_ns) {
  const int64_t sent_ns =
      response.server_send_time_unix_ns() > 0 ? response.server_send_time_unix_ns() : now_ns;
  const float latency_ms =
      response.server_receive_time_unix_ns() > 0
          ? static_cast<float>((sent_ns - response.server_receive_time_unix_ns()) * 1e-6)
          : 0.0f;
  const bool ok = response.status().code() == v1::FRAME_CODE_OK;
  const uint32_t lanes = ok ? FoundLanes(response) : 0;
  const bool watched = Watched(now_ns);

  absl::MutexLock lock(&mu_);
  const int64_t second = FloorSecond(sent_ns);
  LiveSecond& bucket = seconds_[static_cast<size_t>(second % kHistorySeconds)];
  if (bucket.second != second) bucket = LiveSecond{second};
  ++bucket.frames;
  bucket.latency_sum_ms += latency_ms;
  bucket.latency_max_ms = std::max(bucket.latency_max_ms, latency_ms);
  if (ok) {
    ++bucket.ok_frames;
    bucket.lanes += lanes;
    bucket.zero_lane_frames += lanes == 0;
  } else {
    last_error_ = response.status().message().substr(0, kMaxErrorBytes);
    last_error_code_ = v1::FrameCode_Name(response.status().code());
    last_error_unix_ns_ = sent_ns;
  }
  const size_t slot = static_cast<size_t>(frames_total_ % kLatencySamples);
  latency_at_ns_[slot] = sent_ns;
  latency_ms_[slot] = latency_ms;
  ++frames_total_;
  last_frame_unix_ns_ = std::max(last_frame_unix_ns_, sent_ns);
  if (!watched) return false;
  // The lanes (and the ego lane) for the table; not the resume state.
  v1::FrameResponse& kept = last_response_.emplace();
  kept.set_frame_id(response.frame_id());
  kept.set_server_send_time_unix_ns(sent_ns);
  *kept.mutable_lanes() = response.lanes();
  if (response.has_ego()) *kept.mutable_ego() = response.ego();
  *kept.mutable_status() = response.status();
  if (frame.empty()) return false;
  // Posted once: a sample replacing one not yet drawn is already posted.
  const bool posted = !sample_.has_value();
  sample_.emplace(LiveSample{std::move(frame), kept});
  return posted;
}

void LiveFeed::Watch(int64_t until_ns) {
  int64_t current = watched_until_ns_.load(std::memory_order_relaxed);
  while (current < until_ns &&
         !watched_until_ns_.compare_exchange_weak(current, until_ns, std::memory_order_relaxed)) {
  }
}

std::optional<LiveSample> LiveFeed::TakeSample() {
  absl::MutexLock lock(&mu_);
  std::optional<LiveSample> out = std::move(sample_);
  sample_.reset();
  return out;
}

void LiveFeed::SetPictures(std::shared_ptr<const LivePictures> pictures) {
  absl::MutexLock lock(&mu_);
  pictures_ = std::move(pictures);
}

std::shared_ptr<const LivePictures> LiveFeed::pictures() const {
  absl::MutexLock lock(&mu_);
  return pictures_;
}

std::optional<v1::FrameResponse> LiveFeed::LastResponse() const {
  absl::MutexLock lock(&mu_);
  return last_response_;
}

void LiveFeed::Forget() {
  std::optional<LiveSample> sample;  // freed outside the lock
  std::shared_ptr<const LivePictures> pictures;
  absl::MutexLock lock(&mu_);
  sample = std::move(sample_);
  sample_.reset();
  pictures = std::move(pictures_);
  pictures_.reset();
  last_response_.reset();
}

bool LiveFeed::HoldsFrame() const {
  absl::MutexLock lock(&mu_);
  return sample_.has_value() || pictures_ != nullptr;
}

LiveSummary LiveFeed::Summarize(int64_t now_ns, int64_t window_ns) const {
  LiveSummary s;
  std::vector<float> latencies;
  absl::MutexLock lock(&mu_);
  s.frames_total = frames_total_;
  s.last_frame_unix_ns = last_frame_unix_ns_;
  s.last_error = last_error_;
  s.last_error_code = last_error_code_;
  s.last_error_unix_ns = last_error_unix_ns_;
  const int64_t from_ns = now_ns - window_ns;
  // Whole seconds: the current one is partial, so the window ends at its
  // start and covers the `window_ns` seconds before.
  const int64_t last_second = FloorSecond(now_ns) - 1;
  const int64_t first_second = last_second - window_ns / kNanosPerSecond + 1;
  uint64_t lanes = 0;
  for (const LiveSecond& bucket : seconds_) {
    if (bucket.second < first_second || bucket.second > last_second) continue;
    s.window_frames += bucket.frames;
    s.window_ok_frames += bucket.ok_frames;
    lanes += bucket.lanes;
  }
  s.window_s = static_cast<double>(last_second - first_second + 1);
  s.fps = s.window_frames / s.window_s;
  s.lanes_per_frame = s.window_ok_frames > 0 ? double(lanes) / s.window_ok_frames : 0.0;
  const size_t held = static_cast<size_t>(std::min<uint64_t>(frames_total_, kLatencySamples));
  latencies.reserve(held);
  for (size_t i = 0; i < held; ++i) {
    if (latency_at_ns_[i] >= from_ns) latencies.push_back(latency_ms_[i]);
  }
  s.p50_ms = Quantile(latencies, 0.50);
  s.p99_ms = Quantile(latencies, 0.99);
  return s;
}

std::vector<LiveSecond> LiveFeed::History(int64_t now_ns) const {
  std::vector<LiveSecond> out;
  const int64_t newest = FloorSecond(now_ns);
  absl::MutexLock lock(&mu_);
  for (const LiveSecond& bucket : seconds_) {
    if (bucket.second >= 0 && bucket.second > newest - kHistorySeconds) out.push_back(bucket);
  }
  std::sort(out.begin(), out.end(),
            [](const LiveSecond& a, const LiveSecond& b) { return a.second < b.second; });
  return out;
}

}  // namespace lane::server
