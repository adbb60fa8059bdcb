#include "io/overlay.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <vector>

#include "absl/strings/str_cat.h"
#include "lane/geometry/bezier.h"

namespace lane::io {
namespace {

constexpr int kCurveSamples = 50;
// Sub-pixel drawing: coordinates are passed to OpenCV times 2^kShift.
constexpr int kShift = 4;
constexpr double kOne = 1 << kShift;

cv::Point Fixed(const Eigen::Vector2d& p) {
  return cv::Point(static_cast<int>(std::lround(p.x() * kOne)),
                   static_cast<int>(std::lround(p.y() * kOne)));
}

bool Finite(const Eigen::Vector2d& p) { return std::isfinite(p.x()) && std::isfinite(p.y()); }

// A cubic Bezier mapped through `to_canvas`: a polyline of samples and small
// circles on the control points.
template <class ToCanvas>
// `dashed`: an inferred boundary (Lane::inferred), drawn in dashes.
void DrawBezier(cv::Mat& canvas, const std::array<Eigen::Vector2d, 4>& control,
                const cv::Scalar& colour, ToCanvas to_canvas, bool dashed = false) {
  const lane::Bezier curve{control};
  std::vector<cv::Point> polyline;
  for (const Eigen::Vector2d& p : curve.Sample(kCurveSamples)) {
    const Eigen::Vector2d q = to_canvas(p);
    // Far outside points only make OpenCV's clipping overflow.
    if (Finite(q) && q.cwiseAbs().maxCoeff() < 1e5) polyline.push_back(Fixed(q));
  }
  if (dashed) {
    // Dashes and gaps of 3 samples each.
    for (size_t i = 0; i + 1 < polyline.size(); ++i) {
      if ((i / 3) % 2 == 0) {
        cv::line(canvas, polyline[i], polyline[i + 1], colour, 2, cv::LINE_AA, kShift);
      }
    }
  } else if (polyline.size() >= 2) {
    cv::polylines(canvas, polyline, /*isClosed=*/false, colour, 2, cv::LINE_AA, kShift);
  }
  for (const Eigen::Vector2d& p : control) {
    const Eigen::Vector2d q = to_canvas(p);
    if (Finite(q) && q.cwiseAbs().maxCoeff() < 1e5) {
      cv::circle(canvas, Fixed(q), 3 << kShift, colour, 1, cv::LINE_AA, kShift);
    }
  }
}

// An untracked detection's lanes, as a tracked frame's without ids.
std::vector<lane::TrackedLane> Untracked(const std::vector<lane::Lane>& lanes) {
  std::vector<lane::TrackedLane> out(lanes.size());
  for (size_t i = 0; i < lanes.size(); ++i) out[i].lane = lanes[i];
  return out;
}

cv::Mat ToBgr(const cv::Mat& image) {
  cv::Mat bgr;
  if (image.channels() == 1) {
    cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR);
  } else {
    bgr = image.clone();
  }
  return bgr;
}

}  // namespace

cv::Scalar LaneColour(int i) {
  static const cv::Scalar kPalette[] = {
      {0, 255, 0},    // green
      {255, 128, 0},  // azure
      {0, 215, 255},  // gold
      {255, 0, 255},  // magenta
      {255, 255, 0},  // cyan
      {0, 128, 255},  // orange
      {128, 0, 255},  // pink
      {255, 0, 128},  // violet
  };
  constexpr int n = sizeof(kPalette) / sizeof(kPalette[0]);
  return kPalette[((i % n) + n) % n];
}

cv::Point DrawCaption(cv::Mat& canvas, const std::string& text, int x, int y,
                      const cv::Scalar& colour) {
  const double scale = std::max(0.4, 0.5 * canvas.cols / 640.0);
  const int thickness = std::max(1, static_cast<int>(std::lround(scale * 1.5)));
  int baseline = 0;
  const cv::Size size =
      cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, thickness, &baseline);
  const int pad = std::max(2, static_cast<int>(std::lround(4 * scale)));
  const cv::Point corner(x + size.width + 2 * pad, y + size.height + baseline + 2 * pad);
  cv::rectangle(canvas, {x, y}, corner, cv::Scalar(0, 0, 0), cv::FILLED);
  cv::putText(canvas, text, {x + pad, y + pad + size.height}, cv::FONT_HERSHEY_SIMPLEX, scale,
              colour, thickness, cv::LINE_AA);
  return corner;
}

namespace {

// DrawLanesOnImage of `lanes` (labelled when they have ids) and `ego`.
cv::Mat DrawOnImage(const cv::Mat& frame, const std::vector<lane::TrackedLane>& lanes,
                    const std::optional<lane::EgoLane>& ego, const lane::Detector& detector,
                    const std::string& frame_name, const std::string& details) {
  cv::Mat canvas = ToBgr(frame);
  if (canvas.empty()) return canvas;

  // Horizon: thin grey dashes.
  const double horizon = detector.ipm().camera().HorizonRow();
  if (std::isfinite(horizon) && horizon >= 0 && horizon < canvas.rows) {
    const int y = static_cast<int>(std::lround(horizon));
    for (int x = 0; x < canvas.cols; x += 12) {
      cv::line(canvas, {x, y}, {std::min(x + 6, canvas.cols - 1), y}, {160, 160, 160}, 1);
    }
  }
  // The ROI actually mapped (after clipping): thin red.
  const lane::Roi& roi = detector.ipm().roi();
  cv::rectangle(canvas, Fixed({roi.left, roi.top}), Fixed({roi.right, roi.bottom}), {0, 0, 255}, 1,
                cv::LINE_AA, kShift);

  for (size_t i = 0; i < lanes.size(); ++i) {
    const lane::TrackedLane& tracked = lanes[i];
    const lane::Lane& lane = tracked.lane;
    DrawBezier(
        canvas, lane.image, LaneColour(static_cast<int>(i)),
        [](const Eigen::Vector2d& p) { return p; }, lane.inferred);
    if (tracked.id >= 0) {
      // Tracked: "#id colour type" at the lane's lower end, '?' until
      // confirmed, "predicted" for a track's prediction (not detected).
      const Eigen::Vector2d& low =
          lane.image[0].y() > lane.image[3].y() ? lane.image[0] : lane.image[3];
      const int x = std::clamp(static_cast<int>(low.x()), 0, std::max(0, canvas.cols - 80));
      const int y = std::clamp(static_cast<int>(low.y()) - canvas.rows / 12, 0, canvas.rows - 1);
      DrawCaption(
          canvas,
          absl::StrCat("#", tracked.id, tracked.confirmed ? " " : "? ",
                       lane::MarkingColorName(tracked.color), " ",
                       lane::MarkingTypeName(tracked.type), tracked.predicted ? " predicted" : ""),
          x, y, LaneColour(static_cast<int>(i)));
    }
  }
  // Caption: the frame's name; the mode, the lane count and the lanes'
  // scores in their colours; the details.
  const int margin = std::max(2, canvas.cols / 160);
  int y = margin;
  if (!frame_name.empty()) y = DrawCaption(canvas, frame_name, margin, y).y;
  const char* mode = detector.options().mode == lane::Mode::kTwo ? "2-lanes" : "all lanes";
  cv::Point at =
      DrawCaption(canvas,
                  absl::StrCat(mode, ": ", lanes.size(), lanes.size() == 1 ? " lane" : " lanes",
                               lanes.empty() ? "" : ", scores:"),
                  margin, y);
  for (size_t i = 0; i < lanes.size(); ++i) {
    char score[32];
    std::snprintf(score, sizeof(score), "%.1f", lanes[i].lane.score);
    at = DrawCaption(canvas, score, at.x, y, LaneColour(static_cast<int>(i)));
  }
  if (!details.empty()) at.y = DrawCaption(canvas, details, margin, at.y).y;
  if (ego) {
    const lane::EgoLane& e = *ego;
    char caption[160];
    std::snprintf(caption, sizeof(caption),
                  "ego: offset %+.2f m, width %.2f m, heading %+.1f deg, lanes #%d|#%d%s",
                  e.offset_m, e.width_m, e.heading_deg, e.left_id, e.right_id,
                  e.departing ? "  DEPARTING" : "");
    DrawCaption(canvas, caption, margin, at.y,
                e.departing ? cv::Scalar(0, 0, 255) : cv::Scalar(255, 255, 255));
  }
  return canvas;
}

// DrawIpmView of `lanes`.
cv::Mat DrawInTopView(const cv::Mat& frame, const std::vector<lane::TrackedLane>& lanes,
                      const lane::Detector& detector, int scale) {
  scale = std::max(1, scale);
  const cv::Mat top = detector.ipm().Apply(detector.ExtractChannel(frame));
  if (top.empty()) return cv::Mat();
  cv::Mat stretched;
  cv::normalize(top, stretched, 0, 255, cv::NORM_MINMAX, CV_8U);
  cv::Mat big;
  cv::resize(stretched, big, cv::Size(), scale, scale, cv::INTER_NEAREST);
  cv::Mat canvas = ToBgr(big);

  // IPM pixel (col, row) covers [scale*col, scale*(col+1)) in the canvas;
  // its centre is at scale*(col+0.5) - 0.5 in OpenCV's pixel coordinates.
  const double s = scale;
  for (size_t i = 0; i < lanes.size(); ++i) {
    DrawBezier(
        canvas, lanes[i].lane.ipm, LaneColour(static_cast<int>(i)),
        [s](const Eigen::Vector2d& p) {
          return Eigen::Vector2d((p.x() + 0.5) * s - 0.5, (p.y() + 0.5) * s - 0.5);
        },
        lanes[i].lane.inferred);
  }
  return canvas;
}

}  // namespace

cv::Mat DrawLanesOnImage(const cv::Mat& frame, const lane::Detection& detection,
                         const lane::Detector& detector, const std::string& frame_name,
                         const std::string& details) {
  return DrawOnImage(frame, Untracked(detection.lanes), std::nullopt, detector, frame_name,
                     details);
}

cv::Mat DrawLanesOnImage(const cv::Mat& frame, const lane::TrackedFrame& tracked,
                         const lane::Detector& detector, const std::string& frame_name,
                         const std::string& details) {
  return DrawOnImage(frame, tracked.lanes, tracked.ego, detector, frame_name, details);
}

cv::Mat DrawIpmView(const cv::Mat& frame, const lane::Detection& detection,
                    const lane::Detector& detector, int scale) {
  return DrawInTopView(frame, Untracked(detection.lanes), detector, scale);
}

cv::Mat DrawIpmView(const cv::Mat& frame, const lane::TrackedFrame& tracked,
                    const lane::Detector& detector, int scale) {
  return DrawInTopView(frame, tracked.lanes, detector, scale);
}

namespace {

// Writes the two pictures of `drawn` (a Detection or a TrackedFrame).
template <typename Drawn>
std::string WriteBoth(const std::filesystem::path& dir, const std::string& stem,
                      const cv::Mat& frame, const Drawn& drawn, const lane::Detector& detector,
                      const std::string& frame_name, const std::string& details) {
  const std::string image_path = (dir / (stem + ".png")).string();
  const std::string ipm_path = (dir / (stem + "_ipm.png")).string();
  try {
    if (!cv::imwrite(image_path, DrawLanesOnImage(frame, drawn, detector, frame_name, details))) {
      return absl::StrCat("cannot write ", image_path);
    }
    if (!cv::imwrite(ipm_path, DrawIpmView(frame, drawn, detector))) {
      return absl::StrCat("cannot write ", ipm_path);
    }
  } catch (const cv::Exception& e) {
    return absl::StrCat("cannot write overlay ", image_path, ": ", e.what());
  }
  return "";
}

}  // namespace

std::string WriteOverlays(const std::filesystem::path& dir, const std::string& stem,
                          const cv::Mat& frame, const lane::Detection& detection,
                          const lane::Detector& detector, const std::string& frame_name,
                          const std::string& details) {
  return WriteBoth(dir, stem, frame, detection, detector, frame_name, details);
}

std::string WriteOverlays(const std::filesystem::path& dir, const std::string& stem,
                          const cv::Mat& frame, const lane::TrackedFrame& tracked,
                          const lane::Detector& detector, const std::string& frame_name,
                          const std::string& details) {
  return WriteBoth(dir, stem, frame, tracked, detector, frame_name, details);
}

}  // namespace lane::io
