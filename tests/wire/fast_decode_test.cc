// The fast path of issue 14: encoded frames decoded only in the rows and
// channel the session's detector reads (Detector::Needs, DecodeFrame with
// needs) must give the lanes of the whole frame, within 1 px. The pixels of
// the rows decoded are byte-identical to the whole decode's, so the lanes are
// identical. On synthetic
// frames always, and on ../shared/data's clips when they are present.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "lane/config/config.h"
#include "lane/detector/detector.h"
#include "lane/synthetic.h"
#include "road_frames.h"
#include "shared_data.h"
#include "wire/frame_decoder.h"

namespace lane::wire {
namespace {

namespace fs = std::filesystem;

Config ShippedConfig(const std::string& name) {
  absl::StatusOr<Config> config = LoadConfigFile(std::string(LANE_SOURCE_DIR) + "/configs/" + name);
  EXPECT_TRUE(config.ok()) << config.status();
  return config.ok() ? *config : Config{};
}

Detector MakeDetector(const Config& config) {
  absl::StatusOr<Detector> detector = Detector::Create(config.camera, config.ipm, config.detector);
  EXPECT_TRUE(detector.ok()) << detector.status();
  return *std::move(detector);
}

// The largest distance between corresponding control points of the two
// detections' image splines; infinity when they found different numbers.
double LaneDifferencePx(const Detection& a, const Detection& b) {
  if (a.lanes.size() != b.lanes.size()) return INFINITY;
  double worst = 0;
  for (size_t i = 0; i < a.lanes.size(); ++i) {
    for (int k = 0; k < 4; ++k) {
      worst = std::max(worst, (a.lanes[i].image[k] - b.lanes[i].image[k]).norm());
    }
  }
  return worst;
}

struct Comparison {
  int frames = 0;
  int lanes = 0;
  int identical = 0;    // frames whose lanes are byte-identical
  double worst_px = 0;  // over all frames
};

// Detects every encoded frame decoded whole and decoded for the detector.
Comparison CompareFastAndFull(const Detector& detector, const Config& config,
                              const std::vector<std::string>& encoded) {
  DecodeOptions options;
  options.width = config.camera.image_width;
  options.height = config.camera.image_height;
  Comparison out;
  for (const std::string& bytes : encoded) {
    v1::FrameRequest request;
    request.set_encoded(bytes);
    const absl::StatusOr<cv::Mat> full = DecodeFrame(request, options);
    const absl::StatusOr<cv::Mat> fast = DecodeFrame(request, options, &detector.Needs());
    EXPECT_TRUE(full.ok() && fast.ok()) << full.status() << " " << fast.status();
    if (!full.ok() || !fast.ok()) continue;
    EXPECT_EQ(fast->size(), full->size());
    const absl::StatusOr<Detection> a = detector.Detect(*full);
    const absl::StatusOr<Detection> b = detector.Detect(*fast);
    EXPECT_TRUE(a.ok() && b.ok());
    if (!a.ok() || !b.ok()) continue;
    ++out.frames;
    out.lanes += static_cast<int>(a->lanes.size());
    const double d = LaneDifferencePx(*a, *b);
    out.worst_px = std::max(out.worst_px, d);
    out.identical += d == 0;
  }
  return out;
}

std::vector<std::string> SyntheticJpegs(const CameraModel& camera, int count) {
  std::vector<std::string> out;
  for (int i = 0; i < count; ++i) {
    absl::StatusOr<SyntheticFrame> frame =
        RenderSyntheticFrame(camera, SyntheticOptions{}, 500 + i);
    EXPECT_TRUE(frame.ok());
    if (frame.ok()) out.push_back(lane::testing::EncodeJpeg(frame->bgr, 90));
  }
  return out;
}

using lane::testing::FindSharedClip;

std::vector<std::string> ReadFiles(const std::string& dir, const std::string& ext) {
  std::vector<std::string> paths;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == ext) paths.push_back(e.path().string());
  }
  std::sort(paths.begin(), paths.end());
  std::vector<std::string> out;
  for (const std::string& p : paths) {
    std::ifstream in(p, std::ios::binary);
    out.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return out;
}

TEST(FastDecodeTest, NeedsCoverTheTopViewAndFollowTheConfig) {
  const Config caltech = ShippedConfig("caltech.json");
  const Detector detector = MakeDetector(caltech);
  const FrameNeeds& needs = detector.Needs();
  EXPECT_LE(needs.top, detector.ipm().roi().top);
  EXPECT_GE(needs.bottom, detector.ipm().roi().bottom);
  EXPECT_GT(needs.top, 0) << "the sky above the horizon is never read";
  EXPECT_LT(needs.bottom, caltech.camera.image_height) << "nor the hood below the extension";
  // The colour check reads red and green: BGR.
  EXPECT_EQ(needs.pixels, FrameNeeds::Pixels::kBgr);

  Config red = caltech;
  red.detector.postprocess.max_redness = 1;  // colour check off: red alone
  EXPECT_EQ(MakeDetector(red).Needs().pixels, FrameNeeds::Pixels::kRed);
  Config grey = red;
  grey.detector.channel = Channel::kGray;  // grey is computed from the colour
  EXPECT_EQ(MakeDetector(grey).Needs().pixels, FrameNeeds::Pixels::kBgr);
  Config green = red;
  green.detector.channel = Channel::kGreen;  // no decoder gives green alone
  EXPECT_EQ(MakeDetector(green).Needs().pixels, FrameNeeds::Pixels::kBgr);
}

TEST(FastDecodeTest, RowsOutsideTheNeedsAreNeverRead) {
  const Config config = ShippedConfig("caltech.json");
  const Detector detector = MakeDetector(config);
  const FrameNeeds& needs = detector.Needs();
  int lanes = 0;
  for (int seed = 0; seed < 12; ++seed) {
    absl::StatusOr<SyntheticFrame> frame =
        RenderSyntheticFrame(config.camera, SyntheticOptions{}, 700 + seed);
    ASSERT_TRUE(frame.ok());
    cv::Mat scrambled = frame->bgr.clone();
    cv::randu(scrambled.rowRange(0, needs.top), 0, 256);
    cv::randu(scrambled.rowRange(needs.bottom, scrambled.rows), 0, 256);
    const absl::StatusOr<Detection> a = detector.Detect(frame->bgr);
    const absl::StatusOr<Detection> b = detector.Detect(scrambled);
    ASSERT_TRUE(a.ok() && b.ok());
    lanes += static_cast<int>(a->lanes.size());
    EXPECT_EQ(LaneDifferencePx(*a, *b), 0.0) << "frame " << seed;
  }
  EXPECT_GT(lanes, 24) << "the frames must have lanes to compare";
}

TEST(FastDecodeTest, SyntheticFramesGiveTheSameLanes) {
  const Config config = ShippedConfig("caltech.json");
  const Detector detector = MakeDetector(config);
  const Comparison c = CompareFastAndFull(detector, config, SyntheticJpegs(config.camera, 16));
  std::printf("[fast-decode] synthetic BGR: %d frames, %d lanes, %d identical, worst %.3f px\n",
              c.frames, c.lanes, c.identical, c.worst_px);
  EXPECT_EQ(c.frames, 16);
  EXPECT_GT(c.lanes, 30);
  // BGR rows are byte-identical to the whole decode's: so are the lanes.
  EXPECT_EQ(c.identical, c.frames);
}

TEST(FastDecodeTest, RedAloneGivesTheSameLanes) {
  // Channel red without the colour check: the fast path decodes the red
  // channel of the rows alone, the R of the whole decode's pixels.
  Config config = ShippedConfig("caltech.json");
  config.detector.postprocess.max_redness = 1;
  const Detector detector = MakeDetector(config);
  ASSERT_EQ(detector.Needs().pixels, FrameNeeds::Pixels::kRed);
  const Comparison c = CompareFastAndFull(detector, config, SyntheticJpegs(config.camera, 16));
  std::printf("[fast-decode] synthetic red: %d frames, %d lanes, %d identical, worst %.3f px\n",
              c.frames, c.lanes, c.identical, c.worst_px);
  EXPECT_EQ(c.frames, 16);
  EXPECT_GT(c.lanes, 30);
  EXPECT_EQ(c.identical, c.frames);
}

TEST(FastDecodeTest, DevClipGivesTheSameLanes) {
  const std::string dir = FindSharedClip("culane-driver161-a");
  if (dir.empty()) GTEST_SKIP() << "../shared/data/culane-driver161-a not present: skipped";
  const Config config = ShippedConfig("culane-driver161.json");
  const Detector detector = MakeDetector(config);
  const Comparison c = CompareFastAndFull(detector, config, ReadFiles(dir, ".jpg"));
  std::printf("[fast-decode] driver161: %d frames, %d lanes, %d identical, worst %.3f px\n",
              c.frames, c.lanes, c.identical, c.worst_px);
  EXPECT_EQ(c.frames, 60);
  EXPECT_GT(c.lanes, 60);
  EXPECT_LE(c.worst_px, 1.0);

  // Red alone (colour check off), against red of the whole frame.
  Config red = config;
  red.detector.channel = Channel::kRed;
  red.detector.postprocess.max_redness = 1;
  const Detector red_detector = MakeDetector(red);
  const Comparison r = CompareFastAndFull(red_detector, red, ReadFiles(dir, ".jpg"));
  std::printf("[fast-decode] driver161 red: %d frames, %d lanes, %d identical, worst %.3f px\n",
              r.frames, r.lanes, r.identical, r.worst_px);
  EXPECT_EQ(r.identical, r.frames);
}

TEST(FastDecodeTest, CordovaPngsGiveTheSameLanes) {
  const std::string dir = FindSharedClip("caltech-cordova1");
  if (dir.empty()) GTEST_SKIP() << "../shared/data/caltech-cordova1 not present: skipped";
  const Config config = ShippedConfig("caltech.json");
  const Detector detector = MakeDetector(config);
  std::vector<std::string> frames = ReadFiles(dir, ".png");
  std::vector<std::string> every_fifth;
  for (size_t i = 0; i < frames.size(); i += 5) every_fifth.push_back(std::move(frames[i]));
  const Comparison c = CompareFastAndFull(detector, config, every_fifth);
  std::printf("[fast-decode] cordova1: %d frames, %d lanes, %d identical, worst %.3f px\n",
              c.frames, c.lanes, c.identical, c.worst_px);
  EXPECT_EQ(c.frames, static_cast<int>(every_fifth.size()));
  EXPECT_EQ(c.identical, c.frames);
}

}  // namespace
}  // namespace lane::wire
