// Hardening, round 2: hostile input a client can send, one test per class,
// each with a healthy stream running beside it on the same connection the
// whole time. The healthy stream must lose, reorder and duplicate nothing.
// docs/service.md's "Bad input" table lists every case with its test.
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/impl/codegen/client_unary_call.h>
#include <grpcpp/impl/codegen/sync_stream.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <iostream>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "hostile_frames.h"
#include "test_util.h"
#include "wire/status_map.h"

namespace lane::server::testing {
namespace {

using std::chrono::steady_clock;

constexpr size_t kMaxMessage = 1024;  // every status message stays under 1 kB

// Streams `frames` good frames on `channel`, `gap` apart, while a test does
// its worst on the same server; Check() asserts they were all answered OK,
// once each, in order.
class HealthyStream {
 public:
  HealthyStream(std::shared_ptr<grpc::Channel> channel, std::string jpeg, int frames = 40,
                std::chrono::milliseconds gap = std::chrono::milliseconds(25))
      : stub_(v1::LaneService::NewStub(std::move(channel))) {
    std::vector<v1::FrameRequest> requests;
    for (int i = 0; i < frames; ++i) requests.push_back(JpegRequest("cam", i, jpeg));
    thread_ = std::thread([this, requests = std::move(requests), gap] {
      grpc::ClientContext context;
      auto stream = stub_->StreamFrames(&context);
      std::thread writer([&] {
        for (const v1::FrameRequest& request : requests) {
          if (!stream->Write(request)) break;
          std::this_thread::sleep_for(gap);
        }
        stream->WritesDone();
      });
      v1::FrameResponse response;
      while (stream->Read(&response)) result_.responses.push_back(response);
      writer.join();
      result_.status = stream->Finish();
    });
  }
  ~HealthyStream() {
    if (thread_.joinable()) thread_.join();
  }

  void Check(int frames = 40) {
    thread_.join();
    EXPECT_TRUE(result_.status.ok()) << wire::GrpcCodeName(result_.status.error_code()) << ": "
                                     << result_.status.error_message();
    ASSERT_EQ(result_.responses.size(), static_cast<size_t>(frames));
    for (int i = 0; i < frames; ++i) {
      const v1::FrameResponse& r = result_.responses[static_cast<size_t>(i)];
      EXPECT_EQ(r.frame_id(), static_cast<uint64_t>(i));
      EXPECT_EQ(r.status().code(), v1::FRAME_CODE_OK) << r.status().message();
    }
  }

 private:
  std::unique_ptr<v1::LaneService::Stub> stub_;
  std::thread thread_;
  StreamResult result_;
};

// Raw calls: bytes that need not be a valid message.
grpc::ByteBuffer ToBuffer(const std::string& bytes) {
  grpc::Slice slice(bytes.data(), bytes.size());
  return grpc::ByteBuffer(&slice, 1);
}

std::string FromBuffer(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  std::string bytes;
  if (!buffer.Dump(&slices).ok()) return bytes;
  for (const grpc::Slice& s : slices)
    bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  return bytes;
}

grpc::Status RawUnary(grpc::Channel& channel, const std::string& method, const std::string& bytes,
                      std::string* response = nullptr) {
  const grpc::internal::RpcMethod rpc(method.c_str(), grpc::internal::RpcMethod::NORMAL_RPC);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  grpc::ByteBuffer out;
  const grpc::Status status = grpc::internal::BlockingUnaryCall<grpc::ByteBuffer, grpc::ByteBuffer>(
      &channel, rpc, &context, ToBuffer(bytes), &out);
  if (response != nullptr) *response = FromBuffer(out);
  return status;
}

struct RawStreamResult {
  std::vector<std::string> responses;
  grpc::Status status;
};

// A StreamFrames call whose messages are arbitrary bytes.
RawStreamResult RawStream(grpc::Channel& channel, const std::vector<std::string>& messages) {
  const grpc::internal::RpcMethod rpc("/lane.v1.LaneService/StreamFrames",
                                      grpc::internal::RpcMethod::BIDI_STREAMING);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  std::unique_ptr<grpc::ClientReaderWriter<grpc::ByteBuffer, grpc::ByteBuffer>> stream(
      grpc::internal::ClientReaderWriterFactory<grpc::ByteBuffer, grpc::ByteBuffer>::Create(
          &channel, rpc, &context));
  std::thread writer([&] {
    for (const std::string& message : messages) {
      if (!stream->Write(ToBuffer(message))) break;
    }
    stream->WritesDone();
  });
  RawStreamResult result;
  grpc::ByteBuffer buffer;
  while (stream->Read(&buffer)) result.responses.push_back(FromBuffer(buffer));
  writer.join();
  result.status = stream->Finish();
  return result;
}

void Log(const char* what, const grpc::Status& status) {
  std::cout << "[hostile] " << what << ": " << wire::GrpcCodeName(status.error_code()) << " ("
            << status.error_message().size() << " bytes): " << status.error_message().substr(0, 200)
            << "\n";
}

class HostileInputTest : public ::testing::Test {
 protected:
  void SetUp() override { Start(TestServer::DefaultOptions()); }

  void Start(ServerOptions options) {
    camera_ = ScaledCamera(0.5);
    config_ = SessionConfigFor(camera_);
    jpeg_ = EncodeJpeg(RoadFrame(camera_, kLineOffsets, 1));
    server_ = std::make_unique<TestServer>(options);
    ASSERT_FALSE(::testing::Test::HasFailure());
    server_->CreateSession("cam", config_);
  }

  grpc::Status Create(const std::string& id, const v1::SessionConfig& config) {
    return CreateSessionStatus(server_->stub(), id, config);
  }

  lane::CameraModel camera_;
  v1::SessionConfig config_;
  std::string jpeg_;
  std::unique_ptr<TestServer> server_;
};

// Class 1: a config of 100,000 nested arrays (200 kB) used to crash the
// server (unbounded recursion formatting it). Both ways in: CreateSession and
// inline on a stream's first request.
TEST_F(HostileInputTest, DeepConfigIsRefusedWithoutRecursion) {
  HealthyStream healthy(server_->channel(), jpeg_);
  v1::SessionConfig deep;
  deep.set_config_json(std::string(100000, '[') + std::string(100000, ']'));
  const grpc::Status created = Create("deep", deep);
  Log("CreateSession, 100k nested arrays", created);
  EXPECT_EQ(created.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_LT(created.error_message().size(), kMaxMessage);
  EXPECT_NE(created.error_message().find("nests deeper than"), std::string::npos);

  v1::FrameRequest first = JpegRequest("deep", 0, jpeg_);
  *first.mutable_session_config() = deep;
  const StreamResult inline_config =
      RunStream(server_->stub(), {first, JpegRequest("deep", 1, jpeg_)});
  Log("stream, inline 100k nested arrays", inline_config.status);
  EXPECT_EQ(inline_config.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_LT(inline_config.status.error_message().size(), kMaxMessage);
  EXPECT_TRUE(inline_config.responses.empty());

  v1::FrameRequest unary = JpegRequest("deep", 0, jpeg_);
  *unary.mutable_session_config() = deep;
  grpc::ClientContext context;
  v1::FrameResponse response;
  const grpc::Status detect = server_->stub().Detect(&context, unary, &response);
  EXPECT_EQ(detect.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  healthy.Check();
}

// Class 2: decompression bombs at the camera's own size pass the header check
// but must not hold a worker: a progressive JPEG of ~146,000 scans, a valid
// one of 2,090 scans, a PNG whose data inflates 1 GiB past its image. Each
// gets an in-band error within a second, and the healthy stream beside them
// loses nothing (with 2 workers, two stalled frames used to stall everyone).
TEST_F(HostileInputTest, DecompressionBombsCostMilliseconds) {
  const lane::CameraModel vga = ScaledCamera(1.0);
  server_->CreateSession("vga", SessionConfigFor(vga));
  HealthyStream healthy(server_->channel(), jpeg_);
  cv::Mat rgb;
  cv::cvtColor(lane::testing::Frame(640, 480), rgb, cv::COLOR_BGR2RGB);
  const std::vector<std::pair<const char*, std::string>> bombs = {
      {"146,000-scan JPEG", lane::testing::RepeatedScanBomb(146000)},
      {"2,090-scan JPEG",
       lane::testing::LibjpegEncode(rgb, JCS_RGB, lane::testing::ManyScansScript())},
      {"PNG, 1 GiB past the image", lane::testing::PngBomb(lane::testing::Frame(640, 480), 1024)},
  };
  std::vector<v1::FrameRequest> requests;
  for (size_t i = 0; i < bombs.size(); ++i)
    requests.push_back(JpegRequest("vga", i, bombs[i].second));
  requests.push_back(JpegRequest("vga", 9, EncodeJpeg(RoadFrame(vga, kLineOffsets, 1))));
  const auto start = steady_clock::now();
  const StreamResult r = RunStream(server_->stub(), requests);
  const double seconds = std::chrono::duration<double>(steady_clock::now() - start).count();
  EXPECT_TRUE(r.status.ok()) << r.status.error_message();
  ASSERT_EQ(r.responses.size(), requests.size());
  for (size_t i = 0; i < bombs.size(); ++i) {
    const v1::FrameResponse& response = r.responses[i];
    std::cout << "[hostile] " << bombs[i].first << " (" << bombs[i].second.size()
              << " bytes): code " << response.status().code() << " after "
              << response.timings().decode_ms() << " ms: " << response.status().message() << "\n";
    EXPECT_EQ(response.status().code(), v1::FRAME_CODE_INVALID_ARGUMENT) << bombs[i].first;
    EXPECT_LT(response.timings().decode_ms(), 1000.0) << bombs[i].first;
    EXPECT_LT(response.status().message().size(), kMaxMessage);
  }
  EXPECT_EQ(r.responses.back().status().code(), v1::FRAME_CODE_OK);
  EXPECT_LT(seconds, 10.0);
  healthy.Check();
}

// Class 5: corrupt or truncated JPEGs are refused (libjpeg's warnings are
// errors), unless the session accepts damaged frames.
TEST_F(HostileInputTest, DamagedJpegsAreRefusedUnlessTheSessionAcceptsThem) {
  HealthyStream healthy(server_->channel(), jpeg_);
  const std::string whole = EncodeJpeg(RoadFrame(camera_, kLineOffsets, 3));
  const std::string half = whole.substr(0, whole.size() / 2);
  std::string scrambled = whole;
  // Randomise 2 kB of entropy-coded data after the first scan's header.
  const size_t sos = scrambled.find("\xFF\xDA");
  ASSERT_NE(sos, std::string::npos);
  std::mt19937 rng(5);
  for (size_t i = sos + 64; i < sos + 64 + 2048 && i + 2 < scrambled.size(); ++i) {
    scrambled[i] = static_cast<char>(rng() & 0x7F);  // no 0xFF: no markers
  }
  const StreamResult strict =
      RunStream(server_->stub(), {JpegRequest("cam", 0, half), JpegRequest("cam", 1, scrambled),
                                  JpegRequest("cam", 2, whole)});
  ASSERT_EQ(strict.responses.size(), 3u);
  for (int i = 0; i < 2; ++i) {
    const v1::FrameStatus& status = strict.responses[static_cast<size_t>(i)].status();
    std::cout << "[hostile] damaged frame " << i << ": " << status.message() << "\n";
    EXPECT_EQ(status.code(), v1::FRAME_CODE_INVALID_ARGUMENT);
    EXPECT_NE(status.message().find("damaged JPEG frame"), std::string::npos);
    EXPECT_EQ(strict.responses[static_cast<size_t>(i)].lanes_size(), 0);
  }
  EXPECT_EQ(strict.responses[2].status().code(), v1::FRAME_CODE_OK);

  v1::SessionConfig lenient = config_;
  lenient.mutable_decode()->set_accept_damaged_frames(true);
  server_->CreateSession("lenient", lenient);
  const StreamResult accepted = RunStream(
      server_->stub(), {JpegRequest("lenient", 0, half), JpegRequest("lenient", 1, scrambled)});
  ASSERT_EQ(accepted.responses.size(), 2u);
  for (const v1::FrameResponse& response : accepted.responses) {
    EXPECT_EQ(response.status().code(), v1::FRAME_CODE_OK) << response.status().message();
  }
  healthy.Check();
}

// Class 3: client strings of any length are quoted as short excerpts, and ids
// are validated before anything quotes them.
TEST_F(HostileInputTest, LongClientStringsGetShortMessages) {
  HealthyStream healthy(server_->channel(), jpeg_);
  const std::string long_id(10000, 'x');
  {
    grpc::ClientContext context;
    v1::GetSessionRequest request;
    request.set_camera_id(long_id);
    v1::Session session;
    const grpc::Status s = server_->stub().GetSession(&context, request, &session);
    Log("GetSession, 10 kB id", s);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_LT(s.error_message().size(), kMaxMessage);
  }
  {
    grpc::ClientContext context;
    v1::DeleteSessionRequest request;
    request.set_camera_id(long_id);
    v1::DeleteSessionResponse response;
    const grpc::Status s = server_->stub().DeleteSession(&context, request, &response);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_LT(s.error_message().size(), kMaxMessage);
  }
  {
    grpc::ClientContext context;
    v1::FrameResponse response;
    const grpc::Status s =
        server_->stub().Detect(&context, JpegRequest(long_id, 0, jpeg_), &response);
    Log("Detect, 10 kB id", s);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_LT(s.error_message().size(), kMaxMessage);
  }
  {
    // On a stream the frame gets its own error and the stream goes on.
    const StreamResult r =
        RunStream(server_->stub(), {JpegRequest(long_id, 0, jpeg_), JpegRequest("cam", 1, jpeg_)});
    EXPECT_TRUE(r.status.ok()) << r.status.error_message().substr(0, 200);
    ASSERT_EQ(r.responses.size(), 2u);
    EXPECT_EQ(r.responses[0].status().code(), v1::FRAME_CODE_INVALID_ARGUMENT);
    EXPECT_LT(r.responses[0].status().message().size(), kMaxMessage);
    EXPECT_EQ(r.responses[1].status().code(), v1::FRAME_CODE_OK);
  }
  {
    v1::SessionConfig config = config_;
    config.set_config_json("{\"camera\": {\"" + std::string(10000, 'k') + "\": 1}}");
    config.clear_camera();
    config.clear_ipm();
    config.clear_detector();
    const grpc::Status s = Create("long-key", config);
    Log("CreateSession, 10 kB unknown key", s);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_LT(s.error_message().size(), kMaxMessage);
    EXPECT_NE(s.error_message().find("unknown key"), std::string::npos);
  }
  {
    // A 128-character id with characters outside the alphabet: quoted escaped.
    const grpc::Status s = Create(std::string(120, 'a') + "\n\x01\xff" + "bbbbb", config_);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_LT(s.error_message().size(), 300u);
  }
  healthy.Check();
}

// Class 4: bytes that are not the request message, or a camera_id that is
// not UTF-8 (proto3 strings must be): INVALID_ARGUMENT with the reason, for
// unary calls and streams; on a stream after answering the frames before it.
TEST_F(HostileInputTest, UnparsableRequestsAreInvalidArgumentWithAReason) {
  HealthyStream healthy(server_->channel(), jpeg_);
  grpc::Channel& channel = *server_->channel();
  std::string good_frame;
  ASSERT_TRUE(JpegRequest("cam", 7, jpeg_).SerializeToString(&good_frame));
  // camera_id "cam" -> three bytes that are not UTF-8 (same length, so the
  // message stays well-formed protobuf).
  std::string not_utf8 = good_frame;
  const size_t at = not_utf8.find("cam");
  ASSERT_NE(at, std::string::npos);
  not_utf8.replace(at, 3, "\xff\xfe\xfd");
  const std::string garbage = "\xff\xff\xff\xff not a protobuf message";

  for (const std::string& method :
       {std::string("/lane.v1.LaneService/Detect"), std::string("/lane.v1.LaneService/GetSession"),
        std::string("/lane.v1.LaneService/CreateSession")}) {
    const grpc::Status s = RawUnary(channel, method, garbage);
    Log((method + ", garbage").c_str(), s);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << method;
    EXPECT_NE(s.error_message().find("is not a valid lane.v1."), std::string::npos) << method;
    EXPECT_LT(s.error_message().size(), kMaxMessage);
  }
  const grpc::Status utf8 = RawUnary(channel, "/lane.v1.LaneService/Detect", not_utf8);
  Log("Detect, camera_id not UTF-8", utf8);
  EXPECT_EQ(utf8.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(utf8.error_message().find("UTF-8"), std::string::npos) << utf8.error_message();
  // A valid message through the same raw path still works.
  std::string answer;
  EXPECT_TRUE(RawUnary(channel, "/lane.v1.LaneService/Detect", good_frame, &answer).ok());
  v1::FrameResponse parsed;
  ASSERT_TRUE(parsed.ParseFromString(answer));
  EXPECT_EQ(parsed.status().code(), v1::FRAME_CODE_OK);
  EXPECT_GT(parsed.lanes_size(), 0);

  for (const std::string& bad : {garbage, not_utf8}) {
    const RawStreamResult r = RawStream(channel, {good_frame, good_frame, bad, good_frame});
    Log("stream, bad third message", r.status);
    EXPECT_EQ(r.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(r.status.error_message().find("is not a valid lane.v1.FrameRequest"),
              std::string::npos);
    // The two frames received before it are answered, in order.
    ASSERT_EQ(r.responses.size(), 2u);
    for (const std::string& bytes : r.responses) {
      v1::FrameResponse response;
      ASSERT_TRUE(response.ParseFromString(bytes));
      EXPECT_EQ(response.status().code(), v1::FRAME_CODE_OK);
      EXPECT_EQ(response.frame_id(), 7u);
    }
  }
  healthy.Check();
}

// Class 6: memory one client can make the server hold. Sessions share a
// budget; cameras whose raw frames cannot fit a message are refused.
TEST_F(HostileInputTest, SessionsShareAMemoryBudget) {
  ServerOptions options = TestServer::DefaultOptions();
  options.max_session_memory_bytes = uint64_t{64} << 20;
  options.max_receive_message_bytes = 16 << 20;
  Start(options);
  HealthyStream healthy(server_->channel(), jpeg_);
  v1::SessionConfig big = config_;
  big.mutable_ipm()->set_width(2048);
  big.mutable_ipm()->set_height(2048);
  const grpc::Status refused = Create("big", big);
  Log("CreateSession, 2048x2048 top view, 64 MiB budget", refused);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(refused.error_message().find("--max_session_memory_mib"), std::string::npos);
  // Sessions that fit go on being created until the budget is spent.
  v1::SessionConfig medium = config_;
  medium.mutable_ipm()->set_width(1024);
  medium.mutable_ipm()->set_height(1024);
  int created = 0;
  grpc::Status last;
  for (int i = 0; i < 10 && (last = Create("medium" + std::to_string(i), medium)).ok(); ++i) {
    ++created;
  }
  EXPECT_GE(created, 1);
  EXPECT_LT(created, 10);
  EXPECT_EQ(last.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  const uint64_t held = server_->server().sessions().memory_bytes();
  EXPECT_LE(held, options.max_session_memory_bytes);
  // Deleting a session gives its memory back.
  grpc::ClientContext context;
  v1::DeleteSessionRequest del;
  del.set_camera_id("medium0");
  v1::DeleteSessionResponse deleted;
  ASSERT_TRUE(server_->stub().DeleteSession(&context, del, &deleted).ok());
  EXPECT_LT(server_->server().sessions().memory_bytes(), held);
  EXPECT_TRUE(Create("medium-again", medium).ok());

  // A 3840x2160 camera's raw BGR frame (24.9 MB) cannot fit 16 MiB.
  v1::SessionConfig uhd = config_;
  uhd.mutable_camera()->set_image_width(3840);
  uhd.mutable_camera()->set_image_height(2160);
  const grpc::Status too_big = Create("uhd", uhd);
  Log("CreateSession, 3840x2160 camera, 16 MiB messages", too_big);
  EXPECT_EQ(too_big.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(too_big.error_message().find("--max_receive_message_bytes"), std::string::npos);
  healthy.Check();
}

// Class 7: a second server on a busy port fails at start (gRPC's default
// SO_REUSEPORT would let it start and split the connections).
TEST_F(HostileInputTest, BusyPortFailsAtStart) {
  ServerOptions second = TestServer::DefaultOptions();
  second.address = server_->target();
  const absl::StatusOr<std::unique_ptr<LaneServer>> started = LaneServer::Start(second, nullptr);
  ASSERT_FALSE(started.ok());
  std::cout << "[hostile] second server: " << started.status() << "\n";
  EXPECT_EQ(started.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_NE(started.status().message().find("in use"), std::string::npos);
  // The first one still serves.
  const StreamResult r = RunStream(server_->stub(), {JpegRequest("cam", 1, jpeg_)});
  ASSERT_EQ(r.responses.size(), 1u);
  EXPECT_EQ(r.responses[0].status().code(), v1::FRAME_CODE_OK);
}

}  // namespace
}  // namespace lane::server::testing
