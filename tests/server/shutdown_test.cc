// The drain on SIGTERM/SIGINT (LaneServer::Drain): health NOT_SERVING, new
// work refused, every received frame answered, then Shutdown.
#include <gtest/gtest.h>

#include <thread>

#include "test_util.h"

namespace lane::server::testing {
namespace {

class ShutdownTest : public ::testing::Test {
 protected:
  void SetUp() override {
    camera_ = ScaledCamera(0.5);
    jpeg_ = EncodeJpeg(RoadFrame(camera_, kLineOffsets, 3));
  }
  lane::CameraModel camera_;
  std::string jpeg_;
};

TEST_F(ShutdownTest, DrainAnswersEveryReceivedFrame) {
  ServerOptions options = TestServer::DefaultOptions();
  options.workers = 1;
  options.max_inflight_frames = 16;
  TestServer server(options);
  ASSERT_FALSE(HasFailure());
  server.CreateSession("cam", SessionConfigFor(camera_));

  constexpr int kFrames = 400;
  grpc::ClientContext context;
  auto stream = server.stub().StreamFrames(&context);
  std::thread writer([&] {
    for (int i = 0; i < kFrames; ++i) {
      if (!stream->Write(JpegRequest("cam", i, jpeg_))) break;  // the server ended the stream
    }
    stream->WritesDone();
  });
  // Drain once frames are in flight.
  ASSERT_TRUE(PollUntil(
      [&] { return MetricValue(server.registry(), "lanesvc_frames_received_total") >= 10; }));
  std::thread drainer([&] { server.server().Drain(); });

  std::vector<v1::FrameResponse> responses;
  v1::FrameResponse response;
  while (stream->Read(&response)) responses.push_back(response);
  const grpc::Status status = stream->Finish();
  writer.join();
  drainer.join();

  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
  const double received = MetricValue(server.registry(), "lanesvc_frames_received_total");
  EXPECT_GE(received, 10);
  EXPECT_LT(received, kFrames) << "the drain came too late to test anything";
  // Every frame the server received was answered, in order, and processed.
  ASSERT_EQ(static_cast<double>(responses.size()), received);
  for (size_t i = 0; i < responses.size(); ++i) {
    ASSERT_EQ(responses[i].frame_id(), i);
    ASSERT_EQ(responses[i].status().code(), v1::FRAME_CODE_OK);
  }
  EXPECT_EQ(MetricValue(server.registry(), "lanesvc_inflight_frames"), 0);
  EXPECT_EQ(MetricValue(server.registry(), "lanesvc_frames_total"), received);
}

TEST_F(ShutdownTest, DrainRefusesNewWorkAndReportsNotServing) {
  TestServer server;
  ASSERT_FALSE(HasFailure());
  server.CreateSession("cam", SessionConfigFor(camera_));
  EXPECT_EQ(HealthStatus(server.channel()), 1);  // SERVING

  server.server().BeginDrain();
  EXPECT_EQ(HealthStatus(server.channel()), 2);  // NOT_SERVING
  {
    grpc::ClientContext context;
    v1::FrameResponse response;
    EXPECT_EQ(server.stub().Detect(&context, JpegRequest("cam", 1, jpeg_), &response).error_code(),
              grpc::StatusCode::UNAVAILABLE);
  }
  {
    grpc::ClientContext context;
    v1::CreateSessionRequest request;
    request.set_camera_id("late");
    v1::CreateSessionResponse response;
    EXPECT_EQ(server.stub().CreateSession(&context, request, &response).error_code(),
              grpc::StatusCode::UNAVAILABLE);
  }
  StreamResult result = RunStream(server.stub(), {JpegRequest("cam", 2, jpeg_)});
  EXPECT_EQ(result.status.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_TRUE(result.responses.empty());
  server.server().Drain();
}

TEST_F(ShutdownTest, IdleStreamEndsAtOnce) {
  ServerOptions options = TestServer::DefaultOptions();
  options.shutdown_deadline = absl::Seconds(60);
  TestServer server(options);
  ASSERT_FALSE(HasFailure());
  grpc::ClientContext context;
  auto stream = server.stub().StreamFrames(&context);
  ASSERT_TRUE(PollUntil([&] { return server.server().service().open_streams() == 1; }));
  const auto start = std::chrono::steady_clock::now();
  server.server().Drain();
  // Nothing to answer: the stream ended without waiting for the deadline.
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(30));
  v1::FrameResponse response;
  EXPECT_FALSE(stream->Read(&response));
  EXPECT_EQ(stream->Finish().error_code(), grpc::StatusCode::UNAVAILABLE);
}

}  // namespace
}  // namespace lane::server::testing
