// camera id -> session. Thread-safe.
//
// Sessions are shared_ptr<Session>: a frame holds the snapshot it
// started with, so replacing or deleting a session never disturbs frames in
// flight. Detectors are built outside the registry's lock.
#ifndef LANE_SERVER_SESSION_REGISTRY_H_
#define LANE_SERVER_SESSION_REGISTRY_H_

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <unordered_set>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "session.h"
#include "wire/camera_id.h"

namespace lane::server {

class SessionRegistry {
 public:
  struct Options {
    // CreateSession beyond this many sessions is RESOURCE_EXHAUSTED.
    size_t max_sessions = 64;
    // Sessions unused for this long are evicted by EvictIdle();
    // absl::InfiniteDuration() = never.
    absl::Duration ttl = absl::Hours(1);
    // Resolves StreamPolicy::max_inflight_frames == 0.
    uint32_t default_max_inflight_frames = 8;
    // Cameras whose frames are larger than this are refused.
    int64_t max_frame_pixels = int64_t{3840} * 2160;
    // Largest message the server receives, bytes: cameras whose raw BGR frame
    // (with the request's other fields) cannot fit are refused, since they
    // could only ever stream encoded frames. 0 = no check.
    uint64_t max_receive_message_bytes = 0;
    // Memory all sessions' detectors may hold together, bytes (a 160x120 top
    // view holds about 0.5 MB, the largest allowed, 2048x2048, about 110 MB).
    // A create that would exceed it is RESOURCE_EXHAUSTED. Detectors are built
    // on the worker pool before this check, so at most one per worker is
    // held beyond the budget at any moment. 0 = no budget.
    uint64_t max_session_memory_bytes = uint64_t{1} << 30;
    // With --live_view: every session gets a LiveFeed that samples a watched
    // camera at most once per this interval (ns); 0 = no live view. Its
    // fixed part (LiveFeed::kFixedBytes) counts in SessionBytes.
    int64_t live_view_draw_interval_ns = 0;
    // Time source (tests inject a fake clock).
    std::function<absl::Time()> clock = [] { return absl::Now(); };
    // Called with the number of sessions after every change, under the
    // registry's lock: keep it cheap (a gauge's Set) and never call back.
    std::function<void(size_t)> on_size_change;
  };

  enum class Outcome { kCreated, kUnchanged, kReplaced };
  struct CreateResult {
    std::shared_ptr<Session> session;
    Outcome outcome = Outcome::kCreated;
  };

  struct Entry {
    std::shared_ptr<Session> session;
    absl::Time last_used;
  };

  explicit SessionRegistry(Options options);

  // Creates a session, or confirms an identical one (same config and stream
  // policy): see CreateSession in lane_service.proto. INVALID_ARGUMENT for a
  // bad camera id or config, ALREADY_EXISTS, RESOURCE_EXHAUSTED.
  absl::StatusOr<CreateResult> Create(const std::string& camera_id, const SessionSpec& spec,
                                      bool replace);

  // The session of a camera, marking it used; nullptr if none.
  std::shared_ptr<Session> Find(absl::string_view camera_id);
  // The same without marking it used (the live view: looking at a camera
  // does not keep its session alive); nullptr if none.
  std::shared_ptr<Session> Peek(absl::string_view camera_id) const;

  // The live view's memory of a watched camera: counts `bytes` for
  // `session` (which must be the camera's current session) against
  // max_session_memory_bytes, in place of what it counted before.
  // RESOURCE_EXHAUSTED beyond the budget, NOT_FOUND when the session is no
  // longer registered (deleted, replaced, evicted).
  absl::Status ReserveLiveView(const std::shared_ptr<Session>& session, uint64_t bytes);
  // Counts it no more (the watch has lapsed).
  void ReleaseLiveView(const std::shared_ptr<Session>& session);
  // Like Find with its last use; NOT_FOUND if none.
  absl::StatusOr<Entry> Get(absl::string_view camera_id);
  // All sessions, sorted by camera id.
  std::vector<Entry> List() const;
  // NOT_FOUND if none.
  absl::Status Delete(absl::string_view camera_id);

  // Deletes sessions unused for the TTL. Returns how many.
  size_t EvictIdle();

  size_t size() const;
  // Bytes held by all sessions' detectors (Detector::MemoryBytes).
  uint64_t memory_bytes() const;
  const Options& options() const { return options_; }

  // Whether `epoch` was the epoch (Session::epoch) of a session deleted or
  // replaced on this server: a resume state of it must not be continued by
  // the camera's new session. The last kMaxRetiredEpochs are remembered;
  // sessions evicted for idleness are not retired (their camera's state
  // still continues them).
  bool EpochRetired(uint64_t epoch) const;
  static constexpr size_t kMaxRetiredEpochs = 4096;

  // What a session counts against max_session_memory_bytes: its detector,
  // its config and, with the live view, its LiveFeed (and while watched the
  // frame and pictures reserved for it).
  static uint64_t SessionBytes(const Session& session);
  // Bytes of the largest request carrying a raw BGR frame of the camera.
  static uint64_t RawFrameRequestBytes(const lane::CameraModel& camera);

  // OK or INVALID_ARGUMENT: 1 to 128 characters of [A-Za-z0-9._:/-]
  // (wire/camera_id.h, the rule the clients check too). Checked before any
  // message quotes an id.
  static constexpr size_t kMaxCameraIdBytes = wire::kMaxCameraIdBytes;
  static absl::Status ValidateCameraId(absl::string_view camera_id);

 private:
  // What Create checks of the camera before anything else: its frame size
  // against --max_frame_pixels and a raw frame against the message size.
  absl::Status CheckSpec(const SessionSpec& spec) const;
  // The checks that need no detector: the camera's session if it is the
  // same (marked used at `now`), nullptr if one may be created or replaced,
  // or why not (a conflict without `replace`, the session cap).
  absl::StatusOr<std::shared_ptr<Session>> ExistingLocked(
      const std::string& camera_id, const std::string& config_json, const StreamPolicy& stream,
      const SessionSpec& spec, bool replace, absl::Time now) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void NotifySizeLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void RetireLocked(const Session& session) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const Options options_;
  mutable absl::Mutex mu_;
  std::map<std::string, Entry, std::less<>> sessions_ ABSL_GUARDED_BY(mu_);
  uint64_t next_version_ ABSL_GUARDED_BY(mu_) = 1;
  // The sum of SessionBytes over sessions_.
  uint64_t memory_bytes_ ABSL_GUARDED_BY(mu_) = 0;
  // Draws sessions' epochs: 64 random bits, so that replicas do not share one.
  std::mt19937_64 epochs_ ABSL_GUARDED_BY(mu_){std::random_device{}()};
  // EpochRetired's memory: the set, and its epochs oldest first.
  std::unordered_set<uint64_t> retired_ ABSL_GUARDED_BY(mu_);
  std::deque<uint64_t> retired_order_ ABSL_GUARDED_BY(mu_);
};

}  // namespace lane::server

#endif  // LANE_SERVER_SESSION_REGISTRY_H_
