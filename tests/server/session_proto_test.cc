#include "session_proto.h"

#include <gtest/gtest.h>

namespace lane::server {
namespace {

TEST(SessionProtoTest, PoliciesRoundTripAndUnknownValuesAreRefused) {
  StreamPolicy policy;
  policy.backpressure = Backpressure::kDropOldest;
  policy.max_inflight_frames = 5;
  v1::StreamOptions proto;
  StreamPolicyToProto(policy, &proto);
  absl::StatusOr<StreamPolicy> back = StreamPolicyFromProto(proto);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, policy);
  v1::StreamOptions stream;
  stream.set_backpressure(static_cast<v1::Backpressure>(9));
  EXPECT_EQ(StreamPolicyFromProto(stream).status().code(), absl::StatusCode::kInvalidArgument);

  v1::SessionConfig config;
  config.mutable_decode()->set_accept_damaged_frames(true);
  absl::StatusOr<SessionSpec> spec = SessionSpecFromProto(config);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_TRUE(spec->decode.accept_damaged_frames);
  EXPECT_FALSE(SessionSpecFromProto(v1::SessionConfig()).value().decode.accept_damaged_frames);
}

}  // namespace
}  // namespace lane::server
