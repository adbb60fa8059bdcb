// A camera's session: what a client configured under a camera id, the
// detector built from it, and the camera's state over its frames. The
// configuration is fixed when the session is created (the const members), so
// a frame in flight keeps using the session it started with even when the
// session is replaced or deleted meanwhile. What the frames change is behind
// the non-const methods, each thread-safe: the tracker (tracker()), the
// online calibrator and its refined detector (ObserveLanes), the counter.
#ifndef LANE_SERVER_SESSION_H_
#define LANE_SERVER_SESSION_H_

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "lane/calibrate/calibration.h"
#include "lane/config/config.h"
#include "lane/detector/detector.h"
#include "lane/track/frame_tracker.h"
#include "live_feed.h"
#include "resume_seal.h"

namespace lane::server {

enum class Backpressure {
  kBlock,       // at the in-flight bound, stop reading the stream
  kDropOldest,  // at the in-flight bound, drop the oldest frame not yet started
};

// How a camera's streams queue frames.
struct StreamPolicy {
  Backpressure backpressure = Backpressure::kBlock;
  // Frames of one stream received and not yet answered, at most. 0 = the
  // server's default (resolved when the session is created).
  uint32_t max_inflight_frames = 0;

  bool operator==(const StreamPolicy& o) const {
    return backpressure == o.backpressure && max_inflight_frames == o.max_inflight_frames;
  }
  bool operator!=(const StreamPolicy& o) const { return !(*this == o); }
};

// How a camera's encoded frames are decoded (DecodeOptions in the proto).
struct DecodePolicy {
  // Accept JPEGs that decode only with libjpeg's corrupt-data warnings.
  bool accept_damaged_frames = false;
  // Decode whole frames instead of the detector's rows and channel.
  bool full_decode = false;

  bool operator==(const DecodePolicy& o) const {
    return accept_damaged_frames == o.accept_damaged_frames && full_decode == o.full_decode;
  }
  bool operator!=(const DecodePolicy& o) const { return !(*this == o); }
};

// How a camera's calibration follows the stream (CalibrationOptions).
struct CalibrationPolicy {
  bool auto_calibrate = false;

  bool operator==(const CalibrationPolicy& o) const { return auto_calibrate == o.auto_calibrate; }
  bool operator!=(const CalibrationPolicy& o) const { return !(*this == o); }
};

// When a camera's frames are tracked (TrackingOptions).
struct TrackingPolicy {
  bool disabled = false;  // StreamFrames is tracked unless this is set
  bool unary = false;     // also Detect

  bool operator==(const TrackingPolicy& o) const {
    return disabled == o.disabled && unary == o.unary;
  }
  bool operator!=(const TrackingPolicy& o) const { return !(*this == o); }
};

// What CreateSession (or a stream's first frame) asks for.
struct SessionSpec {
  lane::Config config;
  StreamPolicy stream;
  DecodePolicy decode;
  CalibrationPolicy calibration;
  TrackingPolicy tracking;
};

// A session's camera now (CalibrationState in the proto).
struct CalibrationSnapshot {
  lane::CameraModel camera;
  double confidence = 0;
  double uncertainty_deg = 0;
  uint64_t frames_seen = 0;
  uint64_t frames_used = 0;
  double drift_pitch_deg = 0;
  double drift_yaw_deg = 0;
  uint32_t rederived = 0;
  uint32_t refused = 0;
  std::string last_refusal;
};

struct Session {
  Session(std::string camera_id_in, uint64_t version_in, lane::Config config_in,
          std::string config_json_in, StreamPolicy stream_in, DecodePolicy decode_in,
          lane::Detector detector_in, absl::Time create_time_in,
          CalibrationPolicy calibration_in = {}, TrackingPolicy tracking_in = {},
          uint64_t epoch_in = 0)
      : camera_id(std::move(camera_id_in)),
        version(version_in),
        config(std::move(config_in)),
        config_json(std::move(config_json_in)),
        config_fingerprint(ConfigFingerprint(config_json)),
        stream(stream_in),
        decode(decode_in),
        calibration(calibration_in),
        tracking(tracking_in),
        detector(std::move(detector_in)),
        create_time(create_time_in),
        tracker_(config.camera),
        calibrator_(config.camera),
        epoch_(epoch_in) {}

  const std::string camera_id;
  // Unique within the process; new on every create and replace.
  const uint64_t version;
  const lane::Config config;
  // lane::ConfigToJson(config): the canonical form compared by CreateSession.
  const std::string config_json;
  // ConfigFingerprint(config_json): what resume states name of the config.
  const std::string config_fingerprint;
  // Resolved: max_inflight_frames > 0.
  const StreamPolicy stream;
  const DecodePolicy decode;
  const CalibrationPolicy calibration;
  const TrackingPolicy tracking;
  // Built from `config`; frames use CurrentDetector().
  const lane::Detector detector;
  const absl::Time create_time;
  // Frames processed with this session.
  std::atomic<uint64_t> frames_processed{0};
  // The live view's side of the camera (live_feed.h); null without
  // --live_view. Set by SessionRegistry before the session is shared.
  std::unique_ptr<LiveFeed> live;

  // The detector for the next frame: `detector`, or with auto_calibrate the
  // one re-derived from the latest refined camera. Valid while the caller
  // holds the session.
  std::shared_ptr<const lane::Detector> CurrentDetector() const;
  // A processed frame's lanes, with auto_calibrate: refines the camera and
  // re-derives the detector (outside the lock) when it has moved enough.
  void ObserveLanes(const std::vector<lane::Lane>& lanes);
  CalibrationSnapshot Calibration() const;

  bool TracksStreams() const { return !tracking.disabled; }
  bool TracksUnary() const { return !tracking.disabled && tracking.unary; }
  // The camera's tracker: frames are measured on workers, concurrently
  // (Measure: its prediction is the state after the last frame committed,
  // with k frames in flight up to k frames old), and committed in stream
  // order (Commit). Thread-safe.
  lane::FrameTracker& tracker() { return tracker_; }

  // The session's epoch, which its resume states name (resume_seal.h):
  // random, drawn at create and replace. A session whose epoch has not yet
  // been sealed into a state nor taken from one continues the epoch of the
  // first state it resumes (the same session, carried on from another
  // replica); from then on the epoch is fixed.
  uint64_t epoch() const;
  // The epoch to seal a state with; fixes it.
  uint64_t SealEpoch();
  // Whether a state of `epoch` continues this session: the same epoch, or
  // this session's epoch was not fixed yet (it takes `epoch` and fixes it).
  bool ContinueEpoch(uint64_t epoch);

 private:
  lane::FrameTracker tracker_;
  mutable absl::Mutex refine_mu_;
  lane::OnlineCalibrator calibrator_ ABSL_GUARDED_BY(refine_mu_);
  std::shared_ptr<const lane::Detector> refined_ ABSL_GUARDED_BY(refine_mu_);
  uint64_t refine_generation_ ABSL_GUARDED_BY(refine_mu_) = 0;
  mutable absl::Mutex epoch_mu_;
  uint64_t epoch_ ABSL_GUARDED_BY(epoch_mu_);
  bool epoch_fixed_ ABSL_GUARDED_BY(epoch_mu_) = false;
};

}  // namespace lane::server

#endif  // LANE_SERVER_SESSION_H_
