#include "session_registry.h"

#include <algorithm>
#include <utility>

#include "absl/strings/str_cat.h"
#include "wire/camera_id.h"
#include "wire/status_map.h"

namespace lane::server {

SessionRegistry::SessionRegistry(Options options) : options_(std::move(options)) {}

absl::Status SessionRegistry::ValidateCameraId(absl::string_view camera_id) {
  // The rule the clients check too (wire/camera_id.h).
  return wire::ValidateCameraId(camera_id);
}

absl::Status SessionRegistry::CheckSpec(const SessionSpec& spec) const {
  const lane::CameraModel& camera = spec.config.camera;
  if (int64_t{camera.image_width} * camera.image_height > options_.max_frame_pixels) {
    return wire::InvalidRequest(
        absl::StrCat("session config: the camera's ", camera.image_width, "x", camera.image_height,
                     " frames exceed --max_frame_pixels ", options_.max_frame_pixels));
  }
  if (options_.max_receive_message_bytes > 0 &&
      RawFrameRequestBytes(camera) > options_.max_receive_message_bytes) {
    return wire::InvalidRequest(
        absl::StrCat("session config: a raw ", camera.image_width, "x", camera.image_height,
                     " BGR frame of this camera needs a ", RawFrameRequestBytes(camera),
                     "-byte message, more than --max_receive_message_bytes ",
                     options_.max_receive_message_bytes, "; raise it on the server"));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<Session>> SessionRegistry::ExistingLocked(
    const std::string& camera_id, const std::string& config_json, const StreamPolicy& stream,
    const SessionSpec& spec, bool replace, absl::Time now) {
  auto it = sessions_.find(camera_id);
  if (it != sessions_.end()) {
    const Session& existing = *it->second.session;
    if (existing.config_json == config_json && existing.stream == stream &&
        existing.decode == spec.decode && existing.calibration == spec.calibration &&
        existing.tracking == spec.tracking) {
      it->second.last_used = now;
      return it->second.session;
    }
    if (!replace) return wire::SessionConfigConflict(camera_id, existing.version);
  } else if (sessions_.size() >= options_.max_sessions) {
    return wire::TooManySessions(options_.max_sessions);
  }
  return nullptr;
}

absl::StatusOr<SessionRegistry::CreateResult> SessionRegistry::Create(const std::string& camera_id,
                                                                      const SessionSpec& spec,
                                                                      bool replace) {
  if (absl::Status s = ValidateCameraId(camera_id); !s.ok()) return s;
  if (absl::Status s = CheckSpec(spec); !s.ok()) return s;
  StreamPolicy stream = spec.stream;
  if (stream.max_inflight_frames == 0) {
    stream.max_inflight_frames = options_.default_max_inflight_frames;
  }
  if (stream.max_inflight_frames > 4096) {
    return wire::InvalidRequest("stream.max_inflight_frames must be at most 4096");
  }
  std::string config_json = lane::ConfigToJson(spec.config);
  {
    // A confirmation costs nothing: no detector is built.
    absl::MutexLock lock(&mu_);
    absl::StatusOr<std::shared_ptr<Session>> existing =
        ExistingLocked(camera_id, config_json, stream, spec, replace, options_.clock());
    if (!existing.ok()) return existing.status();
    if (*existing != nullptr) return CreateResult{*std::move(existing), Outcome::kUnchanged};
  }

  // Expensive (IPM maps, kernels): outside the lock.
  absl::StatusOr<lane::Detector> detector =
      lane::Detector::Create(spec.config.camera, spec.config.ipm, spec.config.detector);
  if (!detector.ok()) {
    return wire::InvalidRequest(absl::StrCat("session config: ", detector.status().message()));
  }
  const uint64_t need = detector->MemoryBytes() + config_json.size() +
                        (options_.live_view_draw_interval_ns > 0 ? LiveFeed::kFixedBytes : 0);

  std::shared_ptr<Session> replaced;  // destroyed outside the lock
  absl::MutexLock lock(&mu_);
  const absl::Time now = options_.clock();
  // Another call may have changed the entry meanwhile: check again.
  absl::StatusOr<std::shared_ptr<Session>> existing =
      ExistingLocked(camera_id, config_json, stream, spec, replace, now);
  if (!existing.ok()) return existing.status();
  if (*existing != nullptr) return CreateResult{*std::move(existing), Outcome::kUnchanged};

  uint64_t held = memory_bytes_;
  auto old = sessions_.find(camera_id);
  if (old != sessions_.end()) held -= SessionBytes(*old->second.session);
  if (options_.max_session_memory_bytes > 0 && held + need > options_.max_session_memory_bytes) {
    return wire::SessionMemoryExhausted(need, held, options_.max_session_memory_bytes);
  }
  if (old != sessions_.end()) {
    replaced = std::move(old->second.session);
    RetireLocked(*replaced);
  }

  auto session = std::make_shared<Session>(
      camera_id, next_version_++, spec.config, std::move(config_json), stream, spec.decode,
      *std::move(detector), now, spec.calibration, spec.tracking, epochs_());
  // Its fixed part is in `need`.
  if (options_.live_view_draw_interval_ns > 0) {
    session->live = std::make_unique<LiveFeed>(options_.live_view_draw_interval_ns);
  }
  memory_bytes_ = held + SessionBytes(*session);
  const bool inserted = replaced == nullptr;
  sessions_.insert_or_assign(camera_id, Entry{session, now});
  NotifySizeLocked();
  return CreateResult{std::move(session), inserted ? Outcome::kCreated : Outcome::kReplaced};
}

std::shared_ptr<Session> SessionRegistry::Find(absl::string_view camera_id) {
  absl::MutexLock lock(&mu_);
  auto it = sessions_.find(camera_id);
  if (it == sessions_.end()) return nullptr;
  it->second.last_used = options_.clock();
  return it->second.session;
}

std::shared_ptr<Session> SessionRegistry::Peek(absl::string_view camera_id) const {
  absl::MutexLock lock(&mu_);
  auto it = sessions_.find(camera_id);
  return it == sessions_.end() ? nullptr : it->second.session;
}

absl::Status SessionRegistry::ReserveLiveView(const std::shared_ptr<Session>& session,
                                              uint64_t bytes) {
  if (session == nullptr || session->live == nullptr) {
    return absl::FailedPreconditionError("the live view is off");
  }
  absl::MutexLock lock(&mu_);
  auto it = sessions_.find(session->camera_id);
  if (it == sessions_.end() || it->second.session != session) {
    return wire::SessionNotFound(session->camera_id);
  }
  const uint64_t before = session->live->reserved_bytes.load(std::memory_order_relaxed);
  const uint64_t held = memory_bytes_ - before;
  if (options_.max_session_memory_bytes > 0 && held + bytes > options_.max_session_memory_bytes) {
    return absl::ResourceExhaustedError(
        absl::StrCat("the live view of this camera would hold ", bytes,
                     " bytes and the sessions hold ", held, " of their budget of ",
                     options_.max_session_memory_bytes, " bytes (--max_session_memory_mib)"));
  }
  session->live->reserved_bytes.store(bytes, std::memory_order_relaxed);
  memory_bytes_ = held + bytes;
  return absl::OkStatus();
}

void SessionRegistry::ReleaseLiveView(const std::shared_ptr<Session>& session) {
  if (session == nullptr || session->live == nullptr) return;
  absl::MutexLock lock(&mu_);
  const uint64_t before = session->live->reserved_bytes.exchange(0, std::memory_order_relaxed);
  auto it = sessions_.find(session->camera_id);
  // A session no longer registered took its bytes out when it left.
  if (it != sessions_.end() && it->second.session == session) memory_bytes_ -= before;
}

absl::StatusOr<SessionRegistry::Entry> SessionRegistry::Get(absl::string_view camera_id) {
  absl::MutexLock lock(&mu_);
  auto it = sessions_.find(camera_id);
  if (it == sessions_.end()) return wire::SessionNotFound(camera_id);
  it->second.last_used = options_.clock();
  return it->second;
}

std::vector<SessionRegistry::Entry> SessionRegistry::List() const {
  absl::MutexLock lock(&mu_);
  std::vector<Entry> out;
  out.reserve(sessions_.size());
  for (const auto& [id, entry] : sessions_) out.push_back(entry);
  return out;
}

absl::Status SessionRegistry::Delete(absl::string_view camera_id) {
  std::shared_ptr<Session> doomed;  // destroyed outside the lock
  absl::MutexLock lock(&mu_);
  auto it = sessions_.find(camera_id);
  if (it == sessions_.end()) return wire::SessionNotFound(camera_id);
  doomed = std::move(it->second.session);
  memory_bytes_ -= SessionBytes(*doomed);
  RetireLocked(*doomed);
  sessions_.erase(it);
  NotifySizeLocked();
  return absl::OkStatus();
}

void SessionRegistry::RetireLocked(const Session& session) {
  const uint64_t epoch = session.epoch();
  if (!retired_.insert(epoch).second) return;
  retired_order_.push_back(epoch);
  if (retired_order_.size() > kMaxRetiredEpochs) {
    retired_.erase(retired_order_.front());
    retired_order_.pop_front();
  }
}

bool SessionRegistry::EpochRetired(uint64_t epoch) const {
  absl::MutexLock lock(&mu_);
  return retired_.count(epoch) > 0;
}

size_t SessionRegistry::EvictIdle() {
  if (options_.ttl == absl::InfiniteDuration()) return 0;
  std::vector<std::shared_ptr<Session>> doomed;  // destroyed outside the lock
  absl::MutexLock lock(&mu_);
  const absl::Time cutoff = options_.clock() - options_.ttl;
  for (auto it = sessions_.begin(); it != sessions_.end();) {
    if (it->second.last_used <= cutoff) {
      memory_bytes_ -= SessionBytes(*it->second.session);
      doomed.push_back(std::move(it->second.session));
      it = sessions_.erase(it);
    } else {
      ++it;
    }
  }
  if (!doomed.empty()) NotifySizeLocked();
  return doomed.size();
}

uint64_t SessionRegistry::SessionBytes(const Session& session) {
  uint64_t bytes = session.detector.MemoryBytes() + session.config_json.size();
  if (session.live != nullptr) {
    bytes += LiveFeed::kFixedBytes + session.live->reserved_bytes.load(std::memory_order_relaxed);
  }
  return bytes;
}

uint64_t SessionRegistry::RawFrameRequestBytes(const lane::CameraModel& camera) {
  // The pixels, plus room for the request's other fields (ids, times, the raw
  // image's header and an inline session config of a stream's first frame).
  constexpr uint64_t kRequestOverhead = 64 * 1024;
  return uint64_t(std::max(0, camera.image_width)) * uint64_t(std::max(0, camera.image_height)) *
             3 +
         kRequestOverhead;
}

uint64_t SessionRegistry::memory_bytes() const {
  absl::MutexLock lock(&mu_);
  return memory_bytes_;
}

size_t SessionRegistry::size() const {
  absl::MutexLock lock(&mu_);
  return sessions_.size();
}

void SessionRegistry::NotifySizeLocked() {
  if (options_.on_size_change) options_.on_size_change(sessions_.size());
}

}  // namespace lane::server
