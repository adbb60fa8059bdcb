// Video-aware sessions through a real server: a stream's lanes keep their
// ids, each camera's tracker is its own, the ego lane comes with the frames,
// and tracking follows the session's TrackingOptions.
#include <gtest/gtest.h>

#include <set>
#include <thread>

#include "test_util.h"

namespace lane::server::testing {
namespace {

std::vector<v1::FrameRequest> Frames(const std::string& camera, const lane::CameraModel& model,
                                     const std::vector<double>& offsets, int n) {
  std::vector<v1::FrameRequest> requests;
  for (int i = 0; i < n; ++i) {
    v1::FrameRequest r = JpegRequest(camera, i, EncodeJpeg(RoadFrame(model, offsets, i + 1)));
    r.set_capture_time_unix_ns(int64_t{1'700'000'000'000'000'000} + i * int64_t{33'333'333});
    requests.push_back(std::move(r));
  }
  return requests;
}

// The ids of a stream's frames from frame `from` on, which must be the same
// set in every one of them.
std::set<int> StableIds(const StreamResult& result, size_t from) {
  std::set<int> first;
  for (size_t f = from; f < result.responses.size(); ++f) {
    const v1::FrameResponse& r = result.responses[f];
    EXPECT_EQ(r.status().code(), v1::FRAME_CODE_OK);
    std::set<int> ids;
    for (const v1::Lane& lane : r.lanes()) {
      EXPECT_GT(lane.id(), 0);
      EXPECT_TRUE(lane.confirmed()) << "frame " << f;
      ids.insert(lane.id());
    }
    if (f == from) first = ids;
    EXPECT_EQ(ids, first) << "frame " << f << ": ids changed";
  }
  return first;
}

TEST(TrackingServiceTest, StreamsKeepIdsAndCamerasTrackIndependently) {
  TestServer server;
  ASSERT_FALSE(HasFailure());
  const lane::CameraModel model = ScaledCamera(0.5);
  server.CreateSession("front", SessionConfigFor(model));
  server.CreateSession("side", SessionConfigFor(model));
  constexpr int kFrames = 20;
  // The second camera sees the road 0.9 m further left.
  const std::vector<double> shifted = {-4.5, -0.9, 2.7, 6.3};
  StreamResult front, side;
  std::thread a(
      [&] { front = RunStream(server.stub(), Frames("front", model, kLineOffsets, kFrames)); });
  std::thread b([&] { side = RunStream(server.stub(), Frames("side", model, shifted, kFrames)); });
  a.join();
  b.join();
  ASSERT_TRUE(front.status.ok()) << front.status.error_message();
  ASSERT_TRUE(side.status.ok()) << side.status.error_message();
  ASSERT_EQ(front.responses.size(), static_cast<size_t>(kFrames));
  ASSERT_EQ(side.responses.size(), static_cast<size_t>(kFrames));

  // Confirmed from the third frame; the same ids to the end.
  for (const v1::Lane& lane : front.responses[0].lanes()) EXPECT_FALSE(lane.confirmed());
  const std::set<int> front_ids = StableIds(front, 2);
  const std::set<int> side_ids = StableIds(side, 2);
  EXPECT_GE(front_ids.size(), 2u);
  // Independent trackers: each numbers its own lanes from 1.
  EXPECT_EQ(*front_ids.begin(), 1);
  EXPECT_EQ(*side_ids.begin(), 1);

  // The ego lane: the lines at -1.8 and +1.8 m, the camera in the middle;
  // the second camera is 0.9 m left of its lane's centre (offset is right +).
  const v1::FrameResponse& last = front.responses.back();
  ASSERT_TRUE(last.has_ego());
  EXPECT_NEAR(last.ego().width_m(), 3.6, 0.25);
  EXPECT_NEAR(last.ego().offset_m(), 0.0, 0.15);
  EXPECT_FALSE(last.ego().departing());
  EXPECT_TRUE(front_ids.count(last.ego().left_lane_id()));
  EXPECT_TRUE(front_ids.count(last.ego().right_lane_id()));
  ASSERT_TRUE(side.responses.back().has_ego());
  EXPECT_NEAR(side.responses.back().ego().offset_m(), -0.9, 0.15);
  // White paint on grey.
  for (const v1::Lane& lane : last.lanes()) {
    EXPECT_EQ(lane.color(), v1::MARKING_COLOR_WHITE) << "lane " << lane.id();
  }
}

TEST(TrackingServiceTest, TrackingFollowsTheSessionOptions) {
  TestServer server;
  ASSERT_FALSE(HasFailure());
  const lane::CameraModel model = ScaledCamera(0.5);
  v1::SessionConfig off = SessionConfigFor(model);
  off.mutable_tracking()->set_disabled(true);
  server.CreateSession("off", off);
  v1::SessionConfig unary = SessionConfigFor(model);
  unary.mutable_tracking()->set_unary(true);
  server.CreateSession("unary", unary);
  server.CreateSession("default", SessionConfigFor(model));

  // Disabled: no ids, no ego, in a stream.
  const StreamResult result = RunStream(server.stub(), Frames("off", model, kLineOffsets, 4));
  ASSERT_TRUE(result.status.ok());
  for (const v1::FrameResponse& r : result.responses) {
    EXPECT_FALSE(r.has_ego());
    for (const v1::Lane& lane : r.lanes()) EXPECT_EQ(lane.id(), 0);
  }
  // Unary Detect: untracked by default, tracked when the session asks.
  auto detect = [&](const std::string& camera, int i) {
    grpc::ClientContext context;
    v1::FrameResponse response;
    const v1::FrameRequest request =
        Frames(camera, model, kLineOffsets, i + 1)[static_cast<size_t>(i)];
    EXPECT_TRUE(server.stub().Detect(&context, request, &response).ok());
    return response;
  };
  for (int i = 0; i < 4; ++i) {
    const v1::FrameResponse plain = detect("default", i);
    ASSERT_FALSE(plain.lanes().empty());
    EXPECT_EQ(plain.lanes(0).id(), 0);
    EXPECT_FALSE(plain.has_ego());
    const v1::FrameResponse tracked = detect("unary", i);
    ASSERT_FALSE(tracked.lanes().empty());
    EXPECT_GT(tracked.lanes(0).id(), 0);
    EXPECT_EQ(tracked.lanes(0).confirmed(), i >= 2);
  }
  // Replacing the session resets its tracker: ids start again from 1.
  unary.mutable_camera()->set_pitch_deg(unary.camera().pitch_deg() + 0.01);
  grpc::ClientContext context;
  v1::CreateSessionRequest request;
  request.set_camera_id("unary");
  *request.mutable_config() = unary;
  request.set_replace(true);
  v1::CreateSessionResponse created;
  ASSERT_TRUE(server.stub().CreateSession(&context, request, &created).ok());
  const v1::FrameResponse again = detect("unary", 0);
  ASSERT_FALSE(again.lanes().empty());
  EXPECT_EQ(again.lanes(0).id(), 1);
}

}  // namespace
}  // namespace lane::server::testing
