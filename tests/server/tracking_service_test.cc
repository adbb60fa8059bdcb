// Video-aware sessions through a real server: a stream's lanes keep their
// ids, each camera's tracker is its own, the ego lane comes with the frames,
// and tracking follows the session's TrackingOptions.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

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

// --- Tracking across reconnects (resume state, docs/deployment.md) ---

// Frames [from, to) of one drive past kLineOffsets.
std::vector<v1::FrameRequest> Slice(const std::string& camera, const lane::CameraModel& model,
                                    int from, int to) {
  std::vector<v1::FrameRequest> all = Frames(camera, model, kLineOffsets, to);
  return {all.begin() + from, all.end()};
}

// The latest resume state of a stream's responses, and its largest lane id.
std::string LatestState(const StreamResult& result, int* max_id) {
  std::string state;
  for (const v1::FrameResponse& r : result.responses) {
    if (!r.resume_state().empty()) state = r.resume_state();
    for (const v1::Lane& lane : r.lanes()) *max_id = std::max(*max_id, lane.id());
  }
  return state;
}

// The key every "replica" of these tests shares (--resume_state_key_file).
std::string SharedKey() { return std::string(ResumeStateKeys::kMinKeyBytes, 'k'); }

ServerOptions ResumeOptions() {
  ServerOptions options = TestServer::DefaultOptions();
  options.resume_state_every = 5;
  options.resume_state_keys = ResumeStateKeys(SharedKey());
  return options;
}

// A resume stream's first answer: refused, naming `what`, with the frame
// itself processed.
void ExpectRefused(const StreamResult& r, const std::string& what) {
  ASSERT_TRUE(r.status.ok()) << what << ": " << r.status.error_message();
  ASSERT_FALSE(r.responses.empty()) << what;
  const v1::FrameResponse& answer = r.responses[0];
  EXPECT_EQ(answer.status().code(), v1::FRAME_CODE_OK) << what;
  EXPECT_EQ(answer.resume_status().code(), v1::FRAME_CODE_INVALID_ARGUMENT) << what;
  EXPECT_NE(answer.resume_status().message().find(what), std::string::npos)
      << what << ": " << answer.resume_status().message();
}

void DeleteSession(TestServer& server, const std::string& camera_id) {
  grpc::ClientContext context;
  v1::DeleteSessionRequest request;
  request.set_camera_id(camera_id);
  v1::DeleteSessionResponse deleted;
  ASSERT_TRUE(server.stub().DeleteSession(&context, request, &deleted).ok());
}

TEST(ResumeTest, AnotherReplicaGoesOnWithTheSameIds) {
  const lane::CameraModel model = ScaledCamera(0.5);
  TestServer a(ResumeOptions());
  a.CreateSession("cam", SessionConfigFor(model));
  const StreamResult first = RunStream(a.stub(), Slice("cam", model, 0, 12));
  ASSERT_TRUE(first.status.ok()) << first.status.error_message();
  // The first answer and every 5th carry the state; it stays small.
  ASSERT_EQ(first.responses.size(), 12u);
  for (size_t i = 0; i < first.responses.size(); ++i) {
    EXPECT_EQ(!first.responses[i].resume_state().empty(), i % 5 == 0) << "frame " << i;
    EXPECT_LT(first.responses[i].resume_state().size(), 1000u);
  }
  const std::set<int> ids = StableIds(first, 2);
  ASSERT_GE(ids.size(), 2u);
  int max_id = 0;
  const std::string state = LatestState(first, &max_id);
  ASSERT_FALSE(state.empty());

  // A replica that has never seen the camera: the stream's first request
  // carries the state; the lanes keep their ids and are confirmed at once.
  TestServer b(ResumeOptions());
  b.CreateSession("cam", SessionConfigFor(model));
  std::vector<v1::FrameRequest> resumed = Slice("cam", model, 12, 20);
  resumed[0].set_resume_state(state);
  resumed[0].set_min_lane_id(static_cast<uint32_t>(max_id) + 1);
  const StreamResult second = RunStream(b.stub(), resumed);
  ASSERT_TRUE(second.status.ok()) << second.status.error_message();
  ASSERT_EQ(second.responses.size(), resumed.size());
  EXPECT_TRUE(second.responses[0].has_resume_status());
  EXPECT_EQ(second.responses[0].resume_status().code(), v1::FRAME_CODE_OK)
      << second.responses[0].resume_status().message();
  EXPECT_FALSE(second.responses[1].has_resume_status());
  EXPECT_EQ(StableIds(second, 0), ids);
  EXPECT_EQ(MetricValue(b.registry(), "lanesvc_stream_resumes_total", {{"outcome", "restored"}}),
            1);
  EXPECT_GE(MetricValue(b.registry(), "lanesvc_resume_state_bytes"), 2);

  // Without the state (lost with the client), ids start above every id the
  // client saw: none is given to another lane.
  TestServer c(ResumeOptions());
  c.CreateSession("cam", SessionConfigFor(model));
  std::vector<v1::FrameRequest> fresh = Slice("cam", model, 12, 16);
  fresh[0].set_min_lane_id(static_cast<uint32_t>(max_id) + 1);
  const StreamResult third = RunStream(c.stub(), fresh);
  ASSERT_TRUE(third.status.ok());
  ASSERT_FALSE(third.responses[0].lanes().empty());
  for (const v1::Lane& lane : third.responses[0].lanes()) {
    EXPECT_GT(lane.id(), max_id);
    EXPECT_FALSE(lane.confirmed());
  }

  // Back on the first replica, whose tracker is ahead of that state: it
  // keeps its own.
  std::vector<v1::FrameRequest> back = Slice("cam", model, 12, 14);
  back[0].set_resume_state(state);
  const StreamResult fourth = RunStream(a.stub(), back);
  ASSERT_TRUE(fourth.status.ok());
  EXPECT_EQ(fourth.responses[0].resume_status().code(), v1::FRAME_CODE_OK);
  EXPECT_EQ(MetricValue(a.registry(), "lanesvc_stream_resumes_total", {{"outcome", "kept"}}), 1);
  EXPECT_EQ(StableIds(fourth, 0), ids);
}

// Resume states spoilt one way each, with what the refusal must name: not
// sealed, too long, altered, or sealed (as only a holder of the key could)
// around a TrackerState that breaks one rule. `sealed` is a real state, and
// `seal` holds the servers' key.
std::vector<std::pair<std::string, std::string>> SpoiltResumeStates(const std::string& sealed,
                                                                    const ResumeStateSeal& seal) {
  absl::StatusOr<OpenedResumeState> opened = seal.Open(sealed);
  EXPECT_TRUE(opened.ok()) << opened.status();
  if (!opened.ok()) return {};
  const ResumeBinding binding = opened->binding;
  v1::TrackerState good;
  EXPECT_TRUE(good.ParseFromString(opened->tracker_state));
  EXPECT_FALSE(good.tracks().empty());
  if (good.tracks().empty()) return {};
  auto sealed_as = [&](const v1::TrackerState& state) {
    return seal.Seal(binding, state.SerializeAsString());
  };

  std::vector<std::pair<std::string, std::string>> cases;  // (bytes, what the error names)
  cases.emplace_back("\xff\xff\xff garbage", "not a sealed state");
  cases.emplace_back(good.SerializeAsString(), "not a sealed state");  // unsealed
  cases.emplace_back(std::string(5000, '\0'), "more than 4096");
  cases.emplace_back(seal.Seal(binding, "\xff\xff\xff garbage"), "not a lane.v1.TrackerState");
  std::string flipped = sealed;
  flipped.back() = static_cast<char>(flipped.back() ^ 1);
  cases.emplace_back(flipped, "tag");
  v1::TrackerState s = good;
  s.set_version(7);
  cases.emplace_back(sealed_as(s), "version");
  s = good;
  s.mutable_tracks(0)->set_curve(0, std::numeric_limits<float>::quiet_NaN());
  cases.emplace_back(sealed_as(s), "curve");
  s = good;
  s.mutable_tracks(0)->set_covariance(0, -1.0f);
  cases.emplace_back(sealed_as(s), "covariance");
  s = good;
  s.mutable_tracks(0)->set_id(s.next_id());
  cases.emplace_back(sealed_as(s), "id");
  s = good;
  s.mutable_tracks(0)->mutable_votes()->RemoveLast();
  cases.emplace_back(sealed_as(s), "vote values");
  s = good;
  for (int i = 0; i < 40; ++i) *s.add_tracks() = good.tracks(0);
  cases.emplace_back(sealed_as(s), "tracks");
  s = good;
  s.mutable_tracks(0)->set_since_hit_frames(s.tracks(0).age_frames() + 1);
  cases.emplace_back(sealed_as(s), "age");

  return cases;
}

TEST(ResumeTest, BadStatesAreRefusedAndTheFramesGoOn) {
  const lane::CameraModel model = ScaledCamera(0.5);
  TestServer server(ResumeOptions());
  server.CreateSession("cam", SessionConfigFor(model));
  // A real state to spoil.
  const StreamResult first = RunStream(server.stub(), Slice("cam", model, 0, 4));
  ASSERT_TRUE(first.status.ok());
  int max_id = 0;
  const std::string sealed = LatestState(first, &max_id);
  // A state is opened only with the servers' key; sealing spoilt states
  // with it, as only a holder of the key could, reaches the checks behind.
  const ResumeStateSeal seal{ResumeStateKeys(SharedKey())};
  const std::vector<std::pair<std::string, std::string>> cases = SpoiltResumeStates(sealed, seal);
  ASSERT_FALSE(cases.empty());

  uint32_t min_id = static_cast<uint32_t>(max_id) + 1;
  for (const auto& [bytes, names] : cases) {
    std::vector<v1::FrameRequest> requests = Slice("cam", model, 4, 7);
    requests[0].set_resume_state(bytes);
    requests[0].set_min_lane_id(min_id);
    const StreamResult r = RunStream(server.stub(), requests);
    ASSERT_TRUE(r.status.ok()) << names << ": " << r.status.error_message();
    ASSERT_EQ(r.responses.size(), 3u) << names;
    const v1::FrameResponse& answer = r.responses[0];
    EXPECT_EQ(answer.status().code(), v1::FRAME_CODE_OK) << names;
    EXPECT_EQ(answer.resume_status().code(), v1::FRAME_CODE_INVALID_ARGUMENT) << names;
    EXPECT_NE(answer.resume_status().message().find(names), std::string::npos)
        << names << ": " << answer.resume_status().message();
    // A fresh tracker: new ids from min_lane_id on, unconfirmed.
    ASSERT_FALSE(answer.lanes().empty()) << names;
    for (const v1::Lane& lane : answer.lanes()) {
      EXPECT_GE(lane.id(), static_cast<int>(min_id)) << names;
      EXPECT_FALSE(lane.confirmed()) << names;
      min_id = std::max(min_id, static_cast<uint32_t>(lane.id()) + 1);
    }
    for (const v1::FrameResponse& later : r.responses) {
      for (const v1::Lane& lane : later.lanes()) {
        min_id = std::max(min_id, static_cast<uint32_t>(lane.id()) + 1);
      }
    }
  }
  EXPECT_EQ(
      MetricValue(server.registry(), "lanesvc_stream_resumes_total", {{"outcome", "refused"}}),
      static_cast<double>(cases.size()));
  // A state on a later request is ignored, with a word why.
  std::vector<v1::FrameRequest> late = Slice("cam", model, 7, 9);
  late[1].set_resume_state(sealed);
  const StreamResult r = RunStream(server.stub(), late);
  ASSERT_TRUE(r.status.ok());
  EXPECT_EQ(r.responses[1].status().code(), v1::FRAME_CODE_OK);
  EXPECT_EQ(r.responses[1].resume_status().code(), v1::FRAME_CODE_INVALID_ARGUMENT);
}

// Issue 47: another camera's state is refused, and the camera reports none
// of that camera's lanes: on frames without markings it reports none.
TEST(ResumeTest, AStateBelongsToItsCamera) {
  const lane::CameraModel model = ScaledCamera(0.5);
  TestServer server(ResumeOptions());
  server.CreateSession("front", SessionConfigFor(model));
  server.CreateSession("side", SessionConfigFor(model));
  const StreamResult front = RunStream(server.stub(), Slice("front", model, 0, 12));
  ASSERT_TRUE(front.status.ok());
  int max_id = 0;
  const std::string state = LatestState(front, &max_id);
  ASSERT_FALSE(state.empty());
  ASSERT_GE(max_id, 2);

  // Frames 12-15 of a road without markings, right after the state's time.
  const std::vector<v1::FrameRequest> all_bare = Frames("side", model, {}, 16);
  std::vector<v1::FrameRequest> bare(all_bare.begin() + 12, all_bare.end());
  bare[0].set_resume_state(state);
  const StreamResult side = RunStream(server.stub(), bare);
  ExpectRefused(side, "camera");
  for (const v1::FrameResponse& r : side.responses) {
    EXPECT_EQ(r.status().code(), v1::FRAME_CODE_OK);
    EXPECT_EQ(r.lanes_size(), 0) << "frame " << r.frame_id() << " reports another camera's lanes";
  }
  EXPECT_EQ(
      MetricValue(server.registry(), "lanesvc_stream_resumes_total", {{"outcome", "refused"}}), 1);
}

// Issue 47: a state is refused by the same camera under another config, by
// a session deleted and created again with the same config (a new epoch),
// and by a replica that does not hold its key; a rotated key still opens it.
TEST(ResumeTest, AStateBelongsToItsConfigEpochAndKey) {
  const lane::CameraModel model = ScaledCamera(0.5);
  TestServer a(ResumeOptions());
  a.CreateSession("cam", SessionConfigFor(model));
  const StreamResult first = RunStream(a.stub(), Slice("cam", model, 0, 12));
  ASSERT_TRUE(first.status.ok());
  int max_id = 0;
  const std::string state = LatestState(first, &max_id);
  ASSERT_FALSE(state.empty());
  auto resumed = [&](const std::string& bytes) {
    std::vector<v1::FrameRequest> requests = Slice("cam", model, 12, 14);
    requests[0].set_resume_state(bytes);
    return requests;
  };

  // Another replica with another camera geometry under the same id.
  TestServer other_config(ResumeOptions());
  other_config.CreateSession("cam", SessionConfigFor(ScaledCamera(0.5, 15.0)));
  ExpectRefused(RunStream(other_config.stub(), resumed(state)), "config");

  // Another replica without the shared key (a random key of its own).
  TestServer no_key;
  no_key.CreateSession("cam", SessionConfigFor(model));
  ExpectRefused(RunStream(no_key.stub(), resumed(state)), "key");

  // A replica whose key was rotated since: the old key is the previous one.
  ServerOptions rotated_options = ResumeOptions();
  rotated_options.resume_state_keys =
      ResumeStateKeys(std::string(ResumeStateKeys::kMinKeyBytes, 'n'), SharedKey());
  TestServer rotated(rotated_options);
  rotated.CreateSession("cam", SessionConfigFor(model));
  const StreamResult after_rotation = RunStream(rotated.stub(), resumed(state));
  ASSERT_TRUE(after_rotation.status.ok());
  EXPECT_EQ(after_rotation.responses[0].resume_status().code(), v1::FRAME_CODE_OK)
      << after_rotation.responses[0].resume_status().message();
  EXPECT_EQ(
      MetricValue(rotated.registry(), "lanesvc_stream_resumes_total", {{"outcome", "restored"}}),
      1);

  // The same replica, after the session was deleted and created again with
  // the very same config: a new epoch.
  DeleteSession(a, "cam");
  a.CreateSession("cam", SessionConfigFor(model));
  const StreamResult recreated = RunStream(a.stub(), resumed(state));
  ExpectRefused(recreated, "epoch");
  for (const v1::Lane& lane : recreated.responses[0].lanes()) EXPECT_FALSE(lane.confirmed());
  // Replaced by a stream's first request: both the config and the epoch
  // changed; the config is named.
  v1::SessionConfig moved = SessionConfigFor(ScaledCamera(0.5, 15.0));
  std::vector<v1::FrameRequest> replacing = resumed(state);
  *replacing[0].mutable_session_config() = moved;
  replacing[0].set_replace_session(true);
  ExpectRefused(RunStream(a.stub(), replacing), "config");
}

TEST(ResumeTest, AStreamOlderThanMaxConnectionAgeAnswersEverythingAndEnds) {
  const lane::CameraModel model = ScaledCamera(0.5);
  ServerOptions options = ResumeOptions();
  options.max_connection_age = absl::Milliseconds(400);
  options.max_connection_age_grace = absl::Seconds(5);
  TestServer server(options);
  server.CreateSession("cam", SessionConfigFor(model));
  const std::vector<v1::FrameRequest> requests = Slice("cam", model, 0, 60);
  grpc::ClientContext context;
  auto stream = server.stub().StreamFrames(&context);
  std::thread writer([&] {
    for (const v1::FrameRequest& r : requests) {
      if (!stream->Write(r)) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    stream->WritesDone();
  });
  std::vector<v1::FrameResponse> responses;
  v1::FrameResponse response;
  while (stream->Read(&response)) responses.push_back(response);
  writer.join();
  const grpc::Status status = stream->Finish();
  // Ended by its age (360-400 ms: about 18-20 frames at 20 ms), not by the
  // client. The server's status names the reason, unless the transport
  // reports first: the connection got its GOAWAY at about the same age, and
  // gRPC closes it as soon as its last stream ends, while this client is
  // still writing, so the client's next write may fail ("Broken pipe",
  // "Socket closed") before it reads the trailers. Both are UNAVAILABLE and
  // mean the same to a client: reconnect. (Seen 2 in 60 runs under ASan.)
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
  const std::string& why = status.error_message();
  const bool by_age = why.find("max_connection_age") != std::string::npos;
  const bool by_transport = why.find("Broken pipe") != std::string::npos ||
                            why.find("Socket closed") != std::string::npos ||
                            why.find("Connection reset") != std::string::npos;
  EXPECT_TRUE(by_age || by_transport) << why;
  ASSERT_GE(responses.size(), 5u);
  ASSERT_LT(responses.size(), requests.size());
  // Every frame it read was answered, in order, the last with the state.
  for (size_t i = 0; i < responses.size(); ++i) {
    EXPECT_EQ(responses[i].frame_id(), requests[i].frame_id());
    EXPECT_EQ(responses[i].status().code(), v1::FRAME_CODE_OK);
  }
  EXPECT_FALSE(responses.back().resume_state().empty());
  EXPECT_EQ(MetricValue(server.registry(), "lanesvc_frames_received_total"),
            static_cast<double>(responses.size()));
}

}  // namespace
}  // namespace lane::server::testing
