// Hostile and malformed input, one test per row of the "Bad input" table in
// docs/service.md: the status the user sees, and the server keeps serving
// (every test ends with a good frame on the same server).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "hostile_frames.h"
#include "test_util.h"
#include "wire/status_map.h"

namespace lane::server::testing {
namespace {

// This process's resident memory in KiB (VmRSS), or -1 when unknown.
long ResidentKiB() {
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    long value = 0;
    if (key == "VmRSS:" && status >> value) return value;
    status.ignore(1 << 12, '\n');
  }
  return -1;
}

// Sanitizers' quarantines and shadow memory inflate RSS. gcc defines
// __SANITIZE_*__; clang answers __has_feature.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#else
constexpr bool kSanitized = false;
#endif

class BadInputTest : public ::testing::Test {
 protected:
  void SetUp() override {
    camera_ = ScaledCamera(0.5);
    config_ = SessionConfigFor(camera_);
    jpeg_ = EncodeJpeg(RoadFrame(camera_, kLineOffsets, 1));
  }

  void Start(ServerOptions options = TestServer::DefaultOptions()) {
    server_ = std::make_unique<TestServer>(options);
    ASSERT_FALSE(::testing::Test::HasFailure());
    server_->CreateSession("cam", config_);
  }

  // One frame on its own stream: the frame's status.
  v1::FrameStatus OneFrame(const v1::FrameRequest& request) {
    StreamResult result = RunStream(server_->stub(), {request});
    EXPECT_TRUE(result.status.ok()) << result.status.error_message();
    if (result.responses.size() != 1) {
      ADD_FAILURE() << "expected one response, got " << result.responses.size();
      return v1::FrameStatus();
    }
    const v1::FrameStatus& status = result.responses[0].status();
    std::cout << "[bad-input] frame code " << status.code() << ": " << status.message() << "\n";
    return status;
  }

  grpc::Status Create(const std::string& id, const v1::SessionConfig& config) {
    return CreateSessionStatus(server_->stub(), id, config);
  }

  grpc::Status CreateLogged(const v1::SessionConfig& config) {
    const grpc::Status status = Create("bad", config);
    std::cout << "[bad-input] " << wire::GrpcCodeName(status.error_code()) << ": "
              << status.error_message() << "\n";
    return status;
  }

  // The server still answers a good frame.
  void ExpectStillServing() {
    EXPECT_EQ(OneFrame(JpegRequest("cam", 99, jpeg_)).code(), v1::FRAME_CODE_OK);
  }

  lane::CameraModel camera_;
  v1::SessionConfig config_;
  std::string jpeg_;
  std::unique_ptr<TestServer> server_;
};

using lane::testing::JpegDeclaring;
using lane::testing::PngDeclaring;

TEST_F(BadInputTest, HugeDeclaredDimensionsAreRefusedFromTheHeader) {
  Start();
  const std::string png = EncodePng(RoadFrame(camera_, kLineOffsets));
  const v1::FrameStatus from_png = OneFrame(JpegRequest("cam", 1, PngDeclaring(png, 65535, 65535)));
  EXPECT_EQ(from_png.code(), v1::FRAME_CODE_INVALID_ARGUMENT);
  EXPECT_NE(from_png.message().find("max_frame_pixels"), std::string::npos);
  const v1::FrameStatus from_jpeg =
      OneFrame(JpegRequest("cam", 2, JpegDeclaring(jpeg_, 65535, 65535)));
  EXPECT_EQ(from_jpeg.code(), v1::FRAME_CODE_INVALID_ARGUMENT);
  EXPECT_NE(from_jpeg.message().find("max_frame_pixels"), std::string::npos);
  ExpectStillServing();
}

TEST_F(BadInputTest, ZeroBytesAndTruncatedPng) {
  Start();
  EXPECT_EQ(OneFrame(JpegRequest("cam", 1, "")).code(), v1::FRAME_CODE_INVALID_ARGUMENT);
  const std::string png = EncodePng(RoadFrame(camera_, kLineOffsets));
  EXPECT_EQ(OneFrame(JpegRequest("cam", 2, png.substr(0, png.size() / 2))).code(),
            v1::FRAME_CODE_INVALID_ARGUMENT);
  ExpectStillServing();
}

TEST_F(BadInputTest, RawStrideMismatchAndUnknownPixelFormat) {
  Start();
  const int w = camera_.image_width, h = camera_.image_height;
  v1::FrameRequest request;
  request.set_camera_id("cam");
  v1::RawImage* raw = request.mutable_raw();
  raw->set_width(w);
  raw->set_height(h);
  raw->set_pixel_format(v1::PIXEL_FORMAT_BGR8);
  raw->set_stride(static_cast<uint32_t>(w * 3 + 16));
  raw->set_data(std::string(static_cast<size_t>(w * 3 * h), '\0'));  // too short for the stride
  EXPECT_EQ(OneFrame(request).code(), v1::FRAME_CODE_INVALID_ARGUMENT);
  raw->set_stride(0);
  raw->set_data(std::string(static_cast<size_t>(w * 3 * h + 7), '\0'));  // too long
  EXPECT_EQ(OneFrame(request).code(), v1::FRAME_CODE_INVALID_ARGUMENT);
  raw->set_data(std::string(static_cast<size_t>(w * 3 * h), '\0'));
  raw->set_pixel_format(static_cast<v1::PixelFormat>(99));
  EXPECT_EQ(OneFrame(request).code(), v1::FRAME_CODE_INVALID_ARGUMENT);
  raw->set_pixel_format(v1::PIXEL_FORMAT_UNSPECIFIED);
  EXPECT_EQ(OneFrame(request).code(), v1::FRAME_CODE_INVALID_ARGUMENT);
  ExpectStillServing();
}

TEST_F(BadInputTest, SessionDeletedMidStream) {
  Start();
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  auto stream = server_->stub().StreamFrames(&context);
  ASSERT_TRUE(stream->Write(JpegRequest("cam", 0, jpeg_)));
  v1::FrameResponse response;
  ASSERT_TRUE(stream->Read(&response));
  EXPECT_EQ(response.status().code(), v1::FRAME_CODE_OK);
  {
    grpc::ClientContext delete_context;
    v1::DeleteSessionRequest request;
    request.set_camera_id("cam");
    v1::DeleteSessionResponse deleted;
    ASSERT_TRUE(server_->stub().DeleteSession(&delete_context, request, &deleted).ok());
  }
  stream->Write(JpegRequest("cam", 1, jpeg_));
  stream->WritesDone();
  while (stream->Read(&response)) {
  }
  const grpc::Status status = stream->Finish();
  std::cout << "[bad-input] " << wire::GrpcCodeName(status.error_code()) << ": "
            << status.error_message() << "\n";
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  server_->CreateSession("cam", config_);
  ExpectStillServing();
}

TEST_F(BadInputTest, BadCalibrationIsInvalidArgument) {
  Start();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<std::pair<const char*, std::function<void(v1::CameraCalibration*)>>> cases = {
      {"fu NaN", [&](v1::CameraCalibration* c) { c->set_fu(nan); }},
      {"cv inf", [&](v1::CameraCalibration* c) { c->set_cv(inf); }},
      {"height NaN", [&](v1::CameraCalibration* c) { c->set_height_m(nan); }},
      {"pitch inf", [&](v1::CameraCalibration* c) { c->set_pitch_deg(-inf); }},
      {"fu 0", [&](v1::CameraCalibration* c) { c->set_fu(0); }},
      {"fv negative", [&](v1::CameraCalibration* c) { c->set_fv(-100); }},
      {"pitch 90", [&](v1::CameraCalibration* c) { c->set_pitch_deg(90); }},
      {"pitch -90", [&](v1::CameraCalibration* c) { c->set_pitch_deg(-90); }},
      {"pitch 120", [&](v1::CameraCalibration* c) { c->set_pitch_deg(120); }},
  };
  for (const auto& [name, mutate] : cases) {
    SCOPED_TRACE(name);
    v1::SessionConfig bad = config_;
    mutate(bad.mutable_camera());
    std::cout << "[bad-input] " << name << " -> ";
    EXPECT_EQ(CreateLogged(bad).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  }
  // A number beyond double in config_json (found by fuzz/config_fuzzer).
  v1::SessionConfig json;
  json.set_config_json("{\"camera\": {\"cv\": 256.5e352}}");
  std::cout << "[bad-input] config_json 256.5e352 -> ";
  EXPECT_EQ(CreateLogged(json).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(server_->server().sessions().size(), 1u);
  ExpectStillServing();
}

TEST_F(BadInputTest, BadRoiAndIpmSizeAreInvalidArgument) {
  Start();
  const std::vector<std::pair<const char*, std::function<void(v1::IpmOptions*)>>> cases = {
      {"roi outside the image",
       [](v1::IpmOptions* o) {
         o->mutable_roi()->set_left(5000);
         o->mutable_roi()->set_right(6000);
       }},
      {"roi above the horizon",
       [](v1::IpmOptions* o) {
         o->mutable_roi()->set_top(0);
         o->mutable_roi()->set_bottom(2);
       }},
      {"ipm width 0", [](v1::IpmOptions* o) { o->set_width(0); }},
      {"ipm height 0", [](v1::IpmOptions* o) { o->set_height(0); }},
      {"ipm absurd",
       [](v1::IpmOptions* o) {
         o->set_width(1000000);
         o->set_height(1000000);
       }},
  };
  for (const auto& [name, mutate] : cases) {
    SCOPED_TRACE(name);
    v1::SessionConfig bad = config_;
    mutate(bad.mutable_ipm());
    std::cout << "[bad-input] " << name << " -> ";
    EXPECT_EQ(CreateLogged(bad).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  }
  EXPECT_EQ(server_->server().sessions().size(), 1u);
  ExpectStillServing();
}

TEST_F(BadInputTest, MessageOverTheSizeLimit) {
  ServerOptions options = TestServer::DefaultOptions();
  // Room for the camera's raw 320x240 BGR frame (sessions whose raw frames
  // cannot fit are refused), not for the 320 KiB messages below.
  options.max_receive_message_bytes = 300 * 1024;
  Start(options);
  grpc::ClientContext context;
  v1::FrameResponse response;
  const grpc::Status status = server_->stub().Detect(
      &context, JpegRequest("cam", 1, std::string(320 * 1024, 'x')), &response);
  std::cout << "[bad-input] " << wire::GrpcCodeName(status.error_code()) << ": "
            << status.error_message() << "\n";
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  StreamResult result =
      RunStream(server_->stub(), {JpegRequest("cam", 2, std::string(320 * 1024, 'x'))});
  EXPECT_EQ(result.status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  ExpectStillServing();
}

TEST_F(BadInputTest, CreateSessionFloodHoldsTheCap) {
  ServerOptions options = TestServer::DefaultOptions();
  options.max_sessions = 8;
  Start(options);
  int exhausted = 0;
  int ok = 0;
  std::string last_message;
  // Memory is measured from call 1,000 on, once the cap is reached and gRPC's
  // pools are warm: refused calls must not leave anything behind.
  long rss_after_warmup = -1;
  for (int i = 0; i < 10000; ++i) {
    if (i == 1000) rss_after_warmup = ResidentKiB();
    const grpc::Status status = Create("flood-" + std::to_string(i), config_);
    if (status.ok()) ++ok;
    if (status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
      ++exhausted;
      last_message = status.error_message();
    }
  }
  const long rss_end = ResidentKiB();
  std::cout << "[bad-input] flood: " << ok << " created, " << exhausted
            << " RESOURCE_EXHAUSTED: " << last_message << "; RSS " << rss_after_warmup
            << " KiB after 1,000 calls, " << rss_end << " KiB after 10,000\n";
  // 9,000 refused calls: a leak of 1 KiB each would add 9 MiB.
  if (!kSanitized && rss_after_warmup > 0 && rss_end > 0) {
    EXPECT_LT(rss_end - rss_after_warmup, 4 * 1024) << "resident memory grew during the flood";
  }
  EXPECT_EQ(ok, 7);  // "cam" holds one of the 8
  EXPECT_EQ(exhausted, 10000 - 7);
  EXPECT_EQ(server_->server().sessions().size(), 8u);
  ExpectStillServing();
}

}  // namespace
}  // namespace lane::server::testing
