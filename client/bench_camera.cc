#include "bench_camera.h"

#include <optional>
#include <string>

#include "lane/v1/lane_service.grpc.pb.h"
#include "results.h"
#include "wire/status_map.h"

namespace lane::client::load {

void CameraStream::Pump() {
  absl::MutexLock lock(&mu_);
  if (pumping_) return;  // the pumping thread re-checks after its call
  pumping_ = true;
  while (true) {
    enum { kNone, kWrite, kWritesDone, kRelease } action = kNone;
    bool measured = false;
    uint64_t unsent = 0;
    if (!writing_) {
      if (failed_) {
        // Nothing more can be written: what is queued was never sent.
        for (const Outgoing& o : queue_) {
          if (o.measured) ++unsent;
          inflight_.erase(o.frame_id);
        }
        queue_.clear();
        if (!hold_released_) {
          hold_released_ = true;
          action = kRelease;
        }
      } else if (!queue_.empty()) {
        write_buffer_.Swap(&queue_.front().buffer);
        measured = queue_.front().measured;
        queue_.pop_front();
        writing_ = true;
        action = kWrite;
      } else if (half_close_ && !writes_done_started_) {
        writes_done_started_ = true;
        writing_ = true;
        action = kWritesDone;
      } else if (writes_done_ && !hold_released_) {
        hold_released_ = true;
        action = kRelease;
      }
    }
    if (action == kNone) break;
    mu_.Unlock();
    if (unsent > 0) {
      camera_->WithStats([unsent](CameraStats& stats) { stats.unsent += unsent; });
    }
    switch (action) {
      case kWrite:
        camera_->CountSent(measured);
        StartWrite(&write_buffer_);
        break;
      case kWritesDone:
        StartWritesDone();
        break;
      case kRelease:
        RemoveHold();
        break;
      case kNone:
        break;
    }
    mu_.Lock();
    if (action == kRelease) break;
  }
  pumping_ = false;
}

void CameraStream::OnReadDone(bool ok) {
  if (!ok) {
    {
      absl::MutexLock lock(&mu_);
      failed_ = true;  // the call is over: nothing more can be written
    }
    Pump();
    return;
  }
  const Clock::time_point now = Clock::now();
  v1::FrameResponse response;
  const bool parsed =
      grpc::SerializationTraits<v1::FrameResponse>::Deserialize(&read_buffer_, &response).ok();
  std::optional<Sent> sent;
  if (parsed) {
    absl::MutexLock lock(&mu_);
    answered_any_ = true;
    const auto it = inflight_.find(response.frame_id());
    if (it != inflight_.end()) {
      sent = it->second;
      inflight_.erase(it);
    }
  }
  if (sent && sent->measured) {
    camera_->WithStats([&](CameraStats& stats) {
      const v1::FrameCode code = response.status().code();
      if (code == v1::FRAME_CODE_OK) {
        ++stats.ok;
        const double latency = Ms(now - sent->due);
        stats.latency_ms.push_back(latency);
        stats.server_ms.push_back(static_cast<double>(response.server_send_time_unix_ns() -
                                                      response.server_receive_time_unix_ns()) *
                                  1e-6);
        stats.queue_ms.push_back(response.timings().queue_wait_ms());
        stats.decode_ms.push_back(response.timings().decode_ms());
        stats.detect_ms.push_back(response.timings().detect_ms());
        stats.ok_at_s.push_back(camera_->run().SinceMeasureStart(now));
        stats.last_ok = now;
        ++stats.interval_ok;
        stats.interval_latency_ms += latency;
      } else if (code == v1::FRAME_CODE_DROPPED) {
        ++stats.dropped;
        stats.error_at_s.push_back(camera_->run().SinceMeasureStart(now));
      } else {
        ++stats.failed;
        ++stats.errors[FrameCodeName(code)];
        stats.error_at_s.push_back(camera_->run().SinceMeasureStart(now));
      }
    });
  }
  StartRead(&read_buffer_);
  camera_->OnResponse(this);
}

void CameraStream::OnDone(const grpc::Status& status) {
  uint64_t lost = 0;
  {
    absl::MutexLock lock(&mu_);
    final_status_ = status;
    for (const auto& entry : inflight_) {
      if (entry.second.measured) ++lost;
    }
    inflight_.clear();
  }
  camera_->WithStats([&](CameraStats& stats) {
    if (lost > 0) {
      stats.failed += lost;
      stats.error_at_s.insert(stats.error_at_s.end(), lost,
                              camera_->run().SinceMeasureStart(Clock::now()));
      const std::string code =
          status.ok() ? std::string("UNKNOWN") : lane::wire::GrpcCodeName(status.error_code());
      stats.errors[code] += lost;
    }
    if (!status.ok() && !camera_->run().stopping.load()) ++stats.stream_failures;
  });
  // Last: once the run sees done_ (under its done mutex), it may destroy
  // this stream, so the notification happens under that mutex too.
  camera_->StreamDone(this);
}

}  // namespace lane::client::load
