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
#include <vector>

#include "auth.h"
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

grpc::Status List(v1::LaneService::Stub& stub, const std::string& authorization) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
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

TEST(LimitsTest, MaxConcurrentStreamsServes) {
  ServerOptions options = TestServer::DefaultOptions();
  options.max_concurrent_streams = 1;
  TestServer server(options);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(List(server.stub(), "").ok());
}

// A CA, a server certificate for 127.0.0.1/localhost and a client
// certificate, made by openssl in a temporary directory.
class TlsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (std::system("openssl version > /dev/null 2>&1") != 0) return;
    char pattern[] = "/tmp/lane_tls_XXXXXX";
    if (mkdtemp(pattern) == nullptr) return;
    dir_ = new std::string(pattern);
    const std::string d = *dir_;
    const std::string key = " -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes";
    const std::string script =
        "cd '" + d + "' && " + "openssl req -x509" + key +
        " -keyout ca.key -out ca.crt -days 2 -subj /CN=lane-test-ca && " + "openssl req" + key +
        " -keyout server.key -out server.csr -subj /CN=localhost && " +
        "printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\\n' > server.ext && " +
        "openssl x509 -req -in server.csr -CA ca.crt -CAkey ca.key -CAcreateserial"
        " -out server.crt -days 2 -extfile server.ext && " +
        "openssl req" + key + " -keyout client.key -out client.csr -subj /CN=lane-test-client && " +
        "openssl x509 -req -in client.csr -CA ca.crt -CAkey ca.key -CAcreateserial"
        " -out client.crt -days 2";
    ok_ = std::system(("(" + script + ") > /dev/null 2>&1").c_str()) == 0;
  }
  static void TearDownTestSuite() {
    if (dir_ != nullptr) std::filesystem::remove_all(*dir_);
    delete dir_;
    dir_ = nullptr;
  }
  void SetUp() override {
    if (dir_ == nullptr || !ok_) GTEST_SKIP() << "openssl is missing or failed: TLS tests skipped";
  }

  static std::string Path(const std::string& name) { return *dir_ + "/" + name; }
  static std::string Read(const std::string& name) {
    std::ifstream in(Path(name));
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  }

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
  static std::string* dir_;
  static bool ok_;
};

std::string* TlsTest::dir_ = nullptr;
bool TlsTest::ok_ = false;

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
