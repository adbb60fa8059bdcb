#include "live_draw.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <vector>

#include "absl/strings/str_cat.h"
#include "lane/geometry/bezier.h"
#include "wire/detection_proto.h"

namespace lane::server {
namespace {

constexpr int kLiveCurveSamples = 60;
// Sub-pixel drawing: coordinates are given to OpenCV times 2^kLiveShift.
constexpr int kLiveShift = 4;
const cv::Scalar kUndecodedGrey(48, 48, 48);

cv::Point LiveFixed(const Eigen::Vector2d& p) {
  return cv::Point(static_cast<int>(std::lround(p.x() * (1 << kLiveShift))),
                   static_cast<int>(std::lround(p.y() * (1 << kLiveShift))));
}

bool Drawable(const Eigen::Vector2d& p) {
  return std::isfinite(p.x()) && std::isfinite(p.y()) && p.cwiseAbs().maxCoeff() < 1e5;
}

// The curve's samples mapped by `to_canvas`, in fixed point.
template <class ToCanvas>
std::vector<cv::Point> CurvePoints(const std::array<Eigen::Vector2d, 4>& control,
                                   ToCanvas to_canvas) {
  std::vector<cv::Point> points;
  for (const Eigen::Vector2d& p : lane::Bezier{control}.Sample(kLiveCurveSamples)) {
    const Eigen::Vector2d q = to_canvas(p);
    if (Drawable(q)) points.push_back(LiveFixed(q));
  }
  return points;
}

void DrawCurve(cv::Mat& canvas, const std::vector<cv::Point>& points, const cv::Scalar& colour,
               int thickness, bool dashed) {
  if (points.size() < 2) return;
  if (!dashed) {
    cv::polylines(canvas, points, false, colour, thickness, cv::LINE_AA, kLiveShift);
    return;
  }
  // Dashes and gaps of 3 samples each.
  for (size_t i = 0; i + 1 < points.size(); ++i) {
    if ((i / 3) % 2 == 0) {
      cv::line(canvas, points[i], points[i + 1], colour, thickness, cv::LINE_AA, kLiveShift);
    }
  }
}

// Shades the area between two curves (the ego lane), `alpha` of `colour`.
void ShadeBetween(cv::Mat& canvas, const std::vector<cv::Point>& left,
                  const std::vector<cv::Point>& right, const cv::Scalar& colour, double alpha) {
  if (left.size() < 2 || right.size() < 2) return;
  std::vector<cv::Point> polygon(left);
  polygon.insert(polygon.end(), right.rbegin(), right.rend());
  cv::Mat layer = canvas.clone();
  cv::fillPoly(layer, std::vector<std::vector<cv::Point>>{polygon}, colour, cv::LINE_AA,
               kLiveShift);
  cv::addWeighted(layer, alpha, canvas, 1.0 - alpha, 0.0, canvas);
}

void DrawTag(cv::Mat& canvas, const std::string& text, cv::Point at, const cv::Scalar& colour) {
  const double scale = std::max(0.4, 0.45 * canvas.cols / 640.0);
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline);
  at.x = std::clamp(at.x, 0, std::max(0, canvas.cols - size.width - 4));
  at.y = std::clamp(at.y, size.height + 4, std::max(size.height + 4, canvas.rows - 2));
  cv::rectangle(canvas, {at.x, at.y - size.height - 4}, {at.x + size.width + 4, at.y + baseline},
                cv::Scalar(0, 0, 0), cv::FILLED);
  cv::putText(canvas, text, {at.x + 2, at.y - 2}, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1,
              cv::LINE_AA);
}

// The whole frame as BGR: the rows held, dark grey elsewhere.
cv::Mat FrameCanvas(const LiveFrame& frame) {
  cv::Mat canvas(frame.height, frame.width, CV_8UC3, kUndecodedGrey);
  if (frame.rows.empty()) return canvas;
  cv::Mat target = canvas.rowRange(frame.top, frame.top + frame.rows.rows);
  if (frame.rows.channels() == 1) {
    cv::cvtColor(frame.rows, target, cv::COLOR_GRAY2BGR);
  } else {
    frame.rows.copyTo(target);
  }
  return canvas;
}

// The frame as the detector reads it: its size and pixel type, zeros in the
// rows not held (the detector never reads them).
cv::Mat DetectorInput(const LiveFrame& frame) {
  cv::Mat full = cv::Mat::zeros(frame.height, frame.width, frame.rows.type());
  frame.rows.copyTo(full.rowRange(frame.top, frame.top + frame.rows.rows));
  return full;
}

int TopViewScale(const lane::Detector& detector) {
  return std::clamp(kLiveTopViewWidth / std::max(1, detector.ipm().width()), 1, 8);
}

constexpr int kLiveSlots = 8;

}  // namespace

std::vector<int> LiveLaneSlots(const v1::FrameResponse& response) {
  std::vector<int> slots;
  bool taken[kLiveSlots] = {};
  for (int i = 0; i < response.lanes_size(); ++i) {
    const int id = response.lanes(i).id();
    int slot = ((id > 0 ? id - 1 : i) % kLiveSlots + kLiveSlots) % kLiveSlots;
    for (int k = 0; k < kLiveSlots && taken[slot]; ++k) slot = (slot + 1) % kLiveSlots;
    taken[slot] = true;
    slots.push_back(slot);
  }
  return slots;
}

cv::Scalar LiveSlotColour(int slot) {
  static const cv::Scalar kPalette[kLiveSlots] = {
      {0, 255, 0},    // green
      {255, 128, 0},  // azure
      {0, 215, 255},  // gold
      {255, 0, 255},  // magenta
      {255, 255, 0},  // cyan
      {0, 128, 255},  // orange
      {128, 0, 255},  // pink
      {255, 0, 128},  // violet
  };
  return kPalette[((slot % kLiveSlots) + kLiveSlots) % kLiveSlots];
}

std::string LiveSlotHex(int slot) {
  const cv::Scalar c = LiveSlotColour(slot);
  char hex[8];
  std::snprintf(hex, sizeof(hex), "#%02x%02x%02x", static_cast<int>(c[2]), static_cast<int>(c[1]),
                static_cast<int>(c[0]));
  return hex;
}

uint64_t LivePictureBytes(int width, int height, const lane::Detector& detector) {
  const uint64_t frame = uint64_t(std::max(0, width)) * uint64_t(std::max(0, height)) * 3;
  const int s = TopViewScale(detector);
  const uint64_t top = uint64_t(detector.ipm().width()) * detector.ipm().height() * s * s * 3;
  // Canvases: the frame, its shading layer and the detector's input; the top
  // view, stretched, enlarged and in colour. Kept: both JPEGs, each at most
  // its raw size.
  return 3 * frame + 3 * top + frame + top;
}

namespace {

// The session camera's horizon (dashed) and vanishing point on the frame.
void DrawHorizonAndVanishingPoint(cv::Mat& canvas, const lane::CameraModel& camera) {
  const double horizon = camera.HorizonRow();
  if (std::isfinite(horizon) && horizon >= 0 && horizon < canvas.rows) {
    const int y = static_cast<int>(std::lround(horizon));
    for (int x = 0; x < canvas.cols; x += 14) {
      cv::line(canvas, {x, y}, {std::min(x + 7, canvas.cols - 1), y}, cv::Scalar(220, 220, 220), 1);
    }
    DrawTag(canvas, "horizon", {4, y - 4}, cv::Scalar(220, 220, 220));
  }
  const Eigen::Vector2d vp = camera.VanishingPoint();
  if (Drawable(vp)) {
    const cv::Point c(static_cast<int>(std::lround(vp.x())), static_cast<int>(std::lround(vp.y())));
    const cv::Scalar yellow(0, 230, 255);
    cv::circle(canvas, c, 6, yellow, 1, cv::LINE_AA);
    cv::line(canvas, c - cv::Point(10, 0), c + cv::Point(10, 0), yellow, 1, cv::LINE_AA);
    cv::line(canvas, c - cv::Point(0, 10), c + cv::Point(0, 10), yellow, 1, cv::LINE_AA);
  }
}

// The detector's top view of the frame, stretched and enlarged, with the
// lanes (ego lane shaded between `ego_left` and `ego_right`, -1: none); an
// empty picture when there is none.
cv::Mat DrawLiveTopView(const LiveFrame& frame, const lane::Detector& detector,
                        const std::vector<lane::TrackedLane>& lanes,
                        const std::vector<int>& slots, int ego_left, int ego_right) {
  const cv::Mat view = detector.ipm().Apply(detector.ExtractChannel(DetectorInput(frame)));
  if (view.empty()) return cv::Mat();
  cv::Mat stretched;
  cv::normalize(view, stretched, 0, 255, cv::NORM_MINMAX, CV_8U);
  const int s = TopViewScale(detector);
  cv::Mat big;
  cv::resize(stretched, big, cv::Size(), s, s, cv::INTER_NEAREST);
  cv::Mat top;
  cv::cvtColor(big, top, cv::COLOR_GRAY2BGR);
  // IPM pixel (col, row) covers [s*col, s*(col+1)) of the canvas.
  const auto to_top = [s](const Eigen::Vector2d& p) {
    return Eigen::Vector2d((p.x() + 0.5) * s - 0.5, (p.y() + 0.5) * s - 0.5);
  };
  if (ego_left >= 0 && ego_right >= 0) {
    ShadeBetween(top, CurvePoints(lanes[size_t(ego_left)].lane.ipm, to_top),
                 CurvePoints(lanes[size_t(ego_right)].lane.ipm, to_top), cv::Scalar(80, 200, 80),
                 0.25);
  }
  for (size_t i = 0; i < lanes.size(); ++i) {
    const lane::Lane& lane = lanes[i].lane;
    DrawCurve(top, CurvePoints(lane.ipm, to_top), LiveSlotColour(slots[i]), 2,
              lanes[i].predicted || lane.inferred);
  }
  return top;
}

}  // namespace

LiveDrawing DrawLiveSample(const LiveSample& sample, const lane::Detector& detector) {
  LiveDrawing out;
  const LiveFrame& frame = sample.frame;
  const std::vector<lane::TrackedLane> lanes = lane::wire::LanesFromProto(sample.response);
  const std::vector<int> slots = LiveLaneSlots(sample.response);
  const lane::CameraModel& camera = detector.ipm().camera();
  const auto identity = [](const Eigen::Vector2d& p) { return p; };

  // The frame.
  out.frame = FrameCanvas(frame);
  cv::Mat& canvas = out.frame;
  if (frame.top > 0 || frame.top + frame.rows.rows < frame.height) {
    DrawTag(canvas,
            absl::StrCat("decoded: rows ", frame.top, "-", frame.top + frame.rows.rows - 1,
                         " (what the detector reads)"),
            {4, 20}, cv::Scalar(200, 200, 200));
  }
  // The ego lane's boundaries, found among the lanes by their ids.
  const std::optional<lane::EgoLane> ego_lane = lane::wire::EgoFromProto(sample.response);
  const int ego_left = ego_lane ? ego_lane->left_index : -1;
  const int ego_right = ego_lane ? ego_lane->right_index : -1;
  if (ego_left >= 0 && ego_right >= 0) {
    ShadeBetween(canvas, CurvePoints(lanes[size_t(ego_left)].lane.image, identity),
                 CurvePoints(lanes[size_t(ego_right)].lane.image, identity),
                 cv::Scalar(80, 200, 80), 0.25);
  }
  DrawHorizonAndVanishingPoint(canvas, camera);
  for (size_t i = 0; i < lanes.size(); ++i) {
    const lane::TrackedLane& tracked = lanes[i];
    const lane::Lane& lane = tracked.lane;
    const cv::Scalar colour = LiveSlotColour(slots[i]);
    const bool ego = static_cast<int>(i) == ego_left || static_cast<int>(i) == ego_right;
    DrawCurve(canvas, CurvePoints(lane.image, identity), colour, ego ? 3 : 2,
              tracked.predicted || lane.inferred);
    if (tracked.id > 0) {
      const Eigen::Vector2d& low =
          lane.image[0].y() > lane.image[3].y() ? lane.image[0] : lane.image[3];
      if (Drawable(low)) {
        DrawTag(canvas, absl::StrCat("#", tracked.id),
                {static_cast<int>(low.x()) - 12, static_cast<int>(low.y()) - canvas.rows / 10},
                colour);
      }
    }
  }
  DrawTag(canvas,
          absl::StrCat("frame ", sample.response.frame_id(), ", ", lanes.size(),
                       lanes.size() == 1 ? " lane" : " lanes"),
          {4, canvas.rows - 4}, cv::Scalar(255, 255, 255));

  // The top view.
  if (!frame.rows.empty())
    out.top = DrawLiveTopView(frame, detector, lanes, slots, ego_left, ego_right);
  return out;
}

}  // namespace lane::server
