// End-to-end tests of lane.v1.LaneService's sessions: create (idempotent,
// replace, refused), get, list, delete, the cap and the TTL, health and
// reflection, the default session from a config file. A real server on a
// loopback port, driven through the generated stub.
#include <gtest/gtest.h>

#include <string>

#include "service_test_fixture.h"
#include "test_util.h"

namespace lane::server::testing {
namespace {

TEST_F(ServiceTest, GetServerInfo) {
  auto server = StartServer();
  ASSERT_NE(server, nullptr);
  grpc::ClientContext context;
  v1::ServerInfo info;
  ASSERT_TRUE(server->stub().GetServerInfo(&context, {}, &info).ok());
  EXPECT_FALSE(info.version().empty());
  EXPECT_NE(info.build().find("gRPC"), std::string::npos);
  EXPECT_EQ(info.encoded_formats_size(), 2);
  EXPECT_EQ(info.raw_formats_size(), 3);
  EXPECT_GE(info.limits().max_receive_message_bytes(), 1920u * 1080 * 3);
  EXPECT_EQ(info.limits().workers(), 2u);
  EXPECT_EQ(info.limits().max_sessions(), 64u);
  EXPECT_EQ(info.default_config_all().detector().mode(), v1::MODE_ALL);
  EXPECT_EQ(info.default_config_two().detector().mode(), v1::MODE_TWO);
  EXPECT_EQ(info.default_config_all().camera().image_width(), 640);
  EXPECT_TRUE(info.default_config_all().detector().threshold().has_quantile());
}

// One unary call each, on a context of its own.
struct CreateAnswer {
  grpc::Status status;
  v1::CreateSessionResponse response;
};
CreateAnswer CallCreateSession(v1::LaneService::Stub& stub,
                               const v1::CreateSessionRequest& request) {
  grpc::ClientContext context;
  CreateAnswer answer;
  answer.status = stub.CreateSession(&context, request, &answer.response);
  return answer;
}
struct GetAnswer {
  grpc::Status status;
  v1::Session session;
};
GetAnswer CallGetSession(v1::LaneService::Stub& stub, const std::string& camera_id) {
  grpc::ClientContext context;
  v1::GetSessionRequest get;
  get.set_camera_id(camera_id);
  GetAnswer answer;
  answer.status = stub.GetSession(&context, get, &answer.session);
  return answer;
}
grpc::Status CallDeleteSession(v1::LaneService::Stub& stub, const std::string& camera_id) {
  grpc::ClientContext context;
  v1::DeleteSessionRequest del;
  del.set_camera_id(camera_id);
  v1::DeleteSessionResponse response;
  return stub.DeleteSession(&context, del, &response);
}

TEST_F(ServiceTest, SessionLifecycle) {
  auto server = StartServer();
  ASSERT_NE(server, nullptr);
  v1::LaneService::Stub& stub = server->stub();

  v1::CreateSessionRequest create;
  create.set_camera_id("cam-a");
  *create.mutable_config() = config_;
  const CreateAnswer created = CallCreateSession(stub, create);
  ASSERT_TRUE(created.status.ok());
  EXPECT_EQ(created.response.outcome(), v1::CREATE_OUTCOME_CREATED);
  EXPECT_EQ(created.response.session().camera_id(), "cam-a");
  EXPECT_EQ(created.response.session().config().camera().image_width(), camera_.image_width);
  const uint64_t v1_version = created.response.session().version();
  EXPECT_GT(v1_version, 0u);

  // The same config again: a reconnecting client is fine.
  const CreateAnswer again = CallCreateSession(stub, create);
  ASSERT_TRUE(again.status.ok());
  EXPECT_EQ(again.response.outcome(), v1::CREATE_OUTCOME_UNCHANGED);
  EXPECT_EQ(again.response.session().version(), v1_version);
  // The resolved config sent back is the same config too.
  v1::CreateSessionRequest resolved = create;
  *resolved.mutable_config() = created.response.session().config();
  const CreateAnswer resolved_again = CallCreateSession(stub, resolved);
  ASSERT_TRUE(resolved_again.status.ok());
  EXPECT_EQ(resolved_again.response.outcome(), v1::CREATE_OUTCOME_UNCHANGED);
  // A different calibration: ALREADY_EXISTS, unless replace.
  v1::CreateSessionRequest changed = create;
  changed.mutable_config()->mutable_camera()->set_pitch_deg(15.0);
  EXPECT_EQ(CallCreateSession(stub, changed).status.error_code(), grpc::StatusCode::ALREADY_EXISTS);
  changed.set_replace(true);
  const CreateAnswer replaced = CallCreateSession(stub, changed);
  ASSERT_TRUE(replaced.status.ok());
  EXPECT_EQ(replaced.response.outcome(), v1::CREATE_OUTCOME_REPLACED);
  const uint64_t v2_version = replaced.response.session().version();
  EXPECT_GT(v2_version, v1_version);
  // Get.
  const GetAnswer got = CallGetSession(stub, "cam-a");
  ASSERT_TRUE(got.status.ok());
  EXPECT_EQ(got.session.version(), v2_version);
  EXPECT_DOUBLE_EQ(got.session.config().camera().pitch_deg(), 15.0);
  // List, sorted by camera id.
  server->CreateSession("cam-0", config_);
  {
    grpc::ClientContext context;
    v1::ListSessionsResponse list;
    ASSERT_TRUE(stub.ListSessions(&context, {}, &list).ok());
    ASSERT_EQ(list.sessions_size(), 2);
    EXPECT_EQ(list.sessions(0).camera_id(), "cam-0");
    EXPECT_EQ(list.sessions(1).camera_id(), "cam-a");
  }
  EXPECT_EQ(MetricValue(server->registry(), "lanesvc_sessions_active"), 2);
  // Delete, then it is gone.
  ASSERT_TRUE(CallDeleteSession(stub, "cam-a").ok());
  EXPECT_EQ(CallDeleteSession(stub, "cam-a").error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(CallGetSession(stub, "cam-a").status.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(MetricValue(server->registry(), "lanesvc_sessions_active"), 1);
  EXPECT_EQ(MetricValue(server->registry(), "grpc_server_handled_total",
                        {{"grpc_method", "CreateSession"}, {"grpc_code", "ALREADY_EXISTS"}}),
            1);
  EXPECT_EQ(MetricValue(server->registry(), "grpc_server_handled_total",
                        {{"grpc_method", "GetSession"}, {"grpc_code", "NOT_FOUND"}}),
            1);
}

TEST_F(ServiceTest, CreateSessionRejectsBadInput) {
  auto server = StartServer();
  ASSERT_NE(server, nullptr);
  auto create = [&](const std::string& id, const v1::SessionConfig& config) {
    grpc::ClientContext context;
    v1::CreateSessionRequest request;
    request.set_camera_id(id);
    *request.mutable_config() = config;
    v1::CreateSessionResponse response;
    return server->stub().CreateSession(&context, request, &response);
  };
  EXPECT_EQ(create("", config_).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(create("bad id", config_).error_code(), grpc::StatusCode::INVALID_ARGUMENT);

  v1::SessionConfig bad = config_;
  bad.mutable_camera()->set_image_width(0);
  EXPECT_EQ(create("cam", bad).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  bad = config_;
  bad.mutable_detector()->mutable_threshold()->set_quantile(1.5);
  EXPECT_EQ(create("cam", bad).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  bad = config_;
  bad.mutable_detector()->set_mode(static_cast<v1::Mode>(42));
  EXPECT_EQ(create("cam", bad).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  bad = config_;
  bad.set_config_json("{}");  // and the structured fields: one or the other
  EXPECT_EQ(create("cam", bad).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  v1::SessionConfig json;
  json.set_config_json("{\"camera\": {\"pitch_deg\": oops}}");
  EXPECT_EQ(create("cam", json).error_code(), grpc::StatusCode::INVALID_ARGUMENT);

  // A JSON document alone is fine.
  json.set_config_json("{\"detector\": {\"mode\": \"two\"}}");
  grpc::ClientContext context;
  v1::CreateSessionRequest request;
  request.set_camera_id("json-cam");
  *request.mutable_config() = json;
  v1::CreateSessionResponse response;
  ASSERT_TRUE(server->stub().CreateSession(&context, request, &response).ok());
  EXPECT_EQ(response.session().config().detector().mode(), v1::MODE_TWO);
  EXPECT_TRUE(response.session().config().config_json().empty());
}

TEST_F(ServiceTest, SessionCap) {
  ServerOptions options = TestServer::DefaultOptions();
  options.max_sessions = 2;
  auto server = StartServer(options);
  ASSERT_NE(server, nullptr);
  server->CreateSession("a", config_);
  server->CreateSession("b", config_);
  auto create = [&](const std::string& id, bool replace) {
    grpc::ClientContext context;
    v1::CreateSessionRequest request;
    request.set_camera_id(id);
    *request.mutable_config() = config_;
    request.mutable_config()->mutable_camera()->set_pitch_deg(13);
    request.set_replace(replace);
    v1::CreateSessionResponse response;
    return server->stub().CreateSession(&context, request, &response);
  };
  EXPECT_EQ(create("c", false).error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  // Replacing an existing session is not a new one.
  EXPECT_TRUE(create("b", true).ok());
  // A stream that brings its own config hits the same cap.
  v1::FrameRequest first = JpegRequest("c", 0, jpeg_);
  *first.mutable_session_config() = config_;
  StreamResult result = RunStream(server->stub(), {first});
  EXPECT_EQ(result.status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED)
      << result.status.error_message();
  EXPECT_TRUE(result.responses.empty());
}

TEST_F(ServiceTest, TtlEvictsIdleSessions) {
  ServerOptions options = TestServer::DefaultOptions();
  options.session_ttl = absl::Milliseconds(300);
  auto server = StartServer(options);
  ASSERT_NE(server, nullptr);
  server->CreateSession("idle", config_);
  // ListSessions does not count as use (GetSession would).
  auto count = [&] {
    grpc::ClientContext context;
    v1::ListSessionsResponse list;
    EXPECT_TRUE(server->stub().ListSessions(&context, {}, &list).ok());
    return list.sessions_size();
  };
  EXPECT_TRUE(PollUntil([&] { return count() == 0; }, 30.0));
  EXPECT_EQ(MetricValue(server->registry(), "lanesvc_sessions_active"), 0);
  // Its frames now fail: there is no session any more.
  StreamResult result = RunStream(server->stub(), {JpegRequest("idle", 0, jpeg_)});
  EXPECT_EQ(result.status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
}

TEST_F(ServiceTest, HealthAndReflection) {
  auto server = StartServer();
  ASSERT_NE(server, nullptr);
  EXPECT_EQ(HealthStatus(server->channel()), 1);  // SERVING
  EXPECT_TRUE(ReflectionListsLaneService(server->channel()));
}

TEST_F(ServiceTest, DefaultSessionFromConfigFile) {
  ServerOptions options = TestServer::DefaultOptions();
  options.default_config_path = std::string(LANE_SOURCE_DIR) + "/configs/synthetic.json";
  options.default_camera_id = "default";
  auto server = StartServer(options);
  ASSERT_NE(server, nullptr);
  grpc::ClientContext context;
  v1::GetSessionRequest get;
  get.set_camera_id("default");
  v1::Session session;
  ASSERT_TRUE(server->stub().GetSession(&context, get, &session).ok());
  EXPECT_EQ(session.config().camera().image_width(), 640);
  const cv::Mat frame = RoadFrame(ScaledCamera(1.0), kLineOffsets);
  grpc::ClientContext detect_context;
  v1::FrameResponse response;
  ASSERT_TRUE(server->stub()
                  .Detect(&detect_context, JpegRequest("default", 1, EncodeJpeg(frame)), &response)
                  .ok());

  // A missing file stops the start.
  options.default_config_path = "/nonexistent/config.json";
  EXPECT_FALSE(LaneServer::Start(options, nullptr).ok());
}

}  // namespace
}  // namespace lane::server::testing
