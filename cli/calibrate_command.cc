// `lane calibrate`: a camera's config from frames of ordinary driving
// (lane/calibrate/calibration.h, docs/calibration.md).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "commands.h"
#include "io/cli_config.h"
#include "io/inputs.h"
#include "lane/calibrate/calibration.h"
#include "lane/calibrate/mounted_camera.h"
#include "lane/config/config.h"
#include "lane/detector/detector.h"

namespace lane::cli {
namespace {

constexpr char kCalibrateDescription[] =
    "Estimates a camera from frames of ordinary driving and writes a complete\n"
    "config: the camera's pitch and yaw from the vanishing point of the lane\n"
    "markings (straight stretches; frames on curves or without markings are\n"
    "left out and counted), the road's rows (the still hood is left out), and\n"
    "a top view on the road (docs/config.md, \"Choosing a ground view\").\n"
    "\n"
    "The camera height sets the metric scale. The focal length is --focal-px,\n"
    "or assumed (0.61 x the image width, a 79 degree field of view): at a\n"
    "given vanishing point it only scales distances along the road.\n"
    "INPUT is read twice (image files, directories, list files or videos).\n"
    "\n"
    "A known mounting (--pitch-deg and --yaw-deg, from the vehicle's drawings)\n"
    "needs no vanishing point: INPUT is read once for the hood's outline, then\n"
    "for the self-check.";

struct CalibrateFlags {
  double height_m = 0;
  std::optional<double> focal_px;
  std::optional<std::string> principal_point;
  double lane_width_m = 3.5;
  std::optional<int> road_bottom_row;
  // A known mounting: no vanishing point (lane/calibrate/mounted_camera.h).
  std::optional<double> pitch_deg, yaw_deg;
  std::optional<std::string> template_config;
  std::string output;
  std::optional<std::string> overlay;
  bool keep_static = false;
  io::ReadFlags read;
  std::vector<std::string> inputs;
};

// "U,V" -> point; nullopt when malformed.
std::optional<Eigen::Vector2d> ParsePoint(const std::string& text) {
  const std::vector<std::string> parts = absl::StrSplit(text, ',');
  if (parts.size() != 2) return std::nullopt;
  try {
    size_t a = 0, b = 0;
    const double u = std::stod(parts[0], &a), v = std::stod(parts[1], &b);
    if (a != parts[0].size() || b != parts[1].size() || !std::isfinite(u) || !std::isfinite(v)) {
      return std::nullopt;
    }
    return Eigen::Vector2d(u, v);
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// The frame of pass 2 whose point had the most support, with its segments.
struct BestFrame {
  cv::Mat bgr;
  std::vector<lane::ImageSegment> segments;
  lane::FrameVanishingPoint point;
};

cv::Point Pixel(const Eigen::Vector2d& p) {
  return {static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y()))};
}

cv::Mat ColourCopy(const cv::Mat& frame) {
  cv::Mat img;
  if (frame.channels() == 3) return frame.clone();
  cv::cvtColor(frame, img, cv::COLOR_GRAY2BGR);
  return img;
}

void DrawSegment(cv::Mat& img, const lane::ImageSegment& s, const cv::Scalar& colour) {
  cv::line(img, Pixel(s.centre - 0.5 * s.length * s.direction),
           Pixel(s.centre + 0.5 * s.length * s.direction), colour, 2, cv::LINE_AA);
}

// The static structure's rectangles (blue).
void DrawStaticBoxes(cv::Mat& img, const std::vector<lane::Roi>& boxes) {
  for (const lane::Roi& b : boxes) {
    cv::rectangle(img, Pixel({b.left, b.top}), Pixel({b.right, b.bottom}), {255, 128, 0}, 1);
  }
}

// A refused estimate: pass 1's point with the segments of every frame that
// supported it (green, extended to it), those left out as static structure
// (blue) and its rectangles, on `frame` (the frame that gave most support).
void DrawRefusalOverlay(const cv::Mat& frame, const lane::FirstPassReport& first,
                        const std::string& path) {
  cv::Mat img = ColourCopy(frame);
  DrawStaticBoxes(img, first.static_structure.boxes);
  for (const auto& [k, s] : first.static_segments) DrawSegment(img, s, {255, 128, 0});
  for (const auto& [k, s] : first.support) {
    cv::line(img, Pixel(s.centre), Pixel(first.point), {0, 200, 0}, 1, cv::LINE_AA);
  }
  for (const auto& [k, s] : first.support) DrawSegment(img, s, {0, 255, 0});
  cv::drawMarker(img, Pixel(first.point), {255, 0, 255}, cv::MARKER_CROSS, 24, 2);
  const std::string lines[] = {
      absl::StrFormat("REFUSED: the first pass's point (%.1f, %.1f)", first.point.x(),
                      first.point.y()),
      absl::StrFormat("%d segments voted for it (green), %d left out as static (blue)",
                      static_cast<int>(first.support.size()),
                      static_cast<int>(first.static_segments.size()))};
  for (int k = 0; k < 2; ++k) {
    cv::putText(img, lines[k], {10, 24 + 24 * k}, cv::FONT_HERSHEY_SIMPLEX, 0.55, {255, 255, 255},
                2, cv::LINE_AA);
  }
  cv::imwrite(path, img);
}

// The frame (0-based) that gave pass 1's point the most support.
int MostSupportingFrame(const lane::FirstPassReport& first) {
  std::vector<int> count;
  for (const auto& [k, s] : first.support) {
    if (k >= static_cast<int>(count.size())) count.resize(static_cast<size_t>(k) + 1, 0);
    ++count[static_cast<size_t>(k)];
  }
  return count.empty()
             ? -1
             : static_cast<int>(std::max_element(count.begin(), count.end()) - count.begin());
}

void DrawOverlay(const BestFrame& best, const lane::CalibrationResult& r,
                 const std::vector<lane::Roi>& static_boxes, const std::string& path) {
  cv::Mat img = ColourCopy(best.bgr);
  DrawStaticBoxes(img, static_boxes);
  const double horizon = r.camera.HorizonRow();
  cv::line(img, {0, static_cast<int>(std::lround(horizon))},
           {img.cols - 1, static_cast<int>(std::lround(horizon))}, {255, 255, 0}, 1, cv::LINE_AA);
  // The road's outline (the hood), where it lies above the image's bottom.
  for (int u = 0; u + 1 < img.cols; ++u) {
    const double a = r.outline.FirstRowBelow(u, img.rows),
                 b = r.outline.FirstRowBelow(u + 1, img.rows);
    if (a < img.rows || b < img.rows) {
      cv::line(img, {u, static_cast<int>(a)}, {u + 1, static_cast<int>(b)}, {0, 0, 255}, 1);
    }
  }
  const Eigen::Vector2d vp = r.vanishing_point.point;
  std::vector<bool> support(best.segments.size(), false);
  for (int k : best.point.support) support[static_cast<size_t>(k)] = true;
  for (size_t k = 0; k < best.segments.size(); ++k) {
    const lane::ImageSegment& s = best.segments[k];
    if (support[k]) {
      // Supporting segments extended to the vanishing point.
      cv::line(img, {static_cast<int>(s.centre.x()), static_cast<int>(s.centre.y())},
               {static_cast<int>(vp.x()), static_cast<int>(vp.y())}, {0, 200, 0}, 1, cv::LINE_AA);
    }
    const Eigen::Vector2d a = s.centre - 0.5 * s.length * s.direction;
    const Eigen::Vector2d b = s.centre + 0.5 * s.length * s.direction;
    cv::line(img, {static_cast<int>(a.x()), static_cast<int>(a.y())},
             {static_cast<int>(b.x()), static_cast<int>(b.y())},
             support[k] ? cv::Scalar(0, 255, 0) : cv::Scalar(0, 0, 255), 2, cv::LINE_AA);
  }
  // The ground view's rectangle on the road.
  const lane::GroundView& g = r.view;
  std::vector<cv::Point> outline;
  for (double t = 0; t <= 1.0001; t += 0.05) {
    outline.emplace_back(cv::Point(0, 0));
    const Eigen::Vector2d p =
        r.camera.GroundToImage({g.x_min_m + t * (g.x_max_m - g.x_min_m), g.y_min_m});
    outline.back() = {static_cast<int>(p.x()), static_cast<int>(p.y())};
  }
  for (double t = 1.0; t >= -0.0001; t -= 0.05) {
    const Eigen::Vector2d p =
        r.camera.GroundToImage({g.x_min_m + t * (g.x_max_m - g.x_min_m), g.y_max_m});
    outline.emplace_back(static_cast<int>(p.x()), static_cast<int>(p.y()));
  }
  cv::polylines(img, outline, true, {0, 165, 255}, 1, cv::LINE_AA);
  cv::drawMarker(img,
                 {static_cast<int>(std::lround(vp.x())), static_cast<int>(std::lround(vp.y()))},
                 {255, 0, 255}, cv::MARKER_CROSS, 24, 2);
  cv::putText(img,
              absl::StrFormat("VP (%.1f, %.1f)  pitch %.2f  yaw %.2f deg", vp.x(), vp.y(),
                              r.camera.pitch_deg, r.camera.yaw_deg),
              {10, 24}, cv::FONT_HERSHEY_SIMPLEX, 0.6, {255, 255, 255}, 2, cv::LINE_AA);
  cv::imwrite(path, img);
}

// The config's header for a known mounting (--pitch-deg, --yaw-deg).
std::string MountedConfigHeader(const lane::CalibrationResult& r,
                                const lane::LaneGeometryReport& check,
                                const CalibrateFlags& flags) {
  std::string h = "// Written by lane calibrate (docs/calibration.md).\n";
  absl::StrAppendFormat(&h,
                        "// Camera mounting given: pitch %.3f deg, yaw %.3f deg, height %.3f m, "
                        "focal length %.1f px (%s); no vanishing point estimated.\n",
                        r.camera.pitch_deg, r.camera.yaw_deg, r.camera.height_m, r.camera.fu,
                        r.focal_assumed ? "assumed: 0.61 x image width" : "given");
  absl::StrAppendFormat(&h,
                        "// %d frames read, %d stationary; the road's rows end at rows %.0f..%.0f "
                        "(per column); lane width for the top view %.2f m.\n",
                        r.frames, r.frames_stationary, r.outline.Top(r.camera.image_height),
                        r.outline.Bottom(r.camera.image_height), flags.lane_width_m);
  absl::StrAppendFormat(&h,
                        "// Self-check passed: lane pairs in %d of %d used frames, heading %.2f "
                        "deg, divergence %.2f deg, width %.2f m.\n",
                        check.frames_with_pair, check.frames, check.heading_deg,
                        check.divergence_deg, check.width_m);
  return h;
}

std::string ConfigHeader(const lane::CalibrationResult& r, const lane::LaneGeometryReport& check,
                         const CalibrateFlags& flags) {
  if (r.mounting_given) return MountedConfigHeader(r, check, flags);
  const lane::CombinedVanishingPoint& vp = r.vanishing_point;
  std::string h = "// Written by lane calibrate (docs/calibration.md).\n";
  absl::StrAppendFormat(
      &h,
      "// Vanishing point (%.1f, %.1f) px +- (%.1f, %.1f) (95 %% interval, bootstrap over the "
      "frames), from %d of %d frames\n// (%d curved, %d without markings, %d meeting "
      "elsewhere, %d stationary, %d outliers) and %d marking segments.\n",
      vp.point.x(), vp.point.y(), r.interval_px.x(), r.interval_px.y(), vp.frames_used, r.frames,
      r.frames_curved, r.frames_no_markings, r.frames_elsewhere, r.frames_stationary,
      vp.frames_rejected, r.segments);
  absl::StrAppendFormat(&h, "// Camera height %.3f m (given); focal length %.1f px (%s).\n",
                        r.camera.height_m, r.camera.fu,
                        r.focal_assumed ? "assumed: 0.61 x image width; only the along-road "
                                          "scale depends on it"
                                        : "given");
  absl::StrAppendFormat(&h,
                        "// Road rows end at row %d (per column: rows %.0f..%.0f); lane width for "
                        "the top view %.2f m.\n",
                        r.road_bottom_row, r.outline.Top(r.camera.image_height),
                        r.outline.Bottom(r.camera.image_height), flags.lane_width_m);
  absl::StrAppendFormat(&h,
                        "// Static structure: %d segments left out; %d rectangles on the road's "
                        "rows masked (ipm.static_mask).\n",
                        r.static_segments, static_cast<int>(r.static_mask.size()));
  absl::StrAppendFormat(&h,
                        "// Self-check passed: lane pairs in %d of %d used frames, heading %.2f "
                        "deg, divergence %.2f deg, width %.2f m.\n",
                        check.frames_with_pair, check.frames, check.heading_deg,
                        check.divergence_deg, check.width_m);
  return h;
}

// Runs `use` on every readable input frame (others counted); false when `use` fails.
bool EachFrame(const CalibrateFlags& flags, int& read_errors,
               const std::function<absl::Status(const io::InputFrame&)>& use) {
  io::FrameReader reader(flags.inputs, flags.read.Options());
  io::InputFrame frame;
  while (reader.Next(&frame)) {
    if (!frame.error.empty()) {
      io::PrintMessage("lane calibrate", frame.name + ": " + frame.error);
      ++read_errors;
      continue;
    }
    if (absl::Status s = use(frame); !s.ok()) {
      io::PrintMessage("lane calibrate", frame.name + ": " + std::string(s.message()));
      return false;
    }
  }
  return true;
}

// Writes the template config with the estimated camera and ground view to --output.
absl::Status WriteCalibratedConfig(const lane::Config& base, const lane::CalibrationResult& r,
                                   const lane::LaneGeometryReport& check,
                                   const CalibrateFlags& flags) {
  lane::Config config = base;
  config.camera = r.camera;
  config.ipm = lane::GroundViewIpm(r.view, config.ipm);
  config.ipm.static_mask = r.static_mask;  // this camera's, not the template's
  if (absl::StatusOr<lane::Detector> d =
          lane::Detector::Create(config.camera, config.ipm, config.detector);
      !d.ok()) {
    return absl::InternalError(
        absl::StrCat("the estimated camera gives no detector: ", d.status().message()));
  }
  std::ofstream out;
  if (!io::OpenOutputFile(flags.output, &out)) {
    return absl::InternalError("cannot write " + flags.output);
  }
  out << ConfigHeader(r, check, flags) << lane::ConfigToJson(config) << '\n';
  out.close();
  if (!out) return absl::InternalError("error writing " + flags.output);
  return absl::OkStatus();
}

void PrintSelfCheck(const lane::LaneGeometryReport& check) {
  std::printf(
      "self-check        lane pairs in %d of %d used frames; heading %.2f deg, divergence %.2f "
      "deg, width %.2f m: %s\n",
      check.frames_with_pair, check.frames, check.heading_deg, check.divergence_deg, check.width_m,
      check.verdict.ok() ? "passed" : "FAILED");
}

// Runs the detector with the estimate on the frames it used (pass 3).
absl::StatusOr<lane::LaneGeometryReport> SelfCheck(const lane::CalibrationResult& r,
                                                   const CalibrateFlags& flags) {
  absl::StatusOr<lane::CalibrationSelfCheck> check =
      lane::CalibrationSelfCheck::Create(r, flags.lane_width_m);
  if (!check.ok()) return check.status();
  std::vector<bool> used;
  for (int k : r.used_frames) {
    if (k >= static_cast<int>(used.size())) used.resize(static_cast<size_t>(k) + 1, false);
    used[static_cast<size_t>(k)] = true;
  }
  int index = 0, read_errors = 0;
  if (!EachFrame(flags, read_errors, [&](const io::InputFrame& f) -> absl::Status {
        const size_t k = static_cast<size_t>(index++);
        return k < used.size() && used[k] ? check->AddFrame(f.bgr) : absl::OkStatus();
      })) {
    return absl::InternalError("the self-check could not run the detector");
  }
  return check->Report();
}

// What to try when the estimate is refused (by Finish or the self-check).
constexpr char kRefusalAdvice[] =
    "no config written. Try: more frames, or a straight stretch of road with markings on both "
    "sides; --focal-px if the focal length is known (0.61 x image width is assumed); "
    "--road-bottom-row if the hood shows in the frames; --overlay to see what voted";

// The summary's lines after the estimate itself (both kinds of estimate).
void PrintCameraAndView(const lane::CalibrationResult& r, const lane::LaneGeometryReport& check,
                        const CalibrateFlags& flags) {
  std::printf("focal length      %.1f px (%s)\n", r.camera.fu,
              r.focal_assumed ? "assumed: 0.61 x image width, give --focal-px if known" : "given");
  std::printf("principal point   (%.1f, %.1f) px%s\n", r.camera.cu, r.camera.cv,
              flags.principal_point ? "" : " (image centre)");
  std::printf("far ground point  (%.1f, %.1f) px (check: at the vanishing point)\n",
              r.far_point.x(), r.far_point.y());
  std::printf("road rows         end at row %d of %d%s; per column rows %.0f..%.0f\n",
              r.road_bottom_row, r.camera.image_height,
              r.road_bottom_row < r.camera.image_height ? " (still hood below)" : "",
              r.outline.Top(r.camera.image_height), r.outline.Bottom(r.camera.image_height));
  std::printf("top view          x %.2f..%.2f m, y %.2f..%.2f m\n", r.view.x_min_m, r.view.x_max_m,
              r.view.y_min_m, r.view.y_max_m);
  PrintSelfCheck(check);
  std::printf("config            %s\n", flags.output.c_str());
}

// Prints the estimate's summary on stdout.
void PrintCalibration(const lane::CalibrationResult& r, const lane::LaneGeometryReport& check,
                      const CalibrateFlags& flags) {
  const lane::CombinedVanishingPoint& vp = r.vanishing_point;
  if (r.mounting_given) {
    std::printf("pitch, yaw        %.3f, %.3f deg (given: no vanishing point estimated)\n",
                r.camera.pitch_deg, r.camera.yaw_deg);
    std::printf("frames            %d read, %d used, %d stationary\n", r.frames, vp.frames_used,
                r.frames_stationary);
    PrintCameraAndView(r, check, flags);
    return;
  }
  std::printf(
      "vanishing point   (%.1f, %.1f) px, 95 %% interval +-(%.1f, %.1f) px (bootstrap over %d "
      "frames), spread (%.1f, %.1f) px\n",
      vp.point.x(), vp.point.y(), r.interval_px.x(), r.interval_px.y(),
      vp.frames_used + vp.frames_rejected, vp.spread.x(), vp.spread.y());
  std::printf(
      "frames            %d read, %d used, %d curved, %d without markings, %d meeting "
      "elsewhere, %d stationary, %d outliers\n",
      r.frames, vp.frames_used, r.frames_curved, r.frames_no_markings, r.frames_elsewhere,
      r.frames_stationary, vp.frames_rejected);
  std::printf("segments          %d supporting\n", r.segments);
  std::printf("pitch, yaw        %.3f +- %.3f, %.3f +- %.3f deg (95 %% interval)\n",
              r.camera.pitch_deg, r.pitch_interval_deg, r.camera.yaw_deg, r.yaw_interval_deg);
  std::string boxes;
  for (const lane::Roi& b : r.static_mask) {
    absl::StrAppendFormat(&boxes, "%s u %.0f..%.0f v %.0f..%.0f", boxes.empty() ? ":" : ";", b.left,
                          b.right, b.top, b.bottom);
  }
  std::printf("static structure  %d segments left out; %d rectangles masked on the road's rows%s\n",
              r.static_segments, static_cast<int>(r.static_mask.size()), boxes.c_str());
  PrintCameraAndView(r, check, flags);
}

// A known mounting (--pitch-deg, --yaw-deg): one read for the road's
// outline, the self-check, the config.
int RunMounted(const CalibrateFlags& flags, const lane::CalibrationOptions& options,
               const lane::Config& base) {
  lane::MountedCameraSurvey survey(options, *flags.pitch_deg, *flags.yaw_deg);
  int read_errors = 0;
  BestFrame first;
  if (!EachFrame(flags, read_errors, [&](const io::InputFrame& f) {
        if (flags.overlay && first.bgr.empty()) first.bgr = f.bgr.clone();
        return survey.AddFrame(f.bgr);
      })) {
    return io::kExitFailure;
  }
  const absl::StatusOr<lane::CalibrationResult> result = survey.Finish();
  if (!result.ok()) return Failure("calibrate", std::string(result.status().message()));
  const lane::CalibrationResult& r = *result;
  if (flags.overlay && !first.bgr.empty()) DrawOverlay(first, r, {}, *flags.overlay);
  const absl::StatusOr<lane::LaneGeometryReport> check = SelfCheck(r, flags);
  if (!check.ok()) return Failure("calibrate", std::string(check.status().message()));
  if (!check->verdict.ok()) {
    PrintSelfCheck(*check);
    return Failure("calibrate",
                   absl::StrFormat("the given mounting (pitch %.3f, yaw %.3f deg) failed its "
                                   "self-check: %s; no config written. Check the mounting's "
                                   "pitch, yaw, height and focal length; --overlay shows the "
                                   "horizon and the top view",
                                   r.camera.pitch_deg, r.camera.yaw_deg, check->verdict.message()));
  }
  if (absl::Status s = WriteCalibratedConfig(base, r, *check, flags); !s.ok()) {
    return Failure("calibrate", std::string(s.message()));
  }
  PrintCalibration(r, *check, flags);
  return read_errors > 0 ? io::kExitFailure : io::kExitOk;
}

int RunCalibrate(const CalibrateFlags& flags) {
  lane::CalibrationOptions options;
  options.height_m = flags.height_m;
  options.focal_px = flags.focal_px;
  options.lane_width_m = flags.lane_width_m;
  options.road_bottom_row = flags.road_bottom_row;
  options.static_structure.enabled = !flags.keep_static;
  if (flags.principal_point) {
    options.principal_point = ParsePoint(*flags.principal_point);
    if (!options.principal_point) {
      return Failure("calibrate", "--principal-point must be U,V in pixels, got \"" +
                                      *flags.principal_point + "\"");
    }
  }
  absl::StatusOr<lane::Config> base = io::LoadEffectiveConfig(flags.template_config, {});
  if (!base.ok()) return Failure("calibrate", std::string(base.status().message()));
  if (flags.pitch_deg) return RunMounted(flags, options, *base);

  lane::CameraCalibrator calibrator(options);
  int read_errors = 0;
  if (!EachFrame(flags, read_errors,
                 [&](const io::InputFrame& f) { return calibrator.AddFirstPass(f.bgr); })) {
    return io::kExitFailure;
  }
  if (absl::Status s = calibrator.FinishFirstPass(); !s.ok()) {
    return Failure("calibrate", std::string(s.message()));
  }
  read_errors = 0;
  BestFrame best;
  // For an overlay of a refusal: the frame that supported pass 1 most.
  const int refusal_frame = flags.overlay ? MostSupportingFrame(calibrator.first_pass()) : -1;
  cv::Mat refusal_bgr;
  int index = 0;
  if (!EachFrame(flags, read_errors, [&](const io::InputFrame& f) -> absl::Status {
        if (index++ == refusal_frame) refusal_bgr = f.bgr.clone();
        std::vector<lane::ImageSegment> segments;
        absl::StatusOr<lane::FrameVanishingPoint> p = calibrator.AddSecondPass(f.bgr, &segments);
        if (!p.ok()) return p.status();
        if (flags.overlay && p->result == lane::VpFrameResult::kOk &&
            p->inliers > best.point.inliers) {
          best = {f.bgr.clone(), std::move(segments), *p};
        }
        return absl::OkStatus();
      })) {
    return io::kExitFailure;
  }
  const absl::StatusOr<lane::CalibrationResult> result = calibrator.Finish();
  if (!result.ok()) {
    if (flags.overlay && !refusal_bgr.empty()) {
      DrawRefusalOverlay(refusal_bgr, calibrator.first_pass(), *flags.overlay);
    }
    return Failure("calibrate", absl::StrCat(result.status().message(), "; ", kRefusalAdvice));
  }
  const lane::CalibrationResult& r = *result;
  if (flags.overlay && !best.bgr.empty()) {
    DrawOverlay(best, r, calibrator.first_pass().static_structure.boxes, *flags.overlay);
  }
  const absl::StatusOr<lane::LaneGeometryReport> check = SelfCheck(r, flags);
  if (!check.ok()) return Failure("calibrate", std::string(check.status().message()));
  if (!check->verdict.ok()) {
    PrintSelfCheck(*check);
    return Failure("calibrate",
                   absl::StrFormat("the estimate (%.1f, %.1f) failed its self-check: %s; %s",
                                   r.vanishing_point.point.x(), r.vanishing_point.point.y(),
                                   check->verdict.message(), kRefusalAdvice));
  }
  if (absl::Status s = WriteCalibratedConfig(*base, r, *check, flags); !s.ok()) {
    return Failure("calibrate", std::string(s.message()));
  }
  PrintCalibration(r, *check, flags);
  return read_errors > 0 ? io::kExitFailure : io::kExitOk;
}

}  // namespace

io::Command AddCalibrateCommand(CLI::App& lane) {
  auto flags = std::make_shared<CalibrateFlags>();
  CLI::App* app = io::AddCommand(lane, "calibrate",
                                 "estimate a camera from driving frames and write its config",
                                 kCalibrateDescription);
  app->add_option("--height-m", flags->height_m, "camera height above the road, metres")
      ->type_name("H")
      ->required()
      ->check(CLI::Range(0.2, 10.0));
  io::AddOptional(
      app, "--focal-px", &flags->focal_px,
      "focal length in pixels (square pixels); assumed 0.61 x image width when not given")
      ->type_name("F")
      ->check(CLI::Range(10.0, 100000.0));
  io::AddOptional(app, "--principal-point", &flags->principal_point,
                  "principal point U,V in pixels (default: the image centre)")
      ->type_name("U,V")
      ->check(CLI::Validator(
          [](std::string& text) {
            return ParsePoint(text) ? std::string() : "must be U,V in pixels, got " + text;
          },
          "U,V"));
  app->add_option("--lane-width-m", flags->lane_width_m,
                  "lane width of the roads, metres: the top view's lateral extent")
      ->type_name("W")
      ->check(CLI::Range(2.0, 6.0));
  io::AddOptional(app, "--road-bottom-row", &flags->road_bottom_row,
                  "first image row below the road (where the car's hood starts), when the still "
                  "rows found are not it")
      ->type_name("V")
      ->check(CLI::Range(1, 16384));
  io::AddOptional(app, "--template", &flags->template_config,
                  "config whose detector settings the output keeps (default: the built-in ones)")
      ->type_name("CONFIG");
  CLI::Option* pitch =
      io::AddOptional(
          app, "--pitch-deg", &flags->pitch_deg,
          "a known mounting: the camera's pitch, degrees (positive looking down; with "
          "--yaw-deg, and best --focal-px). No vanishing point is estimated: the frames "
          "give the hood's outline for the top view, and the self-check")
          ->type_name("DEG")
          ->check(CLI::Range(-89.0, 89.0));
  CLI::Option* yaw =
      io::AddOptional(app, "--yaw-deg", &flags->yaw_deg,
                      "a known mounting: the camera's yaw, degrees (positive looking "
                      "right of the road; with --pitch-deg)")
          ->type_name("DEG")
          ->check(CLI::Range(-89.0, 89.0));
  pitch->needs(yaw);
  yaw->needs(pitch);
  app->add_option("--output,-o", flags->output, "the config to write")
      ->type_name("CONFIG.json")
      ->required();
  io::AddOptional(app, "--overlay", &flags->overlay,
                  "also draw the best-supported frame's segments, vanishing point, horizon, road "
                  "rows, top view and static structure to this PNG; when the estimate is refused, "
                  "the first pass's point and the segments that voted for it")
      ->type_name("PNG");
  app->add_flag("--keep-static-structure", flags->keep_static,
                "let structure fixed to the camera (reflections, stickers, overlays) vote, and "
                "write no static mask: for comparison");
  io::AddReadFlags(app, &flags->read);
  app->add_option("INPUT", flags->inputs, "image files, directories, list files or videos")
      ->required();
  return {app, [flags] { return RunCalibrate(*flags); }};
}

}  // namespace lane::cli
