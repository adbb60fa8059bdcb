// The fixture of the service's end-to-end tests (service_test.cc: frames and
// streams; service_session_test.cc: sessions, health, the default session):
// a real server on a loopback port, driven through the generated stub.
#ifndef LANE_TESTS_SERVER_SERVICE_TEST_FIXTURE_H_
#define LANE_TESTS_SERVER_SERVICE_TEST_FIXTURE_H_

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "test_util.h"

namespace lane::server::testing {

class ServiceTest : public ::testing::Test {
 protected:
  // Small frames keep the suite fast (and bearable under TSan).
  static constexpr double kScale = 0.5;

  void SetUp() override {
    camera_ = ScaledCamera(kScale);
    config_ = SessionConfigFor(camera_);
    jpeg_ = EncodeJpeg(RoadFrame(camera_, kLineOffsets, 1));
  }

  std::unique_ptr<TestServer> StartServer(ServerOptions options = TestServer::DefaultOptions()) {
    auto server = std::make_unique<TestServer>(options);
    if (::testing::Test::HasFailure()) return nullptr;
    return server;
  }

  lane::CameraModel camera_;
  v1::SessionConfig config_;
  std::string jpeg_;
};

}  // namespace lane::server::testing

#endif  // LANE_TESTS_SERVER_SERVICE_TEST_FIXTURE_H_
