#include "test_util.h"

#include <grpcpp/generic/generic_stub.h>
#include <gtest/gtest.h>

#include <future>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <thread>

namespace lane::server::testing {

lane::CameraModel ScaledCamera(double scale, double pitch_deg) {
  lane::CameraModel camera;
  camera.fu *= scale;
  camera.fv *= scale;
  camera.cu *= scale;
  camera.cv *= scale;
  camera.image_width = static_cast<int>(camera.image_width * scale);
  camera.image_height = static_cast<int>(camera.image_height * scale);
  camera.pitch_deg = pitch_deg;
  return camera;
}

v1::SessionConfig SessionConfigFor(const lane::CameraModel& camera) {
  v1::SessionConfig config;
  v1::CameraCalibration* c = config.mutable_camera();
  c->set_fu(camera.fu);
  c->set_fv(camera.fv);
  c->set_cu(camera.cu);
  c->set_cv(camera.cv);
  c->set_pitch_deg(camera.pitch_deg);
  c->set_yaw_deg(camera.yaw_deg);
  c->set_height_m(camera.height_m);
  c->set_image_width(camera.image_width);
  c->set_image_height(camera.image_height);
  const double scale = camera.image_width / 640.0;
  const lane::Roi roi;  // the default, for 640x480
  v1::Roi* r = config.mutable_ipm()->mutable_roi();
  r->set_left(roi.left * scale);
  r->set_right(roi.right * scale);
  r->set_top(roi.top * scale);
  r->set_bottom(roi.bottom * scale);
  return config;
}

cv::Mat RoadFrame(const lane::CameraModel& camera, const std::vector<double>& offsets, int seed) {
  cv::Mat frame(camera.image_height, camera.image_width, CV_8UC3, cv::Scalar(95, 100, 105));
  // Sky above the horizon.
  const int horizon = static_cast<int>(camera.HorizonRow());
  if (horizon > 0) {
    frame(cv::Rect(0, 0, frame.cols, std::min(horizon, frame.rows)))
        .setTo(cv::Scalar(200, 180, 160));
  }
  const double ys[] = {2, 3, 4, 5, 6, 8, 10, 13, 16, 20, 25, 30, 40, 60};
  const double half_width = 0.075;
  for (const double x : offsets) {
    for (size_t i = 0; i + 1 < std::size(ys); ++i) {
      const Eigen::Vector2d corners[4] = {
          camera.GroundToImage({x - half_width, ys[i]}),
          camera.GroundToImage({x + half_width, ys[i]}),
          camera.GroundToImage({x + half_width, ys[i + 1]}),
          camera.GroundToImage({x - half_width, ys[i + 1]}),
      };
      // Sub-pixel polygon (4 fractional bits) so thin far markings survive.
      std::vector<cv::Point> poly;
      for (const Eigen::Vector2d& p : corners) {
        poly.emplace_back(static_cast<int>(std::lround(p.x() * 16)),
                          static_cast<int>(std::lround(p.y() * 16)));
      }
      cv::fillConvexPoly(frame, poly, cv::Scalar(235, 235, 235), cv::LINE_AA, 4);
    }
  }
  if (seed != 0) {
    cv::Mat noise(frame.size(), CV_16SC3);
    cv::theRNG().state = static_cast<uint64_t>(seed);
    cv::randn(noise, 0, 3);
    cv::Mat noisy;
    frame.convertTo(noisy, CV_16SC3);
    noisy += noise;
    noisy.convertTo(frame, CV_8UC3);
  }
  return frame;
}

std::string EncodeJpeg(const cv::Mat& image, int quality) {
  std::vector<uchar> bytes;
  cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, quality});
  return std::string(bytes.begin(), bytes.end());
}

std::string EncodePng(const cv::Mat& image) {
  std::vector<uchar> bytes;
  cv::imencode(".png", image, bytes);
  return std::string(bytes.begin(), bytes.end());
}

v1::FrameRequest JpegRequest(const std::string& camera_id, uint64_t frame_id,
                             const std::string& jpeg) {
  v1::FrameRequest request;
  request.set_camera_id(camera_id);
  request.set_frame_id(frame_id);
  request.set_capture_time_unix_ns(static_cast<int64_t>(1'700'000'000'000'000'000 + frame_id));
  request.set_encoded(jpeg);
  return request;
}

ServerOptions TestServer::DefaultOptions() {
  ServerOptions options;
  options.address = "127.0.0.1:0";
  options.metrics_address = "";
  options.workers = 2;
  options.shutdown_deadline = absl::Seconds(20);
  options.build = CurrentBuildInfo();
  return options;
}

TestServer::TestServer(ServerOptions options)
    : registry_(std::make_shared<prometheus::Registry>()) {
  absl::StatusOr<std::unique_ptr<LaneServer>> server = LaneServer::Start(options, registry_);
  if (!server.ok()) {
    ADD_FAILURE() << "server did not start: " << server.status();
    return;
  }
  server_ = *std::move(server);
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 * 1024 * 1024);
  args.SetMaxSendMessageSize(64 * 1024 * 1024);
  channel_ = grpc::CreateCustomChannel(target(), grpc::InsecureChannelCredentials(), args);
  stub_ = v1::LaneService::NewStub(channel_);
}

TestServer::~TestServer() {
  stub_.reset();
  channel_.reset();
  if (server_ != nullptr) server_->Drain();
}

std::string TestServer::target() const { return "127.0.0.1:" + std::to_string(server_->port()); }

uint64_t TestServer::CreateSession(const std::string& camera_id, const v1::SessionConfig& config) {
  grpc::ClientContext context;
  v1::CreateSessionRequest request;
  request.set_camera_id(camera_id);
  *request.mutable_config() = config;
  v1::CreateSessionResponse response;
  const grpc::Status status = stub_->CreateSession(&context, request, &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return response.session().version();
}

double MetricValue(const prometheus::Registry& registry, const std::string& name,
                   const std::vector<std::pair<std::string, std::string>>& labels) {
  double sum = 0;
  for (const prometheus::MetricFamily& family : registry.Collect()) {
    if (family.name != name) continue;
    for (const prometheus::ClientMetric& metric : family.metric) {
      bool match = true;
      for (const auto& [key, value] : labels) {
        bool found = false;
        for (const prometheus::ClientMetric::Label& label : metric.label) {
          if (label.name == key && label.value == value) found = true;
        }
        match = match && found;
      }
      if (!match) continue;
      switch (family.type) {
        case prometheus::MetricType::Counter:
          sum += metric.counter.value;
          break;
        case prometheus::MetricType::Gauge:
          sum += metric.gauge.value;
          break;
        case prometheus::MetricType::Histogram:
          sum += static_cast<double>(metric.histogram.sample_count);
          break;
        default:
          break;
      }
    }
  }
  return sum;
}

StreamResult RunStream(v1::LaneService::Stub& stub, const std::vector<v1::FrameRequest>& requests) {
  StreamResult result;
  grpc::ClientContext context;
  std::unique_ptr<grpc::ClientReaderWriter<v1::FrameRequest, v1::FrameResponse>> stream =
      stub.StreamFrames(&context);
  std::thread writer([&] {
    for (const v1::FrameRequest& request : requests) {
      if (!stream->Write(request)) break;  // the server ended the stream
    }
    stream->WritesDone();
  });
  v1::FrameResponse response;
  while (stream->Read(&response)) result.responses.push_back(response);
  writer.join();
  result.status = stream->Finish();
  return result;
}

namespace {
std::string BufferToString(const grpc::ByteBuffer& buffer);
}  // namespace

int HealthStatus(const std::shared_ptr<grpc::Channel>& channel) {
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  // HealthCheckRequest{service: ""} encodes to no bytes (one empty slice:
  // a ByteBuffer without slices is not a message).
  grpc::Slice empty;
  grpc::ByteBuffer request(&empty, 1);
  grpc::ByteBuffer response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                 [&done](grpc::Status status) { done.set_value(status); });
  const grpc::Status status = done.get_future().get();
  if (!status.ok()) return -1;
  const std::string bytes = BufferToString(response);
  // HealthCheckResponse{status = 1 (varint)}: 0x08 <value>; empty = UNKNOWN.
  if (bytes.empty()) return 0;
  if (bytes.size() != 2 || bytes[0] != 0x08) return -1;
  return bytes[1];
}

namespace {

std::string BufferToString(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  std::string bytes;
  if (!buffer.Dump(&slices).ok()) return bytes;
  for (const grpc::Slice& slice : slices) {
    bytes.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
  }
  return bytes;
}

}  // namespace

bool ReflectionListsLaneService(const std::shared_ptr<grpc::Channel>& channel) {
  grpc::GenericStub stub(channel);
  grpc::CompletionQueue cq;
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  auto call = stub.PrepareCall(
      &context, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", &cq);
  // Each step waits for its own completion.
  auto step = [&cq](intptr_t id) {
    void* tag = nullptr;
    bool ok = false;
    return cq.Next(&tag, &ok) && ok && reinterpret_cast<intptr_t>(tag) == id;
  };
  call->StartCall(reinterpret_cast<void*>(1));
  bool ok = step(1);
  // ServerReflectionRequest{list_services (field 7): ""}.
  const std::string request_bytes("\x3a\x00", 2);
  grpc::Slice slice(request_bytes.data(), request_bytes.size());
  grpc::ByteBuffer request(&slice, 1);
  if (ok) {
    call->Write(request, reinterpret_cast<void*>(2));
    ok = step(2);
  }
  grpc::ByteBuffer response;
  if (ok) {
    call->Read(&response, reinterpret_cast<void*>(3));
    ok = step(3);
  }
  call->WritesDone(reinterpret_cast<void*>(4));
  step(4);
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(5));
  step(5);
  cq.Shutdown();
  void* tag = nullptr;
  bool drained_ok = false;
  while (cq.Next(&tag, &drained_ok)) {
  }
  return ok && BufferToString(response).find("lane.v1.LaneService") != std::string::npos;
}

}  // namespace lane::server::testing
