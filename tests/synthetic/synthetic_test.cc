#include "lane/synthetic.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <utility>
#include <vector>

#include "lane/eval/render_labels.h"
#include "lane/geometry/bezier.h"
#include "lane/geometry/camera.h"
#include "test_cameras.h"

namespace {

using lane::Bezier;
using lane::CameraModel;
using lane::RenderSyntheticFrame;
using lane::SyntheticFrame;
using lane::SyntheticOptions;

CameraModel CaltechCamera() { return CameraModel{}; }

using ::lane::testing::CulaneCamera;
using ::lane::testing::CulaneNightConfig;

SyntheticFrame Render(const CameraModel& cam, const SyntheticOptions& opt, uint64_t seed) {
  auto frame = RenderSyntheticFrame(cam, opt, seed);
  EXPECT_TRUE(frame.ok()) << frame.status();
  return frame.ok() ? *std::move(frame) : SyntheticFrame{};
}

bool SameTruth(const SyntheticFrame& a, const SyntheticFrame& b) {
  if (a.boundaries.size() != b.boundaries.size()) return false;
  if (a.ego_left != b.ego_left || a.ego_right != b.ego_right) return false;
  for (size_t i = 0; i < a.boundaries.size(); ++i) {
    const auto& x = a.boundaries[i];
    const auto& y = b.boundaries[i];
    if (x.dashed != y.dashed || x.yellow != y.yellow || x.lateral_offset_m != y.lateral_offset_m) {
      return false;
    }
    for (int k = 0; k < 4; ++k) {
      if (x.image[k] != y.image[k]) return false;
    }
  }
  return true;
}

bool SameBytes(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  return cv::countNonZero(diff.reshape(1)) == 0;
}

// Red channel with bilinear interpolation; NaN outside the image.
double Red(const cv::Mat& bgr, const Eigen::Vector2d& p) {
  const double u = p.x(), v = p.y();
  if (!(u >= 0 && v >= 0 && u <= bgr.cols - 1 && v <= bgr.rows - 1)) return std::nan("");
  const int u0 = std::min(static_cast<int>(u), bgr.cols - 2 < 0 ? 0 : bgr.cols - 2);
  const int v0 = std::min(static_cast<int>(v), bgr.rows - 2 < 0 ? 0 : bgr.rows - 2);
  const double fu = u - u0, fv = v - v0;
  auto at = [&](int r, int c) { return static_cast<double>(bgr.at<cv::Vec3b>(r, c)[2]); };
  return (1 - fv) * ((1 - fu) * at(v0, u0) + fu * at(v0, u0 + 1)) +
         fv * ((1 - fu) * at(v0 + 1, u0) + fu * at(v0 + 1, u0 + 1));
}

TEST(SyntheticTest, SameSeedIsDeterministic) {
  const SyntheticOptions opt;
  for (const CameraModel& cam : {CaltechCamera(), CulaneCamera()}) {
    const SyntheticFrame a = Render(cam, opt, 1234);
    const SyntheticFrame b = Render(cam, opt, 1234);
    EXPECT_TRUE(SameBytes(a.bgr, b.bgr));
    EXPECT_TRUE(SameTruth(a, b));
    EXPECT_EQ(lane::eval::RenderLabelsJson("x.png", a), lane::eval::RenderLabelsJson("x.png", b));
  }
}

TEST(SyntheticTest, DifferentSeedsGiveDifferentRoads) {
  const SyntheticOptions opt;
  const CameraModel cam = CaltechCamera();
  const SyntheticFrame a = Render(cam, opt, 1);
  const SyntheticFrame b = Render(cam, opt, 2);
  EXPECT_FALSE(SameTruth(a, b));
  cv::Mat diff;
  cv::absdiff(a.bgr, b.bgr, diff);
  const cv::Scalar mean = cv::mean(diff);
  EXPECT_GT((mean[0] + mean[1] + mean[2]) / 3.0, 5.0);  // visibly different
}

TEST(SyntheticTest, TruthDoesNotDependOnDegradations) {
  // The road is drawn from the seed before clutter, so clean and degraded
  // renderings of one seed share their ground truth.
  SyntheticOptions clean;
  clean.max_vehicles = 0;
  clean.max_shadows = 0;
  clean.noise_sigma = 0;
  clean.jpeg_quality = 0;
  const SyntheticOptions dirty;
  const CameraModel cam = CaltechCamera();
  for (uint64_t seed : {3, 4, 5}) {
    EXPECT_TRUE(SameTruth(Render(cam, clean, seed), Render(cam, dirty, seed))) << seed;
  }
}

TEST(SyntheticTest, FrameHasCameraSizeAndType) {
  for (const CameraModel& cam : {CaltechCamera(), CulaneCamera()}) {
    const SyntheticFrame f = Render(cam, SyntheticOptions{}, 7);
    EXPECT_EQ(f.bgr.cols, cam.image_width);
    EXPECT_EQ(f.bgr.rows, cam.image_height);
    EXPECT_EQ(f.bgr.type(), CV_8UC3);
  }
}

TEST(SyntheticTest, TruthLiesInsideImageAndBelowHorizon) {
  constexpr double kTol = 3.0;  // pixels: inner control points may leave the curve a little
  for (const CameraModel& cam : {CaltechCamera(), CulaneCamera()}) {
    const double horizon = cam.HorizonRow();
    for (uint64_t seed = 0; seed < 12; ++seed) {
      const SyntheticFrame f = Render(cam, SyntheticOptions{}, seed);
      for (const auto& b : f.boundaries) {
        for (const auto& p : b.image) {
          EXPECT_GE(p.x(), -kTol) << "seed " << seed;
          EXPECT_LE(p.x(), cam.image_width - 1 + kTol) << "seed " << seed;
          EXPECT_GE(p.y(), -kTol) << "seed " << seed;
          EXPECT_LE(p.y(), cam.image_height - 1 + kTol) << "seed " << seed;
          EXPECT_GT(p.y(), horizon) << "seed " << seed;
        }
        // The visible part spans a useful number of rows.
        EXPECT_GE(std::abs(b.image[3].y() - b.image[0].y()), 25.0) << "seed " << seed;
      }
    }
  }
}

TEST(SyntheticTest, BoundariesAreOrderedAndEgoLaneContainsCar) {
  for (const CameraModel& cam : {CaltechCamera(), CulaneCamera()}) {
    for (uint64_t seed = 0; seed < 8; ++seed) {
      const SyntheticFrame f = Render(cam, SyntheticOptions{}, seed);
      for (size_t i = 1; i < f.boundaries.size(); ++i) {
        EXPECT_LT(f.boundaries[i - 1].lateral_offset_m, f.boundaries[i].lateral_offset_m);
      }
      if (f.ego_left >= 0) {
        EXPECT_LT(f.boundaries[f.ego_left].lateral_offset_m, 0.0);
      }
      if (f.ego_right >= 0) {
        EXPECT_GT(f.boundaries[f.ego_right].lateral_offset_m, 0.0);
      }
      if (f.ego_left >= 0 && f.ego_right >= 0) {
        EXPECT_EQ(f.ego_right, f.ego_left + 1);
      }
    }
  }
}

TEST(SyntheticTest, SolidWhiteMarkingIsBrighterThanRoadBeside) {
  SyntheticOptions opt;
  opt.dashed_probability = 0;
  opt.yellow_probability = 0;
  opt.max_vehicles = 0;
  opt.max_shadows = 0;
  opt.noise_sigma = 0;
  opt.jpeg_quality = 0;
  for (const CameraModel& cam : {CaltechCamera(), CulaneCamera()}) {
    for (uint64_t seed = 10; seed < 16; ++seed) {
      const SyntheticFrame f = Render(cam, opt, seed);
      ASSERT_FALSE(f.boundaries.empty());
      for (int i = 0; i < static_cast<int>(f.boundaries.size()); ++i) {
        const Bezier bz{f.boundaries[i].image};
        double on = 0, left = 0, right = 0;
        int n_on = 0, n_left = 0, n_right = 0;
        for (const auto& p : bz.Sample(60)) {
          const Eigen::Vector2d g = cam.ImageToGround(p);
          const double r0 = Red(f.bgr, p);
          const double rl = Red(f.bgr, cam.GroundToImage(g - Eigen::Vector2d(1.0, 0.0)));
          const double rr = Red(f.bgr, cam.GroundToImage(g + Eigen::Vector2d(1.0, 0.0)));
          if (std::isnan(r0)) continue;
          on += r0;
          ++n_on;
          if (!std::isnan(rl)) {
            left += rl;
            ++n_left;
          }
          if (!std::isnan(rr)) {
            right += rr;
            ++n_right;
          }
        }
        ASSERT_GT(n_on, 0);
        on /= n_on;
        // The ego lane's markings are near and wide in the image: strongly
        // brighter. Far side boundaries are thin and seen at grazing angles.
        const bool ego = i == f.ego_left || i == f.ego_right;
        const double margin = ego ? 40.0 : 8.0;
        const std::string where =
            "seed " + std::to_string(seed) + " width " + std::to_string(cam.image_width);
        if (n_left > 10) {
          EXPECT_GT(on, left / n_left + margin) << where;
        }
        if (n_right > 10) {
          EXPECT_GT(on, right / n_right + margin) << where;
        }
      }
    }
  }
}

TEST(SyntheticTest, ThreeLanesGiveAtLeastTwoBoundariesOnBothCameras) {
  SyntheticOptions opt;
  opt.num_lanes = 3;
  for (const CameraModel& cam : {CaltechCamera(), CulaneCamera()}) {
    for (uint64_t seed = 0; seed < 6; ++seed) {
      const SyntheticFrame f = Render(cam, opt, seed);
      EXPECT_GE(f.boundaries.size(), 2u) << "seed " << seed;
      EXPECT_LE(f.boundaries.size(), 4u) << "seed " << seed;
      EXPECT_GE(f.ego_left, 0) << "seed " << seed;
      EXPECT_GE(f.ego_right, 0) << "seed " << seed;
    }
  }
}

TEST(SyntheticTest, InvalidCameraIsAnError) {
  CameraModel cam;
  cam.fu = -1;
  const auto f = RenderSyntheticFrame(cam, SyntheticOptions{}, 1);
  ASSERT_FALSE(f.ok());
  EXPECT_EQ(f.status().code(), absl::StatusCode::kInvalidArgument);

  CameraModel empty;
  empty.image_width = 0;
  EXPECT_FALSE(RenderSyntheticFrame(empty, SyntheticOptions{}, 1).ok());
}

TEST(SyntheticTest, InvalidOptionsAreAnError) {
  const CameraModel cam;
  std::vector<SyntheticOptions> bad(8);
  bad[0].num_lanes = -1;
  bad[1].lane_width_m = 0;
  bad[2].min_radius_m = -5;
  bad[3].yellow_probability = 1.5;
  bad[4].min_marking_width_m = 0.2;  // > max
  bad[5].jpeg_quality = 101;
  bad[6].noise_sigma = -1;
  bad[7].truth_far_m = -1;
  for (size_t i = 0; i < bad.size(); ++i) {
    const auto f = RenderSyntheticFrame(cam, bad[i], 1);
    ASSERT_FALSE(f.ok()) << i;
    EXPECT_EQ(f.status().code(), absl::StatusCode::kInvalidArgument) << i;
  }
}

// The hood (issue 49): still from frame to frame, under a parabola from
// `hood_side_row` at the image's edges to `hood_top_row` at the principal
// point's column; the labels stop at it, or run on through it to the
// image's bottom (CULane's convention); dash patterns placed beyond it.
TEST(SyntheticTest, HoodIsStillAndLabelsStopAtItOrRunThrough) {
  const CameraModel cam = CaltechCamera();
  SyntheticOptions o;
  o.num_lanes = 3;
  o.hood_top_row = 400;
  o.hood_side_row = 450;
  EXPECT_DOUBLE_EQ(lane::HoodRow(cam, o, cam.cu), 400);
  EXPECT_NEAR(lane::HoodRow(cam, o, 0), 450, 1e-9);
  const SyntheticFrame a = Render(cam, o, 21), b = Render(cam, o, 22);
  // Below the hood's edge two different roads give the same pixels (up to
  // the sensor's noise); above it they differ.
  cv::Mat hood_a, hood_b, road_a, road_b;
  cv::cvtColor(a.bgr.rowRange(455, 480), hood_a, cv::COLOR_BGR2GRAY);
  cv::cvtColor(b.bgr.rowRange(455, 480), hood_b, cv::COLOR_BGR2GRAY);
  cv::cvtColor(a.bgr.rowRange(300, 380), road_a, cv::COLOR_BGR2GRAY);
  cv::cvtColor(b.bgr.rowRange(300, 380), road_b, cv::COLOR_BGR2GRAY);
  EXPECT_LT(cv::norm(hood_a, hood_b, cv::NORM_L1) / hood_a.total(), 6.0);
  EXPECT_GT(cv::norm(road_a, road_b, cv::NORM_L1) / road_a.total(), 10.0);
  ASSERT_FALSE(a.boundaries.empty());
  for (const auto& boundary : a.boundaries) {
    for (const Eigen::Vector2d& p : Bezier{boundary.image}.Sample(50)) {
      EXPECT_LT(p.y(), lane::HoodRow(cam, o, p.x()) + 1.0);
    }
  }
  o.labels_through_hood = true;
  const SyntheticFrame through = Render(cam, o, 21);
  double lowest = 0;
  for (const auto& boundary : through.boundaries) {
    for (const Eigen::Vector2d& p : Bezier{boundary.image}.Sample(50))
      lowest = std::max(lowest, p.y());
  }
  EXPECT_GT(lowest, 470);
  // Nothing painted nearer than first_dash_m, a dash from there on.
  SyntheticOptions dashes;
  dashes.num_lanes = 2;
  dashes.dashed_probability = 1.0;
  dashes.straight_probability = 1.0;
  dashes.max_heading_rad = 0;
  dashes.max_vehicles = 0;
  dashes.max_shadows = 0;
  dashes.first_dash_m = 12.0;
  const SyntheticFrame d = Render(cam, dashes, 5);
  ASSERT_EQ(d.boundaries.size(), 3u);
  for (const auto& boundary : d.boundaries) {
    const double x = boundary.lateral_offset_m;
    double brightest_near = 0;
    for (const double y : {6.0, 8.0, 10.0, 11.5}) {
      brightest_near = std::max(brightest_near, Red(d.bgr, cam.GroundToImage({x, y})));
    }
    EXPECT_LT(brightest_near, 140) << "paint nearer than 12 m at x = " << x;
    EXPECT_GT(Red(d.bgr, cam.GroundToImage({x, 13.0})), brightest_near + 20) << x;
  }
}

// A hood given by distance (`lane render --hood M`, CULane's cameras) is the
// hood by rows: its top row is where the road `edge_m` ahead lies, its sides
// a twentieth of the image's height lower.
TEST(SyntheticTest, HoodAtADistanceIsTheHoodByRows) {
  const CameraModel cam = CulaneNightConfig().camera;
  const absl::StatusOr<lane::HoodRows> rows = lane::HoodRowsAtDistance(cam, 6.0);
  ASSERT_TRUE(rows.ok()) << rows.status();
  EXPECT_NEAR(cam.ImageToGround({cam.cu, rows->top_row}).y(), 6.0, 0.05);
  EXPECT_NEAR(rows->side_row - rows->top_row, 0.05 * cam.image_height, 1e-9);
  SyntheticOptions o;
  o.hood_top_row = rows->top_row;
  o.hood_side_row = rows->side_row;
  EXPECT_DOUBLE_EQ(lane::HoodRow(cam, o, cam.cu), rows->top_row);
  // Nearer than the image's bottom the hood is out of view.
  const absl::StatusOr<lane::HoodRows> hidden = lane::HoodRowsAtDistance(cam, 0.5);
  ASSERT_TRUE(hidden.ok()) << hidden.status();
  EXPECT_EQ(hidden->top_row, cam.image_height);
  for (const double bad : {0.0, -1.0, 101.0, std::nan("")}) {
    EXPECT_EQ(lane::HoodRowsAtDistance(cam, bad).status().code(),
              absl::StatusCode::kInvalidArgument)
        << bad;
  }
}

TEST(SyntheticTest, DegenerateViewsRenderWithoutTruth) {
  // Looking at the sky: no ground visible.
  CameraModel up;
  up.pitch_deg = -60;
  const SyntheticFrame sky = Render(up, SyntheticOptions{}, 1);
  EXPECT_EQ(sky.bgr.size(), cv::Size(up.image_width, up.image_height));
  EXPECT_TRUE(sky.boundaries.empty());
  EXPECT_EQ(sky.ego_left, -1);
  EXPECT_EQ(sky.ego_right, -1);
  // A tiny frame: too small for any boundary to span 30 rows.
  CameraModel tiny;
  tiny.fu = tiny.fv = 30;
  tiny.cu = 16;
  tiny.cv = 12;
  tiny.image_width = 32;
  tiny.image_height = 24;
  const SyntheticFrame small = Render(tiny, SyntheticOptions{}, 1);
  EXPECT_EQ(small.bgr.size(), cv::Size(32, 24));
  EXPECT_TRUE(small.boundaries.empty());
}

TEST(SyntheticTest, LabelsJsonIsOneLineInTheDocumentedForm) {
  const SyntheticFrame f = Render(CaltechCamera(), SyntheticOptions{}, 21);
  ASSERT_FALSE(f.boundaries.empty());
  const std::string line = lane::eval::RenderLabelsJson("000021.png", f);
  EXPECT_EQ(line.find('\n'), std::string::npos);
  EXPECT_EQ(
      line.rfind("{\"frame\":\"000021.png\",\"width\":640,\"height\":480,\"boundaries\":[", 0), 0u)
      << line;
  const nlohmann::json j = nlohmann::json::parse(line);
  ASSERT_EQ(j["boundaries"].size(), f.boundaries.size());
  for (size_t i = 0; i < f.boundaries.size(); ++i) {
    const auto& b = j["boundaries"][i];
    ASSERT_EQ(b["points"].size(), 4u);
    for (int k = 0; k < 4; ++k) {
      EXPECT_NEAR(b["points"][k][0].get<double>(), f.boundaries[i].image[k].x(), 0.01);
      EXPECT_NEAR(b["points"][k][1].get<double>(), f.boundaries[i].image[k].y(), 0.01);
    }
    EXPECT_EQ(b["dashed"].get<bool>(), f.boundaries[i].dashed);
    EXPECT_EQ(b["color"].get<std::string>(), f.boundaries[i].yellow ? "yellow" : "white");
    const std::string ego = static_cast<int>(i) == f.ego_left    ? "left"
                            : static_cast<int>(i) == f.ego_right ? "right"
                                                                 : "none";
    EXPECT_EQ(b["ego"].get<std::string>(), ego);
  }
}

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// The night test's scene: CULane's night camera with its hood 6 m ahead,
// a straight road of 4 lanes, no vehicles, solid white markings 15 cm wide,
// no noise or JPEG.
SyntheticOptions MeasuredNightOptions(const CameraModel& cam) {
  SyntheticOptions opt;
  opt.night = true;
  const absl::StatusOr<lane::HoodRows> hood_rows = lane::HoodRowsAtDistance(cam, 6.0);
  EXPECT_TRUE(hood_rows.ok()) << hood_rows.status();
  if (!hood_rows.ok()) return opt;
  opt.hood_top_row = hood_rows->top_row;
  opt.hood_side_row = hood_rows->side_row;
  opt.labels_through_hood = true;
  opt.num_lanes = 4;
  opt.lane_width_m = 3.5;
  opt.min_marking_width_m = 0.15;
  opt.max_marking_width_m = 0.15;
  opt.dashed_probability = 0;
  opt.yellow_probability = 0;
  opt.max_vehicles = 0;
  opt.noise_sigma = 0;
  opt.jpeg_quality = 0;
  opt.straight_probability = 1;
  opt.max_heading_rad = 0;
  return opt;
}

// Saturated blobs (red >= 250) above the horizon: their count and the
// largest one's area in pixels.
std::pair<int, double> GlareBlobs(const cv::Mat& bgr, double horizon_row) {
  cv::Mat red, sat, labels, stats, centroids;
  cv::extractChannel(bgr, red, 2);
  cv::compare(red.rowRange(0, static_cast<int>(horizon_row)), 250, sat, cv::CMP_GE);
  const int n = cv::connectedComponentsWithStats(sat, labels, stats, centroids);
  double largest = 0;
  for (int k = 1; k < n; ++k) {
    largest = std::max<double>(largest, stats.at<int>(k, cv::CC_STAT_AREA));
  }
  return {n - 1, largest};
}

// Issue 49's night, measured on a CULane night clip (1640x590, camera 1.23
// m high, pitch 1.8 deg), rendered through that camera
// (configs/culane-night.json) with its hood: the grey levels of the road on
// the camera's axis, of the unlit road, of the markings over the road at
// the measured distances, the glare above the horizon and the black hood.
// Medians over 8 frames (straight roads of 4 lanes, no vehicles, solid
// white markings 15 cm wide, no noise or JPEG: the figures of the model
// itself), against the measured figures with a margin.
TEST(SyntheticTest, NightHasTheMeasuredGreyLevels) {
  const CameraModel cam = CulaneNightConfig().camera;
  const SyntheticOptions opt = MeasuredNightOptions(cam);
  // Red at ground point (x, y).
  const auto grey = [&](const cv::Mat& bgr, double x, double y) {
    return Red(bgr, cam.GroundToImage({x, y}));
  };
  std::vector<double> axis12, axis20, axis30, axis40, axis60, unlit, hood;
  // Marking over the road beside it (0.6 m out), ego boundaries, by band.
  const double bands[][2] = {{8, 12}, {12, 20}, {20, 30}, {30, 50}, {50, 90}};
  std::vector<double> ego_contrast[5], outer_contrast;
  int glare_min = 1 << 30, glare_max = 0;
  double glare_largest = 0;
  for (uint64_t seed = 300; seed < 308; ++seed) {
    const SyntheticFrame f = Render(cam, opt, seed);
    axis12.push_back(Median({grey(f.bgr, 0, 12), grey(f.bgr, 0, 13), grey(f.bgr, 0, 14)}));
    axis20.push_back(grey(f.bgr, 0, 20));
    axis30.push_back(grey(f.bgr, 0, 30));
    axis40.push_back(grey(f.bgr, 0, 40));
    axis60.push_back(grey(f.bgr, 0, 60));
    for (int i = 0; i < static_cast<int>(f.boundaries.size()); ++i) {
      const double x = f.boundaries[i].lateral_offset_m;  // a straight road along y
      const bool ego = i == f.ego_left || i == f.ego_right;
      for (int b = 0; b < 5; ++b) {
        for (double y = bands[b][0]; y < bands[b][1]; y += 1.0) {
          const Eigen::Vector2d p = cam.GroundToImage({x, y});
          if (p.x() < 8 || p.x() > cam.image_width - 9) continue;
          const double road = 0.5 * (grey(f.bgr, x - 0.6, y) + grey(f.bgr, x + 0.6, y));
          double peak = 0;
          for (int du = -2; du <= 2; ++du)
            peak = std::max(peak, Red(f.bgr, p + Eigen::Vector2d(du, 0)));
          if (std::isnan(road)) continue;
          if (ego) ego_contrast[b].push_back(peak - road);
          if (std::abs(x) > 4.5 && y < 20) {
            outer_contrast.push_back(peak - road);
            unlit.push_back(road);
          }
        }
      }
    }
    for (int u = 0; u < cam.image_width; u += 41) hood.push_back(Red(f.bgr, {u, 585.0}));
    // Glare: saturated blobs above the horizon.
    const auto [blobs, largest] = GlareBlobs(f.bgr, cam.HorizonRow());
    glare_min = std::min(glare_min, blobs);
    glare_max = std::max(glare_max, blobs);
    glare_largest = std::max(glare_largest, largest);
  }
  std::printf(
      "[ night ] axis 12-14 m %.0f, 20 m %.0f, 30 m %.0f, 40 m %.0f, 60 m %.0f; unlit road "
      "%.0f, marking +%.0f; ego markings +%.0f +%.0f +%.0f +%.0f +%.0f; glare %d-%d blobs, "
      "largest %.0f px; hood %.0f\n",
      Median(axis12), Median(axis20), Median(axis30), Median(axis40), Median(axis60), Median(unlit),
      Median(outer_contrast), Median(ego_contrast[0]), Median(ego_contrast[1]),
      Median(ego_contrast[2]), Median(ego_contrast[3]), Median(ego_contrast[4]), glare_min,
      glare_max, glare_largest, Median(hood));
  // Measured: 150-160, 124, 82, 52, 38.
  EXPECT_NEAR(Median(axis12), 155, 12);
  EXPECT_NEAR(Median(axis20), 124, 15);
  EXPECT_NEAR(Median(axis30), 82, 12);
  EXPECT_NEAR(Median(axis40), 52, 10);
  EXPECT_NEAR(Median(axis60), 38, 8);
  // Measured: road 17, marking +14 (31-35).
  EXPECT_NEAR(Median(unlit), 17, 5);
  EXPECT_NEAR(Median(outer_contrast), 16, 6);
  // Measured: +40 at 8-12 m, +46 at 12-20, +37 at 20-30, +32 at 30-50, +14
  // at 50-90 m.
  const double measured[] = {40, 46, 37, 32, 14};
  for (int b = 0; b < 5; ++b) EXPECT_NEAR(Median(ego_contrast[b]), measured[b], 10) << b;
  // Measured: 4-19 blobs, up to about 2,200 px; the hood <= 16.
  EXPECT_GE(glare_min, 3);
  EXPECT_LE(glare_max, 25);
  EXPECT_LE(glare_largest, 3000);
  EXPECT_LE(Median(hood), 16);
}

}  // namespace
