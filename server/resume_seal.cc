#include "resume_seal.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/rand.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/string_view.h"
#include "lane/v1/lane_service.pb.h"

namespace lane::server {
namespace {

constexpr size_t kMaxKeyFileBytes = 64 * 1024;
// Domain separation: a key's id is not a hash any other use of the key makes.
constexpr char kKeyIdLabel[] = "lane resume-state key id\n";
constexpr char kFingerprintLabel[] = "lane session config\n";
constexpr size_t kFingerprintBytes = 16;

// SHA-256 of label | data (EVP: the SHA256_* calls are deprecated in OpenSSL 3).
std::array<unsigned char, 32> Sha256(absl::string_view label, absl::string_view data) {
  std::string message = absl::StrCat(label, data);
  std::array<unsigned char, 32> digest{};
  unsigned int length = 0;
  EVP_Digest(message.data(), message.size(), digest.data(), &length, EVP_sha256(), nullptr);
  return digest;
}

absl::Status BadKeyLine(int line, absl::string_view why) {
  return absl::InvalidArgumentError(absl::StrCat("resume-state key file, line ", line, ": ", why));
}

}  // namespace

ResumeStateKeys ResumeStateKeys::Random() {
  std::string key(kMinKeyBytes, '\0');
  if (RAND_bytes(reinterpret_cast<unsigned char*>(key.data()), static_cast<int>(key.size())) != 1) {
    // OpenSSL's generator failing at start-up leaves no safe key to make.
    std::abort();
  }
  ResumeStateKeys keys(std::move(key));
  keys.random_ = true;
  return keys;
}

absl::StatusOr<ResumeStateKeys> ResumeStateKeys::Parse(absl::string_view text) {
  std::vector<std::string> keys;
  int line_number = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_number;
    line = absl::StripAsciiWhitespace(line);
    if (line.empty() || line.front() == '#') continue;
    if (keys.size() == 2) {
      return BadKeyLine(line_number,
                        "a third key; the file holds the current key and, "
                        "optionally, the previous one");
    }
    if (line.size() % 2 != 0 || line.size() / 2 < kMinKeyBytes || line.size() / 2 > kMaxKeyBytes) {
      return BadKeyLine(
          line_number,
          absl::StrCat("a key is ", 2 * kMinKeyBytes, " to ", 2 * kMaxKeyBytes,
                       " hex digits (`openssl rand -hex 32`), got ", line.size(), " characters"));
    }
    for (char c : line) {
      if (!absl::ascii_isxdigit(static_cast<unsigned char>(c))) {
        return BadKeyLine(line_number, "a key is hex digits only (`openssl rand -hex 32`)");
      }
    }
    keys.push_back(absl::HexStringToBytes(line));
  }
  if (keys.empty()) {
    return absl::InvalidArgumentError(
        "resume-state key file: no key (one line of hex digits: `openssl rand -hex 32`)");
  }
  if (keys.size() == 2 && keys[0] == keys[1]) {
    return absl::InvalidArgumentError(
        "resume-state key file: the previous key is the current one; drop the second line");
  }
  std::optional<std::string> previous;
  if (keys.size() == 2) previous = std::move(keys[1]);
  return ResumeStateKeys(std::move(keys[0]), std::move(previous));
}

absl::StatusOr<ResumeStateKeys> ResumeStateKeys::ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot read ", path));
  std::string text(kMaxKeyFileBytes + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<size_t>(in.gcount()));
  if (text.size() > kMaxKeyFileBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": more than ", kMaxKeyFileBytes, " bytes; not a key file"));
  }
  absl::StatusOr<ResumeStateKeys> keys = Parse(text);
  if (!keys.ok())
    return absl::InvalidArgumentError(absl::StrCat(path, ": ", keys.status().message()));
  return keys;
}

ResumeStateKeys::ResumeStateKeys(std::string current, std::optional<std::string> previous)
    : current_(std::move(current)), previous_(std::move(previous)) {}

std::string ConfigFingerprint(absl::string_view config_json) {
  const std::array<unsigned char, 32> digest = Sha256(kFingerprintLabel, config_json);
  return std::string(reinterpret_cast<const char*>(digest.data()), kFingerprintBytes);
}

ResumeStateSeal::ResumeStateSeal(ResumeStateKeys keys)
    : keys_(std::move(keys)), current_id_(IdOf(keys_.current())) {
  if (keys_.previous()) previous_id_ = IdOf(*keys_.previous());
}

ResumeStateSeal::KeyId ResumeStateSeal::IdOf(const std::string& key) {
  const std::array<unsigned char, 32> digest = Sha256(kKeyIdLabel, key);
  KeyId id;
  std::memcpy(id.data(), digest.data(), id.size());
  return id;
}

std::array<unsigned char, ResumeStateSeal::kTagBytes> ResumeStateSeal::Tag(const std::string& key,
                                                                           const KeyId& id,
                                                                           absl::string_view body) {
  // magic | id | body, contiguous for the one-shot HMAC (states are < 4 KiB).
  std::string message;
  message.reserve(kMagicBytes + kKeyIdBytes + body.size());
  message.append(kMagic, kMagicBytes);
  message.append(reinterpret_cast<const char*>(id.data()), id.size());
  message.append(body.data(), body.size());
  std::array<unsigned char, kTagBytes> tag{};
  unsigned int length = 0;
  HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()),
       reinterpret_cast<const unsigned char*>(message.data()), message.size(), tag.data(), &length);
  return tag;
}

std::string ResumeStateSeal::Seal(const ResumeBinding& binding,
                                  absl::string_view tracker_state) const {
  v1::ResumeStateBody body;
  body.set_camera_id(binding.camera_id);
  body.set_config_fingerprint(binding.config_fingerprint);
  body.set_epoch(binding.epoch);
  body.set_tracker_state(std::string(tracker_state));
  const std::string body_bytes = body.SerializeAsString();
  const std::array<unsigned char, kTagBytes> tag = Tag(keys_.current(), current_id_, body_bytes);
  std::string sealed;
  sealed.reserve(kHeaderBytes + body_bytes.size());
  sealed.append(kMagic, kMagicBytes);
  sealed.append(reinterpret_cast<const char*>(current_id_.data()), current_id_.size());
  sealed.append(reinterpret_cast<const char*>(tag.data()), tag.size());
  sealed.append(body_bytes);
  return sealed;
}

absl::StatusOr<OpenedResumeState> ResumeStateSeal::Open(absl::string_view sealed) const {
  if (sealed.size() < kHeaderBytes || std::memcmp(sealed.data(), kMagic, kMagicBytes) != 0) {
    return absl::InvalidArgumentError(
        "resume state: not a sealed state of this service (a state is sent back as it was "
        "received in FrameResponse.resume_state)");
  }
  KeyId id;
  std::memcpy(id.data(), sealed.data() + kMagicBytes, id.size());
  const std::string* key = nullptr;
  bool previous = false;
  if (id == current_id_) {
    key = &keys_.current();
  } else if (previous_id_ && id == *previous_id_) {
    key = &*keys_.previous();
    previous = true;
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat("resume state: key: sealed under a key this server does not hold (key id ",
                     absl::BytesToHexString(
                         absl::string_view(reinterpret_cast<const char*>(id.data()), id.size())),
                     "; replicas share one with --resume_state_key_file)"));
  }
  const absl::string_view body = sealed.substr(kHeaderBytes);
  const std::array<unsigned char, kTagBytes> expected = Tag(*key, id, body);
  if (CRYPTO_memcmp(expected.data(), sealed.data() + kMagicBytes + kKeyIdBytes, kTagBytes) != 0) {
    return absl::InvalidArgumentError(
        "resume state: tag: its HMAC does not verify (altered, truncated or forged)");
  }
  v1::ResumeStateBody parsed;
  if (!parsed.ParseFromArray(body.data(), static_cast<int>(body.size()))) {
    // Only this server's keys make a valid tag, so only a bug gets here.
    return absl::InvalidArgumentError("resume state: the sealed body does not parse");
  }
  OpenedResumeState opened;
  opened.binding.camera_id = parsed.camera_id();
  opened.binding.config_fingerprint = parsed.config_fingerprint();
  opened.binding.epoch = parsed.epoch();
  opened.tracker_state = std::move(*parsed.mutable_tracker_state());
  opened.previous_key = previous;
  return opened;
}

}  // namespace lane::server
