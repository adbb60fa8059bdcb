// Sealed resume states (server/resume_seal.h): bound to what they name,
// refused on any altered bit before anything is parsed, opened under the
// previous key while keys rotate; and the key file's format.
#include "resume_seal.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <string>
#include <vector>

#include "lane/detector/detector.h"
#include "lane/track/lane_tracker.h"
#include "wire/tracker_state_proto.h"

namespace lane::server {
namespace {

std::string Key(char fill) { return std::string(ResumeStateKeys::kMinKeyBytes, fill); }

// A real tracker's state after 20 frames of four straight lanes.
std::string FourLaneState() {
  lane::LaneTracker tracker;
  std::vector<lane::Lane> lanes;
  for (int i = 0; i < 4; ++i) {
    const double x = -5.4 + 3.6 * i;
    lane::Lane lane;
    lane.ground = {Eigen::Vector2d(x, 5), Eigen::Vector2d(x, 12), Eigen::Vector2d(x, 19),
                   Eigen::Vector2d(x, 26)};
    lanes.push_back(lane);
  }
  for (int f = 0; f < 20; ++f) tracker.Update(lanes, f / 30.0);
  return wire::EncodeTrackerState(tracker.Snapshot());
}

ResumeBinding Binding() {
  return {"cam0", ConfigFingerprint("{\"camera\":1}"), 0x0123456789abcdefULL};
}

TEST(ResumeSealTest, OpensWhatItSealedWithItsBinding) {
  const ResumeStateSeal seal{ResumeStateKeys(Key('a'))};
  const std::string state = FourLaneState();
  const std::string sealed = seal.Seal(Binding(), state);
  EXPECT_LT(sealed.size(), wire::kMaxResumeStateBytes);
  const absl::StatusOr<OpenedResumeState> opened = seal.Open(sealed);
  ASSERT_TRUE(opened.ok()) << opened.status();
  EXPECT_EQ(opened->binding.camera_id, "cam0");
  EXPECT_EQ(opened->binding.config_fingerprint, Binding().config_fingerprint);
  EXPECT_EQ(opened->binding.epoch, Binding().epoch);
  EXPECT_EQ(opened->tracker_state, state);
  EXPECT_FALSE(opened->previous_key);
  EXPECT_TRUE(wire::DecodeTrackerState(opened->tracker_state).ok());
}

TEST(ResumeSealTest, EveryFlippedBitIsRefused) {
  const ResumeStateSeal seal{ResumeStateKeys(Key('a'))};
  const std::string sealed = seal.Seal(Binding(), FourLaneState());
  ASSERT_GT(sealed.size(), 200u);
  size_t refused = 0;
  for (size_t byte = 0; byte < sealed.size(); ++byte) {
    for (int bit = 0; bit < 8; ++bit) {
      std::string flipped = sealed;
      flipped[byte] = static_cast<char>(flipped[byte] ^ (1 << bit));
      const absl::StatusOr<OpenedResumeState> opened = seal.Open(flipped);
      ASSERT_FALSE(opened.ok()) << "byte " << byte << " bit " << bit;
      EXPECT_EQ(opened.status().code(), absl::StatusCode::kInvalidArgument);
      ++refused;
    }
  }
  EXPECT_EQ(refused, 8 * sealed.size());
  // Truncated or extended, too.
  for (size_t n : {size_t{0}, size_t{3}, ResumeStateSeal::kHeaderBytes, sealed.size() - 1}) {
    EXPECT_FALSE(seal.Open(sealed.substr(0, n)).ok()) << n << " bytes";
  }
  EXPECT_FALSE(seal.Open(sealed + '\0').ok());
}

TEST(ResumeSealTest, AnAlteredBodyFailsTheTagBeforeItIsParsed) {
  const ResumeStateSeal seal{ResumeStateKeys(Key('a'))};
  std::string sealed = seal.Seal(Binding(), FourLaneState());
  // Bytes that do not parse as a protobuf at all: the tag refuses them.
  sealed.replace(ResumeStateSeal::kHeaderBytes, 4, "\xff\xff\xff\xff");
  const absl::StatusOr<OpenedResumeState> opened = seal.Open(sealed);
  ASSERT_FALSE(opened.ok());
  EXPECT_NE(opened.status().message().find("tag"), std::string::npos) << opened.status();
  // A plain TrackerState, as sent before states were sealed: not sealed.
  const absl::StatusOr<OpenedResumeState> plain = seal.Open(FourLaneState());
  ASSERT_FALSE(plain.ok());
  EXPECT_NE(plain.status().message().find("not a sealed state"), std::string::npos);
}

TEST(ResumeSealTest, KeysRotateThroughThePreviousSlot) {
  const std::string state = FourLaneState();
  const ResumeStateSeal old_key{ResumeStateKeys(Key('a'))};
  const std::string sealed = old_key.Seal(Binding(), state);
  // Rotated: the new key seals, the old one still opens.
  const ResumeStateSeal rotated{ResumeStateKeys(Key('b'), Key('a'))};
  const absl::StatusOr<OpenedResumeState> opened = rotated.Open(sealed);
  ASSERT_TRUE(opened.ok()) << opened.status();
  EXPECT_TRUE(opened->previous_key);
  EXPECT_EQ(opened->tracker_state, state);
  // What the rotated server seals opens under the new key alone.
  const ResumeStateSeal new_only{ResumeStateKeys(Key('b'))};
  EXPECT_TRUE(new_only.Open(rotated.Seal(Binding(), state)).ok());
  // Once the old key is dropped, its states are refused, naming the key.
  const absl::StatusOr<OpenedResumeState> dropped = new_only.Open(sealed);
  ASSERT_FALSE(dropped.ok());
  EXPECT_NE(dropped.status().message().find("key"), std::string::npos) << dropped.status();
  // Random keys of two processes never open each other's states.
  const ResumeStateSeal p1{ResumeStateKeys::Random()}, p2{ResumeStateKeys::Random()};
  EXPECT_TRUE(p1.random_key());
  EXPECT_FALSE(p2.Open(p1.Seal(Binding(), state)).ok());
}

TEST(ResumeSealTest, KeyFileHoldsTheCurrentAndThePreviousKey) {
  const std::string a(64, 'a'), b(64, 'B');
  absl::StatusOr<ResumeStateKeys> one = ResumeStateKeys::Parse("# resume key\n" + a + "\n");
  ASSERT_TRUE(one.ok()) << one.status();
  EXPECT_EQ(one->current(), std::string(32, '\xaa'));
  EXPECT_FALSE(one->previous().has_value());
  absl::StatusOr<ResumeStateKeys> two = ResumeStateKeys::Parse(a + "\n\n  " + b + "  \n");
  ASSERT_TRUE(two.ok()) << two.status();
  ASSERT_TRUE(two->previous().has_value());
  EXPECT_EQ(*two->previous(), std::string(32, '\xbb'));

  const std::vector<std::pair<std::string, std::string>> bad = {
      {"", "no key"},
      {"# only a comment\n", "no key"},
      {std::string(62, 'a'), "line 1"},
      {a + "0", "line 1"},
      {std::string(63, 'a') + "g", "hex"},
      {a + "\n" + b + "\n" + std::string(64, 'c'), "line 3"},
      {a + "\n" + a, "previous key is the current one"},
  };
  for (const auto& [text, names] : bad) {
    const absl::StatusOr<ResumeStateKeys> keys = ResumeStateKeys::Parse(text);
    ASSERT_FALSE(keys.ok()) << names;
    EXPECT_NE(keys.status().message().find(names), std::string::npos) << keys.status();
  }
  EXPECT_FALSE(ResumeStateKeys::ReadFile("/nonexistent/key").ok());
}

TEST(ResumeSealTest, FingerprintsTellConfigsApart) {
  EXPECT_EQ(ConfigFingerprint("{\"a\":1}").size(), 16u);
  EXPECT_EQ(ConfigFingerprint("{\"a\":1}"), ConfigFingerprint("{\"a\":1}"));
  EXPECT_NE(ConfigFingerprint("{\"a\":1}"), ConfigFingerprint("{\"a\":2}"));
}

}  // namespace
}  // namespace lane::server
