// Resume states a client carries (FrameResponse.resume_state, sent back in
// FrameRequest.resume_state) are sealed: bound to the camera, the session's
// config and its epoch, and authenticated with HMAC-SHA-256 under a key the
// replicas share (docs/deployment.md, "Resume-state keys").
//
//   sealed = "LRS1" | key id (8 bytes) | tag (32 bytes) | body
//   body   = lane.v1.ResumeStateBody (camera id, config fingerprint, epoch,
//            the encoded lane.v1.TrackerState)
//   tag    = HMAC-SHA-256(key, "LRS1" | key id | body)
//
// The key id (the first 8 bytes of SHA-256 over a label and the key) picks
// which of the two keys opens a state; the tag is checked, in constant time,
// before any byte of the body is parsed.
#ifndef LANE_SERVER_RESUME_SEAL_H_
#define LANE_SERVER_RESUME_SEAL_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace lane::server {

// The keys resume states are sealed and opened with: `current` seals and
// opens; `previous`, when set, only opens (a key being rotated out).
class ResumeStateKeys {
 public:
  static constexpr size_t kMinKeyBytes = 32;
  static constexpr size_t kMaxKeyBytes = 1024;

  // A fresh random 32-byte key (OpenSSL's RAND_bytes), no previous key:
  // states then resume only on the process that made them.
  static ResumeStateKeys Random();
  // A key file's text: one or two keys, one per line, each as hex digits
  // (at least kMinKeyBytes bytes: `openssl rand -hex 32`); the first line is
  // the current key, the second the previous one. Blank lines and lines
  // starting with '#' are ignored. INVALID_ARGUMENT naming the line.
  static absl::StatusOr<ResumeStateKeys> Parse(absl::string_view text);
  // Parse() of a file of at most 64 KiB.
  static absl::StatusOr<ResumeStateKeys> ReadFile(const std::string& path);

  // Raw key bytes. `current` must be at least kMinKeyBytes long.
  explicit ResumeStateKeys(std::string current, std::optional<std::string> previous = {});

  const std::string& current() const { return current_; }
  const std::optional<std::string>& previous() const { return previous_; }
  bool random() const { return random_; }

 private:
  std::string current_;
  std::optional<std::string> previous_;
  bool random_ = false;
};

// What a sealed state belongs to.
struct ResumeBinding {
  std::string camera_id;
  // ConfigFingerprint of the session's canonical config.
  std::string config_fingerprint;
  // The session's epoch (Session::epoch).
  uint64_t epoch = 0;
};

// A sealed state opened: what it is bound to, and the TrackerState bytes
// (still to be decoded and checked: wire::DecodeTrackerState).
struct OpenedResumeState {
  ResumeBinding binding;
  std::string tracker_state;
  // Opened with the previous key (the state was sealed before a rotation).
  bool previous_key = false;
};

// 16 bytes of SHA-256 over a session's canonical config (lane::ConfigToJson):
// the camera, the top view and every detector setting.
std::string ConfigFingerprint(absl::string_view config_json);

class ResumeStateSeal {
 public:
  static constexpr char kMagic[] = "LRS1";
  static constexpr size_t kMagicBytes = 4;
  static constexpr size_t kKeyIdBytes = 8;
  static constexpr size_t kTagBytes = 32;
  static constexpr size_t kHeaderBytes = kMagicBytes + kKeyIdBytes + kTagBytes;

  explicit ResumeStateSeal(ResumeStateKeys keys);

  // `tracker_state` (an encoded lane.v1.TrackerState) bound to `binding`,
  // sealed under the current key.
  std::string Seal(const ResumeBinding& binding, absl::string_view tracker_state) const;
  // The state inside `sealed`, or INVALID_ARGUMENT saying why not: too
  // short, not a sealed state, a key this server does not hold, a tag that
  // does not verify (altered, forged or truncated). Nothing of the body is
  // parsed before its tag has verified.
  absl::StatusOr<OpenedResumeState> Open(absl::string_view sealed) const;

  bool random_key() const { return keys_.random(); }
  bool has_previous_key() const { return keys_.previous().has_value(); }

 private:
  using KeyId = std::array<unsigned char, kKeyIdBytes>;
  static KeyId IdOf(const std::string& key);
  // HMAC-SHA-256 over magic | id | body.
  static std::array<unsigned char, kTagBytes> Tag(const std::string& key, const KeyId& id,
                                                  absl::string_view body);

  ResumeStateKeys keys_;
  KeyId current_id_;
  std::optional<KeyId> previous_id_;
};

}  // namespace lane::server

#endif  // LANE_SERVER_RESUME_SEAL_H_
