// End-to-end tests of lane.v1.LaneService's frames: Detect and StreamFrames
// (order, corrupt and raw frames, a session carried by the first frame,
// backpressure). A real server on a loopback port, driven through the
// generated stub; the sessions' own tests are in service_session_test.cc.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <map>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "service_test_fixture.h"
#include "test_util.h"

namespace lane::server::testing {
namespace {

TEST_F(ServiceTest, DetectUnary) {
  auto server = StartServer();
  ASSERT_NE(server, nullptr);
  const uint64_t version = server->CreateSession("cam", config_);
  {
    grpc::ClientContext context;
    v1::FrameResponse response;
    const grpc::Status status =
        server->stub().Detect(&context, JpegRequest("cam", 7, jpeg_), &response);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(response.frame_id(), 7u);
    EXPECT_EQ(response.status().code(), v1::FRAME_CODE_OK);
    EXPECT_EQ(response.calibration_version(), version);
    EXPECT_EQ(response.camera_id(), "cam");
    EXPECT_GT(response.server_receive_time_unix_ns(), 0);
    EXPECT_GE(response.server_send_time_unix_ns(), response.server_receive_time_unix_ns());
    EXPECT_GT(response.timings().decode_ms(), 0);
    for (const v1::Lane& lane : response.lanes()) {
      EXPECT_EQ(lane.image().control_points_size(), 4);
      EXPECT_EQ(lane.ipm().control_points_size(), 4);
      EXPECT_EQ(lane.ground().control_points_size(), 4);
    }
  }
  {  // A bad frame: the call's status.
    grpc::ClientContext context;
    v1::FrameResponse response;
    EXPECT_EQ(server->stub()
                  .Detect(&context, JpegRequest("cam", 8, "not an image"), &response)
                  .error_code(),
              grpc::StatusCode::INVALID_ARGUMENT);
  }
  {  // No session.
    grpc::ClientContext context;
    v1::FrameResponse response;
    EXPECT_EQ(
        server->stub().Detect(&context, JpegRequest("nope", 9, jpeg_), &response).error_code(),
        grpc::StatusCode::FAILED_PRECONDITION);
  }
  {  // Self-sufficient: the config comes with the frame.
    grpc::ClientContext context;
    v1::FrameRequest request = JpegRequest("inline", 10, jpeg_);
    *request.mutable_session_config() = config_;
    v1::FrameResponse response;
    ASSERT_TRUE(server->stub().Detect(&context, request, &response).ok());
    EXPECT_GT(response.calibration_version(), version);
  }
  EXPECT_EQ(MetricValue(server->registry(), "grpc_server_handled_total",
                        {{"grpc_method", "Detect"}, {"grpc_code", "OK"}}),
            2);
  EXPECT_EQ(MetricValue(server->registry(), "lanesvc_frames_total", {{"result", "ok"}}), 2);
  EXPECT_EQ(MetricValue(server->registry(), "lanesvc_frames_total", {{"result", "invalid"}}), 1);
  EXPECT_EQ(MetricValue(server->registry(), "lanesvc_frame_latency_seconds"), 3);
  EXPECT_EQ(MetricValue(server->registry(), "lanesvc_inflight_frames"), 0);
}

TEST_F(ServiceTest, ThousandFramesArriveInOrder) {
  auto server = StartServer();
  ASSERT_NE(server, nullptr);
  const uint64_t version = server->CreateSession("cam", config_);
  constexpr int kFrames = 1000;
  std::vector<v1::FrameRequest> requests;
  requests.reserve(kFrames);
  for (int i = 0; i < kFrames; ++i) requests.push_back(JpegRequest("cam", 1000 + i, jpeg_));
  StreamResult result = RunStream(server->stub(), requests);
  ASSERT_TRUE(result.status.ok()) << result.status.error_message();
  ASSERT_EQ(result.responses.size(), static_cast<size_t>(kFrames));
  for (int i = 0; i < kFrames; ++i) {
    const v1::FrameResponse& r = result.responses[i];
    ASSERT_EQ(r.frame_id(), static_cast<uint64_t>(1000 + i));
    ASSERT_EQ(r.capture_time_unix_ns(), requests[i].capture_time_unix_ns());
    ASSERT_EQ(r.status().code(), v1::FRAME_CODE_OK) << r.status().message();
    ASSERT_EQ(r.calibration_version(), version);
  }
  EXPECT_EQ(MetricValue(server->registry(), "lanesvc_frames_total", {{"result", "ok"}}), kFrames);
  EXPECT_EQ(MetricValue(server->registry(), "lanesvc_frame_latency_seconds"), kFrames);
  EXPECT_EQ(
      MetricValue(server->registry(), "lanesvc_stage_duration_seconds", {{"stage", "decode"}}),
      kFrames);
  EXPECT_EQ(MetricValue(server->registry(), "lanesvc_queue_wait_seconds"), kFrames);
  EXPECT_EQ(MetricValue(server->registry(), "grpc_server_handled_total",
                        {{"grpc_method", "StreamFrames"}, {"grpc_code", "OK"}}),
            1);
  EXPECT_EQ(MetricValue(server->registry(), "lanesvc_inflight_frames"), 0);
}

TEST_F(ServiceTest, CorruptFrameGetsItsOwnError) {
  auto server = StartServer();
  ASSERT_NE(server, nullptr);
  server->CreateSession("cam", config_);
  std::string truncated_header = jpeg_.substr(0, 20);  // cut inside the JPEG header
  std::string garbage_body = jpeg_;                    // valid header, scrambled data
  for (size_t i = garbage_body.size() / 2; i < garbage_body.size(); ++i) garbage_body[i] = 0;
  std::vector<v1::FrameRequest> requests;
  for (int i = 0; i < 12; ++i) requests.push_back(JpegRequest("cam", i, jpeg_));
  requests[3].set_encoded("definitely not a JPEG");
  requests[5].set_encoded(truncated_header);
  requests[7].set_encoded(EncodeJpeg(RoadFrame(ScaledCamera(0.25), kLineOffsets)));  // wrong size
  requests[9].clear_image();
  StreamResult result = RunStream(server->stub(), requests);
  ASSERT_TRUE(result.status.ok()) << result.status.error_message();
  ASSERT_EQ(result.responses.size(), requests.size());
  for (size_t i = 0; i < requests.size(); ++i) {
    const v1::FrameResponse& r = result.responses[i];
    EXPECT_EQ(r.frame_id(), i);
    const bool bad = i == 3 || i == 5 || i == 7 || i == 9;
    EXPECT_EQ(r.status().code(), bad ? v1::FRAME_CODE_INVALID_ARGUMENT : v1::FRAME_CODE_OK)
        << "frame " << i << ": " << r.status().message();
    if (bad) {
      EXPECT_FALSE(r.status().message().empty());
      EXPECT_EQ(r.lanes_size(), 0);
    }
  }
  EXPECT_NE(result.responses[7].status().message().find("camera delivers"), std::string::npos);
  EXPECT_EQ(MetricValue(server->registry(), "lanesvc_frames_total", {{"result", "invalid"}}), 4);
}

TEST_F(ServiceTest, RawFrames) {
  auto server = StartServer();
  ASSERT_NE(server, nullptr);
  server->CreateSession("cam", config_);
  const cv::Mat bgr = RoadFrame(camera_, kLineOffsets, 2);
  auto raw_request = [&](uint64_t id, v1::PixelFormat format, const cv::Mat& image, int pad) {
    v1::FrameRequest request;
    request.set_camera_id("cam");
    request.set_frame_id(id);
    v1::RawImage* raw = request.mutable_raw();
    raw->set_width(image.cols);
    raw->set_height(image.rows);
    raw->set_pixel_format(format);
    const size_t row = image.cols * image.elemSize();
    const size_t stride = row + pad;
    if (pad > 0) raw->set_stride(static_cast<uint32_t>(stride));
    std::string data(stride * image.rows, '\x7f');
    for (int y = 0; y < image.rows; ++y) {
      std::memcpy(&data[y * stride], image.ptr(y), row);
    }
    raw->set_data(std::move(data));
    return request;
  };
  cv::Mat rgb, gray;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  std::vector<v1::FrameRequest> requests = {
      raw_request(0, v1::PIXEL_FORMAT_BGR8, bgr, 0),
      raw_request(1, v1::PIXEL_FORMAT_RGB8, rgb, 16),
      raw_request(2, v1::PIXEL_FORMAT_GRAY8, gray, 3),
      // Size mismatch: a frame of another camera.
      raw_request(3, v1::PIXEL_FORMAT_BGR8, RoadFrame(ScaledCamera(0.25), kLineOffsets), 0),
      raw_request(4, v1::PIXEL_FORMAT_BGR8, bgr, 0),
      raw_request(5, v1::PIXEL_FORMAT_BGR8, bgr, 0),
      raw_request(6, v1::PIXEL_FORMAT_UNSPECIFIED, bgr, 0),
  };
  requests[4].mutable_raw()->set_stride(10);               // less than a row
  requests[5].mutable_raw()->mutable_data()->resize(100);  // too little data
  // A PNG too.
  v1::FrameRequest png = JpegRequest("cam", 7, EncodePng(bgr));
  requests.push_back(png);

  StreamResult result = RunStream(server->stub(), requests);
  ASSERT_TRUE(result.status.ok()) << result.status.error_message();
  ASSERT_EQ(result.responses.size(), requests.size());
  const v1::FrameCode expected[] = {v1::FRAME_CODE_OK,
                                    v1::FRAME_CODE_OK,
                                    v1::FRAME_CODE_OK,
                                    v1::FRAME_CODE_INVALID_ARGUMENT,
                                    v1::FRAME_CODE_INVALID_ARGUMENT,
                                    v1::FRAME_CODE_INVALID_ARGUMENT,
                                    v1::FRAME_CODE_INVALID_ARGUMENT,
                                    v1::FRAME_CODE_OK};
  for (size_t i = 0; i < requests.size(); ++i) {
    EXPECT_EQ(result.responses[i].status().code(), expected[i])
        << "frame " << i << ": " << result.responses[i].status().message();
  }
  // BGR, RGB and the BGR PNG are the same picture: the same lanes.
  EXPECT_EQ(result.responses[0].lanes_size(), result.responses[1].lanes_size());
  EXPECT_EQ(result.responses[0].lanes_size(), result.responses[7].lanes_size());
}

TEST_F(ServiceTest, RawFullHdFrameFitsTheDefaultMessageSize) {
  auto server = StartServer();
  ASSERT_NE(server, nullptr);
  // The Caltech camera at 3x, cropped to 1920x1080.
  lane::CameraModel camera = ScaledCamera(3.0);
  camera.image_height = 1080;
  camera.cv -= 180;
  v1::SessionConfig config = SessionConfigFor(camera);
  v1::Roi* roi = config.mutable_ipm()->mutable_roi();
  roi->set_top(roi->top() - 180);
  roi->set_bottom(roi->bottom() - 180);
  server->CreateSession("hd", config);
  const cv::Mat frame = RoadFrame(camera, kLineOffsets);
  v1::FrameRequest request;
  request.set_camera_id("hd");
  v1::RawImage* raw = request.mutable_raw();
  raw->set_width(1920);
  raw->set_height(1080);
  raw->set_pixel_format(v1::PIXEL_FORMAT_BGR8);
  raw->set_data(std::string(reinterpret_cast<const char*>(frame.data), frame.total() * 3));
  ASSERT_GT(request.ByteSizeLong(), size_t{1920} * 1080 * 3);
  grpc::ClientContext context;
  v1::FrameResponse response;
  const grpc::Status status = server->stub().Detect(&context, request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response.status().code(), v1::FRAME_CODE_OK);
  EXPECT_GT(response.lanes_size(), 0);
}

TEST_F(ServiceTest, UnknownSessionEndsTheStreamAfterEarlierFrames) {
  auto server = StartServer();
  ASSERT_NE(server, nullptr);
  server->CreateSession("cam", config_);
  std::vector<v1::FrameRequest> requests = {
      JpegRequest("cam", 0, jpeg_), JpegRequest("cam", 1, jpeg_), JpegRequest("ghost", 2, jpeg_),
      JpegRequest("cam", 3, jpeg_)};
  StreamResult result = RunStream(server->stub(), requests);
  EXPECT_EQ(result.status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(result.status.error_message().find("ghost"), std::string::npos);
  ASSERT_EQ(result.responses.size(), 2u);
  EXPECT_EQ(result.responses[0].frame_id(), 0u);
  EXPECT_EQ(result.responses[1].frame_id(), 1u);

  // A stream whose very first frame names no known session.
  result = RunStream(server->stub(), {JpegRequest("ghost", 0, jpeg_)});
  EXPECT_EQ(result.status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_TRUE(result.responses.empty());
  EXPECT_EQ(MetricValue(server->registry(), "grpc_server_handled_total",
                        {{"grpc_method", "StreamFrames"}, {"grpc_code", "FAILED_PRECONDITION"}}),
            2);
}

TEST_F(ServiceTest, FirstFrameCarriesTheSession) {
  auto server = StartServer();
  ASSERT_NE(server, nullptr);
  std::vector<v1::FrameRequest> requests;
  for (int i = 0; i < 6; ++i) requests.push_back(JpegRequest(i == 0 ? "lb-cam" : "", i, jpeg_));
  *requests[0].mutable_session_config() = config_;
  *requests[4].mutable_session_config() = config_;  // only the first may
  StreamResult result = RunStream(server->stub(), requests);
  ASSERT_TRUE(result.status.ok()) << result.status.error_message();
  ASSERT_EQ(result.responses.size(), requests.size());
  for (size_t i = 0; i < requests.size(); ++i) {
    EXPECT_EQ(result.responses[i].camera_id(), "lb-cam");
    EXPECT_EQ(result.responses[i].status().code(),
              i == 4 ? v1::FRAME_CODE_INVALID_ARGUMENT : v1::FRAME_CODE_OK);
  }
  // A second stream with the same config confirms the session (same version).
  StreamResult again = RunStream(server->stub(), {requests[0]});
  ASSERT_TRUE(again.status.ok());
  ASSERT_EQ(again.responses.size(), 1u);
  EXPECT_EQ(again.responses[0].calibration_version(), result.responses[0].calibration_version());
  // A conflicting config without replace_session ends the stream.
  v1::FrameRequest conflicting = requests[0];
  conflicting.mutable_session_config()->mutable_camera()->set_pitch_deg(12);
  StreamResult conflict = RunStream(server->stub(), {conflicting});
  EXPECT_EQ(conflict.status.error_code(), grpc::StatusCode::ALREADY_EXISTS);
  conflicting.set_replace_session(true);
  StreamResult replaced = RunStream(server->stub(), {conflicting});
  ASSERT_TRUE(replaced.status.ok());
  EXPECT_GT(replaced.responses.at(0).calibration_version(),
            result.responses[0].calibration_version());
  // A bad inline config: INVALID_ARGUMENT for the stream.
  v1::FrameRequest bad = JpegRequest("other", 0, jpeg_);
  bad.mutable_session_config()->mutable_camera()->set_height_m(-1);
  EXPECT_EQ(RunStream(server->stub(), {bad}).status.error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
}

TEST_F(ServiceTest, EightStreamsKeepTheirOwnCalibrations) {
  auto server = StartServer();
  ASSERT_NE(server, nullptr);
  constexpr int kStreams = 8;
  constexpr int kFrames = 20;
  const double scales[] = {0.5, 0.5625, 0.625, 0.6875};
  const double pitches[] = {13.0, 15.0};
  struct Camera {
    std::string id;
    lane::CameraModel model;
    uint64_t version = 0;
    std::string jpeg;
  };
  std::vector<Camera> cameras(kStreams);
  for (int i = 0; i < kStreams; ++i) {
    Camera& c = cameras[i];
    c.id = "cam-" + std::to_string(i);
    c.model = ScaledCamera(scales[i % 4], pitches[i / 4]);
    c.version = server->CreateSession(c.id, SessionConfigFor(c.model));
    c.jpeg = EncodeJpeg(RoadFrame(c.model, kLineOffsets, i + 1));
  }
  std::vector<StreamResult> results(kStreams);
  std::vector<std::thread> threads;
  for (int i = 0; i < kStreams; ++i) {
    threads.emplace_back([&, i] {
      std::vector<v1::FrameRequest> requests;
      for (int f = 0; f < kFrames; ++f) {
        requests.push_back(JpegRequest(cameras[i].id, f, cameras[i].jpeg));
      }
      results[i] = RunStream(server->stub(), requests);
    });
  }
  for (std::thread& t : threads) t.join();

  for (int i = 0; i < kStreams; ++i) {
    const Camera& c = cameras[i];
    SCOPED_TRACE(c.id);
    ASSERT_TRUE(results[i].status.ok()) << results[i].status.error_message();
    ASSERT_EQ(results[i].responses.size(), static_cast<size_t>(kFrames));
    int near_truth = 0;
    int lanes = 0;
    for (int f = 0; f < kFrames; ++f) {
      const v1::FrameResponse& r = results[i].responses[f];
      ASSERT_EQ(r.frame_id(), static_cast<uint64_t>(f));
      // A frame of another camera would not even have the right size.
      ASSERT_EQ(r.status().code(), v1::FRAME_CODE_OK) << r.status().message();
      ASSERT_EQ(r.camera_id(), c.id);
      ASSERT_EQ(r.calibration_version(), c.version);
      for (const v1::Lane& lane : r.lanes()) {
        ++lanes;
        // Through the right calibration the ground positions are the painted ones.
        const v1::Point2& p = lane.ground().control_points(0);
        const double x = p.x();
        const double err = std::abs(*std::min_element(kLineOffsets.begin(), kLineOffsets.end(),
                                                      [x](double a, double b) {
                                                        return std::abs(a - x) < std::abs(b - x);
                                                      }) -
                                    x);
        if (err < 0.5) ++near_truth;
        for (const v1::Point2& q : lane.image().control_points()) {
          EXPECT_GT(q.x(), -c.model.image_width);
          EXPECT_LT(q.x(), 2 * c.model.image_width);
        }
      }
    }
    EXPECT_GT(lanes, 0);
    EXPECT_GE(near_truth, lanes * 3 / 4) << near_truth << " of " << lanes << " lanes";
  }
}

TEST_F(ServiceTest, DropOldestAnswersEveryFrameInOrder) {
  ServerOptions options = TestServer::DefaultOptions();
  options.workers = 1;
  auto server = StartServer(options);
  ASSERT_NE(server, nullptr);
  v1::SessionConfig config = config_;
  config.mutable_stream()->set_backpressure(v1::BACKPRESSURE_DROP_OLDEST);
  config.mutable_stream()->set_max_inflight_frames(2);
  server->CreateSession("live", config);
  constexpr int kFrames = 60;
  std::vector<v1::FrameRequest> requests;
  for (int i = 0; i < kFrames; ++i) requests.push_back(JpegRequest("live", i, jpeg_));
  StreamResult result = RunStream(server->stub(), requests);
  ASSERT_TRUE(result.status.ok()) << result.status.error_message();
  ASSERT_EQ(result.responses.size(), static_cast<size_t>(kFrames));
  int dropped = 0;
  for (int i = 0; i < kFrames; ++i) {
    const v1::FrameResponse& r = result.responses[i];
    ASSERT_EQ(r.frame_id(), static_cast<uint64_t>(i));
    if (r.status().code() == v1::FRAME_CODE_DROPPED) {
      ++dropped;
    } else {
      ASSERT_EQ(r.status().code(), v1::FRAME_CODE_OK) << r.status().message();
    }
  }
  // The newest frame is never the one dropped.
  EXPECT_EQ(result.responses.back().status().code(), v1::FRAME_CODE_OK);
  EXPECT_GT(dropped, 0) << "60 frames sent at once through one worker, none dropped";
  EXPECT_EQ(MetricValue(server->registry(), "lanesvc_frames_total", {{"result", "dropped"}}),
            dropped);
  EXPECT_EQ(MetricValue(server->registry(), "lanesvc_frames_total", {{"result", "ok"}}),
            kFrames - dropped);
}

TEST_F(ServiceTest, BlockBackpressureBoundsFramesInFlight) {
  ServerOptions options = TestServer::DefaultOptions();
  options.workers = 1;
  options.max_inflight_frames = 3;
  auto server = StartServer(options);
  ASSERT_NE(server, nullptr);
  server->CreateSession("cam", config_);
  std::atomic<bool> done{false};
  std::atomic<double> peak{0};
  std::thread sampler([&] {
    while (!done) {
      const double v = MetricValue(server->registry(), "lanesvc_inflight_frames");
      if (v > peak) peak = v;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  std::vector<v1::FrameRequest> requests;
  for (int i = 0; i < 80; ++i) requests.push_back(JpegRequest("cam", i, jpeg_));
  StreamResult result = RunStream(server->stub(), requests);
  done = true;
  sampler.join();
  ASSERT_TRUE(result.status.ok());
  EXPECT_EQ(result.responses.size(), requests.size());
  EXPECT_LE(peak.load(), 3.0);
  EXPECT_GE(peak.load(), 1.0);
}

}  // namespace
}  // namespace lane::server::testing
