#include "wire/status_map.h"

#include <gtest/gtest.h>

namespace lane::wire {
namespace {

TEST(StatusMapTest, ServiceErrorsHaveTheDocumentedCodes) {
  struct Case {
    absl::Status status;
    grpc::StatusCode code;
  };
  const Case cases[] = {
      {SessionNotFound("a"), grpc::StatusCode::NOT_FOUND},
      {NoSessionForFrame("a"), grpc::StatusCode::FAILED_PRECONDITION},
      {SessionConfigConflict("a", 3), grpc::StatusCode::ALREADY_EXISTS},
      {TooManySessions(4), grpc::StatusCode::RESOURCE_EXHAUSTED},
      {WorkerQueueFull(), grpc::StatusCode::RESOURCE_EXHAUSTED},
      {ServerStarting(), grpc::StatusCode::UNAVAILABLE},
      {ServerDraining(), grpc::StatusCode::UNAVAILABLE},
      {FrameDropped(8), grpc::StatusCode::ABORTED},
      {InvalidFrame("x"), grpc::StatusCode::INVALID_ARGUMENT},
      {InvalidRequest("x"), grpc::StatusCode::INVALID_ARGUMENT},
  };
  for (const Case& c : cases) {
    const grpc::Status g = ToGrpcStatus(c.status);
    EXPECT_EQ(g.error_code(), c.code) << c.status;
    EXPECT_EQ(g.error_message(), std::string(c.status.message()));
    EXPECT_FALSE(g.error_message().empty());
  }
  EXPECT_TRUE(ToGrpcStatus(absl::OkStatus()).ok());
  EXPECT_NE(NoSessionForFrame("cam-7").message().find("cam-7"), absl::string_view::npos);
}

TEST(StatusMapTest, EveryAbslCodeMapsToTheSameGrpcCode) {
  for (int code = 1; code <= 16; ++code) {
    const absl::Status s(static_cast<absl::StatusCode>(code), "m");
    EXPECT_EQ(static_cast<int>(ToGrpcStatus(s).error_code()), code);
  }
}

TEST(StatusMapTest, FrameStatuses) {
  v1::FrameStatus status;
  ToFrameStatus(absl::OkStatus(), &status);
  EXPECT_EQ(status.code(), v1::FRAME_CODE_OK);
  EXPECT_TRUE(status.message().empty());
  ToFrameStatus(InvalidFrame("bad jpeg"), &status);
  EXPECT_EQ(status.code(), v1::FRAME_CODE_INVALID_ARGUMENT);
  EXPECT_EQ(status.message(), "bad jpeg");
  ToFrameStatus(FrameDropped(2), &status);
  EXPECT_EQ(status.code(), v1::FRAME_CODE_DROPPED);
  ToFrameStatus(absl::UnknownError("boom"), &status);
  EXPECT_EQ(status.code(), v1::FRAME_CODE_INTERNAL);
  EXPECT_NE(status.message().find("UNKNOWN"), std::string::npos);
  // The numbers are gRPC's.
  EXPECT_EQ(static_cast<int>(v1::FRAME_CODE_INVALID_ARGUMENT),
            static_cast<int>(grpc::StatusCode::INVALID_ARGUMENT));
  EXPECT_EQ(static_cast<int>(v1::FRAME_CODE_DROPPED), static_cast<int>(grpc::StatusCode::ABORTED));
  EXPECT_EQ(FromFrameStatus(status).code(), absl::StatusCode::kInternal);
}

TEST(StatusMapTest, Labels) {
  EXPECT_STREQ(FrameResultLabel(ToFrameResult(v1::FRAME_CODE_OK)), "ok");
  EXPECT_STREQ(FrameResultLabel(ToFrameResult(v1::FRAME_CODE_INVALID_ARGUMENT)), "invalid");
  EXPECT_STREQ(FrameResultLabel(ToFrameResult(v1::FRAME_CODE_DROPPED)), "dropped");
  EXPECT_STREQ(FrameResultLabel(ToFrameResult(v1::FRAME_CODE_INTERNAL)), "error");
  EXPECT_STREQ(GrpcCodeName(grpc::StatusCode::FAILED_PRECONDITION), "FAILED_PRECONDITION");
  EXPECT_STREQ(GrpcCodeName(grpc::StatusCode::OK), "OK");
}

}  // namespace
}  // namespace lane::wire
