// Security of the service: Bearer tokens (checked once, in
// LaneServiceImpl::Admission), an open health service, TLS and mutual TLS
// with a test CA made at test time by openssl.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "auth.h"
#include "test_ca.h"
#include "test_util.h"

namespace lane::server::testing {
namespace {

constexpr char kGoodToken[] = "good-token-0123456789";
constexpr char kOtherToken[] = "second-token";

grpc::Status GetInfo(v1::LaneService::Stub& stub, const std::string& authorization) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  if (!authorization.empty()) context.AddMetadata("authorization", authorization);
  v1::ServerInfo info;
  return stub.GetServerInfo(&context, v1::GetServerInfoRequest(), &info);
}

grpc::Status List(v1::LaneService::Stub& stub, const std::string& authorization,
                  std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + timeout);
  if (!authorization.empty()) context.AddMetadata("authorization", authorization);
  v1::ListSessionsResponse response;
  return stub.ListSessions(&context, v1::ListSessionsRequest(), &response);
}

grpc::Status Stream(v1::LaneService::Stub& stub, const std::string& authorization) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  if (!authorization.empty()) context.AddMetadata("authorization", authorization);
  auto stream = stub.StreamFrames(&context);
  stream->WritesDone();
  v1::FrameResponse response;
  while (stream->Read(&response)) {
  }
  return stream->Finish();
}

ServerOptions TokenOptions() {
  ServerOptions options = TestServer::DefaultOptions();
  options.auth_tokens = {kGoodToken, kOtherToken};
  return options;
}

TEST(AuthTest, ConstantTimeEquals) {
  EXPECT_TRUE(ConstantTimeEquals("", ""));
  EXPECT_TRUE(ConstantTimeEquals("abc", "abc"));
  EXPECT_FALSE(ConstantTimeEquals("abc", "abd"));
  EXPECT_FALSE(ConstantTimeEquals("abc", "abcd"));
  EXPECT_FALSE(ConstantTimeEquals("abcd", "abc"));
  EXPECT_FALSE(ConstantTimeEquals("", "a"));
}

TEST(AuthTest, TokenFileAndList) {
  const std::string path = ::testing::TempDir() + "/lane_tokens.txt";
  {
    std::ofstream out(path);
    out << "# fleet tokens\n  alpha  \n\nbeta\n";
  }
  absl::StatusOr<std::vector<std::string>> tokens = ReadTokenFile(path);
  ASSERT_TRUE(tokens.ok()) << tokens.status();
  EXPECT_EQ(*tokens, (std::vector<std::string>{"alpha", "beta"}));
  EXPECT_FALSE(ReadTokenFile(path + ".missing").ok());
  EXPECT_EQ(ParseTokenList(" a, ,b,"), (std::vector<std::string>{"a", "b"}));
  std::filesystem::remove(path);
}

TEST(AuthTest, GoodTokenIsAccepted) {
  TestServer server(TokenOptions());
  const std::string bearer = std::string("Bearer ") + kGoodToken;
  EXPECT_TRUE(GetInfo(server.stub(), bearer).ok());
  EXPECT_TRUE(List(server.stub(), bearer).ok());
  EXPECT_TRUE(List(server.stub(), std::string("Bearer ") + kOtherToken).ok());
  EXPECT_TRUE(Stream(server.stub(), bearer).ok());
}

TEST(AuthTest, WrongTokenIsUnauthenticated) {
  TestServer server(TokenOptions());
  for (const std::string& value :
       {std::string("Bearer wrong"), std::string("Bearer ") + kGoodToken + "x",
        std::string("Bearer good-token"), std::string(kGoodToken),
        std::string("Basic ") + kGoodToken}) {
    SCOPED_TRACE(value);
    EXPECT_EQ(GetInfo(server.stub(), value).error_code(), grpc::StatusCode::UNAUTHENTICATED);
    EXPECT_EQ(List(server.stub(), value).error_code(), grpc::StatusCode::UNAUTHENTICATED);
    EXPECT_EQ(Stream(server.stub(), value).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  }
}

TEST(AuthTest, NoTokenIsUnauthenticatedAndNeverEchoesTokens) {
  TestServer server(TokenOptions());
  const grpc::Status status = List(server.stub(), "");
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(status.error_message().find(kGoodToken), std::string::npos);
  EXPECT_EQ(GetInfo(server.stub(), "").error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(Stream(server.stub(), "").error_code(), grpc::StatusCode::UNAUTHENTICATED);
  grpc::ClientContext context;
  v1::FrameResponse response;
  EXPECT_EQ(server.stub().Detect(&context, JpegRequest("default", 1, "x"), &response).error_code(),
            grpc::StatusCode::UNAUTHENTICATED);
}

TEST(AuthTest, HealthNeedsNoToken) {
  TestServer server(TokenOptions());
  EXPECT_EQ(HealthStatus(server.channel()), 1);
}

TEST(AuthTest, WithoutTokensEveryCallIsOpen) {
  TestServer server;
  EXPECT_TRUE(List(server.stub(), "").ok());
  EXPECT_TRUE(List(server.stub(), "Bearer anything").ok());
}

// Holds one StreamFrames call open on `stub` (one frame answered, so the
// HTTP/2 stream is live) until Close().
class OpenStream {
 public:
  OpenStream(v1::LaneService::Stub& stub, const v1::FrameRequest& frame) {
    context_.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    stream_ = stub.StreamFrames(&context_);
    ok_ = stream_->Write(frame);
    v1::FrameResponse response;
    ok_ = ok_ && stream_->Read(&response) && response.status().code() == v1::FRAME_CODE_OK;
  }
  bool ok() const { return ok_; }
  grpc::Status Close() {
    stream_->WritesDone();
    v1::FrameResponse response;
    while (stream_->Read(&response)) {
    }
    return stream_->Finish();
  }

 private:
  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReaderWriter<v1::FrameRequest, v1::FrameResponse>> stream_;
  bool ok_ = false;
};

// A stub on a connection of its own (a private subchannel pool: channels to
// the same target otherwise share one connection).
std::unique_ptr<v1::LaneService::Stub> StubOnItsOwnConnection(const std::string& target) {
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  return v1::LaneService::NewStub(
      grpc::CreateCustomChannel(target, grpc::InsecureChannelCredentials(), args));
}

// --max_concurrent_streams=1: while one stream is open on a connection, a
// second call on that connection waits (HTTP/2 SETTINGS_MAX_CONCURRENT_STREAMS,
// enforced by the client's transport); another connection is served; the
// waiting call goes through once the stream ends. Without the limit the
// second call is served at once.
TEST(LimitsTest, MaxConcurrentStreamsHoldsPerConnection) {
  const lane::CameraModel camera = ScaledCamera(0.5);
  const v1::FrameRequest frame = JpegRequest("cam", 1, EncodeJpeg(RoadFrame(camera, kLineOffsets)));
  {
    TestServer unlimited;
    unlimited.CreateSession("cam", SessionConfigFor(camera));
    OpenStream open(unlimited.stub(), frame);
    ASSERT_TRUE(open.ok());
    EXPECT_TRUE(List(unlimited.stub(), "").ok());
    EXPECT_TRUE(open.Close().ok());
  }
  ServerOptions options = TestServer::DefaultOptions();
  options.max_concurrent_streams = 1;
  TestServer server(options);
  server.CreateSession("cam", SessionConfigFor(camera));
  OpenStream open(server.stub(), frame);
  ASSERT_TRUE(open.ok());
  EXPECT_EQ(List(server.stub(), "", std::chrono::milliseconds(1500)).error_code(),
            grpc::StatusCode::DEADLINE_EXCEEDED)
      << "a second call on the connection was served while the limit was taken";
  auto other = StubOnItsOwnConnection(server.target());
  EXPECT_TRUE(List(*other, "").ok());
  // A call that waits is served as soon as the open stream ends.
  grpc::Status waited;
  std::thread waiter([&] { waited = List(server.stub(), "", std::chrono::seconds(20)); });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_TRUE(open.Close().ok());
  waiter.join();
  EXPECT_TRUE(waited.ok()) << waited.error_message();
}

// TLS against a test CA (tests/common/test_ca.h), made once for the suite.
class TlsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { ca_ = new lane::testing::TestCa(); }
  static void TearDownTestSuite() {
    delete ca_;
    ca_ = nullptr;
  }
  void SetUp() override {
    if (!ca_->ok()) GTEST_SKIP() << "no test CA, TLS tests skipped: " << ca_->error();
  }

  static std::string Path(const std::string& name) { return ca_->Path(name); }
  static std::string Read(const std::string& name) { return ca_->Read(name); }

  ServerOptions TlsOptions(bool mutual) {
    ServerOptions options = TestServer::DefaultOptions();
    options.tls_cert_path = Path("server.crt");
    options.tls_key_path = Path("server.key");
    if (mutual) options.tls_client_ca_path = Path("ca.crt");
    return options;
  }

  std::unique_ptr<v1::LaneService::Stub> TlsStub(TestServer& server, bool client_cert) {
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = Read("ca.crt");
    if (client_cert) {
      ssl.pem_cert_chain = Read("client.crt");
      ssl.pem_private_key = Read("client.key");
    }
    channel_ = grpc::CreateChannel(server.target(), grpc::SslCredentials(ssl));
    return v1::LaneService::NewStub(channel_);
  }

  std::shared_ptr<grpc::Channel> channel_;
  static lane::testing::TestCa* ca_;
};

lane::testing::TestCa* TlsTest::ca_ = nullptr;

TEST_F(TlsTest, ClientWithTheCaSucceeds) {
  TestServer server(TlsOptions(false));
  auto stub = TlsStub(server, false);
  EXPECT_TRUE(List(*stub, "").ok());
  EXPECT_EQ(HealthStatus(channel_), 1);
}

TEST_F(TlsTest, PlaintextClientFails) {
  TestServer server(TlsOptions(false));
  // server.stub() is a plaintext channel.
  const grpc::Status status = List(server.stub(), "");
  EXPECT_FALSE(status.ok());
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
}

TEST_F(TlsTest, TlsWithTokens) {
  ServerOptions options = TlsOptions(false);
  options.auth_tokens = {kGoodToken};
  TestServer server(options);
  auto stub = TlsStub(server, false);
  EXPECT_TRUE(List(*stub, std::string("Bearer ") + kGoodToken).ok());
  EXPECT_EQ(List(*stub, "").error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(HealthStatus(channel_), 1);
}

TEST_F(TlsTest, MutualTlsNeedsAClientCertificate) {
  TestServer server(TlsOptions(true));
  {
    auto stub = TlsStub(server, false);
    EXPECT_EQ(List(*stub, "").error_code(), grpc::StatusCode::UNAVAILABLE);
  }
  auto stub = TlsStub(server, true);
  EXPECT_TRUE(List(*stub, "").ok());
}

TEST_F(TlsTest, BadTlsOptionsFailAtStart) {
  ServerOptions options = TestServer::DefaultOptions();
  options.tls_cert_path = Path("server.crt");
  EXPECT_FALSE(LaneServer::Start(options, nullptr).ok());
  options.tls_key_path = Path("missing.key");
  EXPECT_FALSE(LaneServer::Start(options, nullptr).ok());
  options = TestServer::DefaultOptions();
  options.tls_client_ca_path = Path("ca.crt");
  EXPECT_FALSE(LaneServer::Start(options, nullptr).ok());
}

}  // namespace
}  // namespace lane::server::testing
