// Structure fixed to the camera gets no vote in `lane calibrate`
// (lane/calibrate/static_structure.h): a fixed pattern against a marking
// that weaves, a reflection in rendered frames, the card on the dashboard
// of the CULane dev clip when ../shared/data holds it, and the static mask
// in the top view.
#include "lane/calibrate/static_structure.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "lane/calibrate/calibration.h"
#include "lane/calibrate/vanishing_point.h"
#include "lane/geometry/ipm.h"
#include "lane/synthetic.h"
#include "shared_data.h"
#include "test_cameras.h"

namespace lane {
namespace {

// An upright segment from (u, top) to (u, bottom).
ImageSegment Upright(double u, double top, double bottom) {
  ImageSegment s;
  s.centre = {u, 0.5 * (top + bottom)};
  s.direction = {0, -1};
  s.length = bottom - top;
  s.top_row = top;
  s.bottom_row = bottom;
  return s;
}

// Frames of moving asphalt texture with two bright bars 4 px wide: one at
// the same pixels in every frame (a sticker, rows 80-179) and one that
// weaves by up to `weave_px` and whose paint texture moves along it (a solid
// line through the whole frame).
std::vector<cv::Mat> BarFrames(int n, double weave_px) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> weave(-weave_px, weave_px);
  std::vector<cv::Mat> frames;
  for (int i = 0; i < n; ++i) {
    cv::Mat f(240, 320, CV_8UC1);
    cv::randn(f, 100, 12);  // new texture every frame: the road moved
    cv::GaussianBlur(f, f, cv::Size(3, 3), 0);
    cv::rectangle(f, cv::Rect(100, 80, 4, 100), cv::Scalar(200), cv::FILLED);
    const int u = 220 + static_cast<int>(std::lround(weave(rng)));
    for (int v = 0; v < f.rows; ++v) {
      const int paint = 190 + static_cast<int>(15 * std::sin(0.4 * v + 1.3 * i));
      cv::line(f, {u, v}, {u + 3, v}, cv::Scalar(paint));
    }
    frames.push_back(f);
  }
  return frames;
}

TEST(StaticStructureTest, AFixedBarIsStaticAWeavingOneIsNot) {
  StaticStructureFinder finder;
  for (const cv::Mat& f : BarFrames(30, 3.0)) finder.Add(f);
  const StaticStructure s = finder.Finish();
  ASSERT_FALSE(s.mask.empty());
  EXPECT_TRUE(s.Covers(Upright(101.5, 85, 175)));
  EXPECT_FALSE(s.Covers(Upright(221.5, 85, 175)));
  ASSERT_EQ(s.boxes.size(), 1u);
  EXPECT_LE(s.boxes[0].left, 100);
  EXPECT_GE(s.boxes[0].right, 103);
  EXPECT_GT(s.boxes[0].left, 90);
  EXPECT_LT(s.boxes[0].right, 115);
  // The boxes a detector reading rows 0..50 or 190..239 could see: none.
  EXPECT_TRUE(s.BoxesInRows(0, 50).empty());
  EXPECT_EQ(s.BoxesInRows(100, 239).size(), 1u);
  std::vector<ImageSegment> segments = {Upright(221.5, 85, 175), Upright(101.5, 85, 175)};
  const std::vector<ImageSegment> taken = s.TakeCovered(segments);
  ASSERT_EQ(taken.size(), 1u);
  EXPECT_DOUBLE_EQ(taken[0].centre.x(), 101.5);
  ASSERT_EQ(segments.size(), 1u);
  EXPECT_DOUBLE_EQ(segments[0].centre.x(), 221.5);
}

TEST(StaticStructureTest, NothingIsStaticFromTooFewFramesOrWhenOff) {
  StaticStructureFinder few;
  for (const cv::Mat& f : BarFrames(StaticStructureOptions().min_frames - 1, 3.0)) few.Add(f);
  EXPECT_TRUE(few.Finish().mask.empty());
  StaticStructureOptions off;
  off.enabled = false;
  StaticStructureFinder disabled(off);
  for (const cv::Mat& f : BarFrames(30, 3.0)) disabled.Add(f);
  const StaticStructure s = disabled.Finish();
  EXPECT_TRUE(s.mask.empty());
  EXPECT_FALSE(s.Covers(Upright(101.5, 85, 175)));
  EXPECT_TRUE(StaticStructureOptions().Validate().ok());
  StaticStructureOptions bad;
  bad.min_presence = 0;
  EXPECT_FALSE(bad.Validate().ok());
}

// Where SyntheticOptions::static_overlay draws its card.
cv::Rect2d OverlayBox(const CameraModel& c) {
  return {0.66 * c.image_width - 2, 0.64 * c.image_height - 2, 0.22 * c.image_width + 4,
          0.09 * c.image_height + 4};
}

struct RenderedCalibration {
  absl::StatusOr<CalibrationResult> result;
  FirstPassReport first_pass;
};

RenderedCalibration Calibrate(const std::vector<cv::Mat>& frames, const CameraModel& camera,
                              bool static_structure) {
  CalibrationOptions o;
  o.height_m = camera.height_m;
  o.focal_px = camera.fu;
  o.static_structure.enabled = static_structure;
  CameraCalibrator calibrator(o);
  for (const cv::Mat& f : frames) EXPECT_TRUE(calibrator.AddFirstPass(f).ok());
  if (absl::Status s = calibrator.FinishFirstPass(); !s.ok()) return {s, {}};
  for (const cv::Mat& f : frames) EXPECT_TRUE(calibrator.AddSecondPass(f).ok());
  return {calibrator.Finish(), calibrator.first_pass()};
}

// A card's barcode reflected in the windscreen, the same in every frame,
// whose bars meet 140 px above and 180 px beside the road's vanishing
// point: it leads the first pass astray (the estimate is refused, or
// wrong) unless it is recognised as fixed to the camera.
TEST(StaticStructureTest, AReflectionFixedToTheCameraGetsNoVote) {
  const CameraModel camera = testing::TestCamera(8.0, 1.0, 1.5);
  SyntheticOptions so;
  so.max_heading_rad = 0.005;
  so.static_overlay = true;
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 30; ++i) {
    absl::StatusOr<SyntheticFrame> f = RenderSyntheticFrame(camera, so, 100 + i);
    ASSERT_TRUE(f.ok()) << f.status();
    frames.push_back(f->bgr);
  }
  const Eigen::Vector2d truth = camera.VanishingPoint();
  const cv::Rect2d card = OverlayBox(camera);

  const RenderedCalibration without = Calibrate(frames, camera, false);
  EXPECT_TRUE(!without.result.ok() ||
              (without.result->vanishing_point.point - truth).norm() > 20.0);
  EXPECT_GT((without.first_pass.point - truth).norm(), 20.0);

  const RenderedCalibration with = Calibrate(frames, camera, true);
  ASSERT_TRUE(with.result.ok()) << with.result.status();
  EXPECT_LT((with.result->vanishing_point.point - truth).norm(), 3.0)
      << with.result->vanishing_point.point.transpose();
  EXPECT_GE(with.result->vanishing_point.frames_used, 10);
  EXPECT_LT((with.first_pass.point - truth).norm(), 6.0);
  // The card's segments were left out, and only they: the markings keep
  // their votes (a marking segment is left out only where it crosses the
  // card).
  EXPECT_GE(with.first_pass.static_segments.size(), frames.size());
  const cv::Rect2d around(card.x - 8, card.y - 8, card.width + 16, card.height + 16);
  for (const auto& [frame, s] : with.first_pass.static_segments) {
    EXPECT_TRUE(around.contains({s.centre.x(), s.centre.y()}))
        << "frame " << frame << ": " << s.centre.transpose();
  }
  // The config's mask: one rectangle around the card's bars.
  ASSERT_EQ(with.result->static_mask.size(), 1u);
  const Roi& box = with.result->static_mask[0];
  EXPECT_TRUE(around.contains({box.left, box.top}) && around.contains({box.right, box.bottom}))
      << box.left << ".." << box.right << ", " << box.top << ".." << box.bottom;
  EXPECT_GT(box.right - box.left, 0.8 * card.width);
  EXPECT_GT(box.bottom - box.top, 0.6 * card.height);
}

// A rendered drive (3 lanes; solid yellow and white lines at its edges,
// which stay near the same image position while the car keeps its lane):
// nothing on the road is static.
TEST(StaticStructureTest, SolidLinesOfARenderedDriveKeepTheirVotes) {
  const CameraModel camera = testing::TestCamera(8.0, 1.0, 1.5);
  SyntheticDriveOptions drive;
  drive.count = 30;
  std::vector<cv::Mat> frames;
  for (int i = 0; i < drive.count; ++i) {
    absl::StatusOr<SyntheticFrame> f = RenderSyntheticDriveFrame(camera, drive, 11, i);
    ASSERT_TRUE(f.ok()) << f.status();
    frames.push_back(f->bgr);
  }
  const RenderedCalibration r = Calibrate(frames, camera, true);
  ASSERT_TRUE(r.result.ok()) << r.result.status();
  const double horizon = camera.HorizonRow();
  for (const auto& [frame, s] : r.first_pass.static_segments) {
    EXPECT_LT(s.bottom_row, horizon + 10) << "frame " << frame << ": " << s.centre.transpose();
  }
  EXPECT_TRUE(r.result->static_mask.empty());
  // The estimate is the one without the test.
  const RenderedCalibration plain = Calibrate(frames, camera, false);
  ASSERT_TRUE(plain.result.ok()) << plain.result.status();
  EXPECT_LT((r.result->vanishing_point.point - plain.result->vanishing_point.point).norm(), 1e-9);
  EXPECT_EQ(r.result->vanishing_point.frames_used, plain.result->vanishing_point.frames_used);
}

// The CULane dev clip: a card on the dashboard, reflected in the windscreen
// at u 1199-1323, v 339-372 in every frame, gives 17-21 px upright bars on
// rows 355-430 that vote for their own point (on the clip's sibling they
// outvote the markings). Every segment of the first pass inside it is
// static, so none of them votes.
TEST(StaticStructureTest, CulaneDashboardCardGetsNoVote) {
  const std::string dir = testing::FindSharedClip("culane-driver161-a");
  if (dir.empty()) GTEST_SKIP() << "../shared/data/culane-driver161-a is absent";
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().extension() == ".jpg") files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  CalibrationOptions o;
  o.height_m = 1.3;
  o.focal_px = 1000.0;
  CameraCalibrator calibrator(o);
  std::vector<cv::Mat> paints;
  for (const std::string& path : files) {
    const cv::Mat frame = cv::imread(path, cv::IMREAD_COLOR);
    ASSERT_FALSE(frame.empty()) << path;
    ASSERT_TRUE(calibrator.AddFirstPass(frame).ok());
    paints.push_back(PaintChannel(frame));
  }
  ASSERT_TRUE(calibrator.FinishFirstPass().ok());
  const StaticStructure& fixed = calibrator.first_pass().static_structure;
  // The card's strokes: steep segments centred on it.
  const cv::Rect2d card(1199, 339, 1323 - 1199, 372 - 339);
  const auto in_card = [&](const ImageSegment& s) {
    return card.contains(cv::Point2d(s.centre.x(), s.centre.y())) &&
           std::abs(s.direction.y()) > std::sin(M_PI / 4);
  };
  // The first pass's segments, as it finds them, inside the card.
  MarkingSegmentOptions first;
  first.top_row = static_cast<int>(0.6 * paints[0].rows);
  first.fixed_widths_px = FixedBarWidths(paints[0].cols);
  int found = 0, voting = 0;
  for (const cv::Mat& paint : paints) {
    for (const ImageSegment& s : FindMarkingSegments(paint, first)) {
      if (!in_card(s)) continue;
      ++found;
      if (!fixed.Covers(s)) ++voting;
    }
  }
  EXPECT_GT(found, 60);
  EXPECT_EQ(voting, 0) << "of " << found << " segments of the card";
  int left_out = 0;
  for (const auto& [frame, s] : calibrator.first_pass().static_segments) left_out += in_card(s);
  EXPECT_GT(left_out, 60);
  // ... and the markings still find the road's vanishing point.
  EXPECT_LT((calibrator.first_pass().point - Eigen::Vector2d(753.9, 384.2)).norm(), 6.0);
}

// The mask in the top view: pixels whose image point lies in a rectangle
// are invalid (no cost per frame: decided when the mapping is built).
TEST(StaticStructureTest, MaskedImagePixelsAreInvalidInTheTopView) {
  const CameraModel camera = testing::TestCamera(8.0, 0.0, 1.5);
  IpmOptions o;
  o.view = IpmView::kGround;
  o.ground = {-6, 6, 5, 15, 0.0625, 0.125};
  for (const Interpolation interpolation : {Interpolation::kBilinear, Interpolation::kArea}) {
    o.interpolation = interpolation;
    o.static_mask.clear();
    const absl::StatusOr<IpmMapping> plain = IpmMapping::Create(camera, o);
    ASSERT_TRUE(plain.ok()) << plain.status();
    const Roi box{400, 480, 250, 280};
    o.static_mask = {box};
    const absl::StatusOr<IpmMapping> masked = IpmMapping::Create(camera, o);
    ASSERT_TRUE(masked.ok()) << masked.status();
    int now_invalid = 0;
    for (int r = 0; r < masked->height(); ++r) {
      for (int c = 0; c < masked->width(); ++c) {
        const Eigen::Vector2d img = masked->IpmToImage(Eigen::Vector2d(c, r));
        const bool inside = img.x() >= box.left && img.x() <= box.right && img.y() >= box.top &&
                            img.y() <= box.bottom;
        const bool was = plain->valid_mask().at<uint8_t>(r, c) != 0;
        const bool is = masked->valid_mask().at<uint8_t>(r, c) != 0;
        ASSERT_EQ(is, was && !inside) << "top-view pixel " << c << ", " << r;
        now_invalid += was && !is;
      }
    }
    EXPECT_GT(now_invalid, 100);
    EXPECT_EQ(masked->invalid_pixels().size(), plain->invalid_pixels().size() + now_invalid);
  }
  o.static_mask = {Roi{10, 5, 0, 1}};
  EXPECT_FALSE(o.Validate().ok());
  o.static_mask.assign(kMaxStaticMaskBoxes + 1, Roi{0, 1, 0, 1});
  EXPECT_FALSE(o.Validate().ok());
}

}  // namespace
}  // namespace lane
