#include "lane/eval/culane_metric.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "lane/eval/hungarian.h"

namespace lane::eval {
namespace {

// Sub-pixel drawing: coordinates go to OpenCV times 2^kShift.
constexpr int kShift = 4;
// Points further out than this only make OpenCV's clipping overflow.
constexpr double kFar = 1e5;

double Scale(int image_width, const CulaneOptions& options) {
  return image_width > 0 ? static_cast<double>(options.reference_width) / image_width : 1.0;
}

// A lane's mask and where it is non-zero.
struct LaneMask {
  cv::Mat mask;
  cv::Rect box;  // bounding box of the drawing, clipped to the canvas
  int area = 0;
};

LaneMask Draw(const Curve& lane, int image_width, int image_height, const CulaneOptions& options) {
  LaneMask out;
  out.mask = DrawLaneMask(lane, image_width, image_height, options);
  out.area = cv::countNonZero(out.mask);
  out.box = out.area > 0 ? cv::boundingRect(out.mask) : cv::Rect();
  return out;
}

double IoU(const LaneMask& a, const LaneMask& b) {
  const int uni = a.area + b.area;
  if (uni == 0) return 0.0;
  const cv::Rect both = a.box & b.box;
  if (both.empty()) return 0.0;
  cv::Mat inter;
  cv::bitwise_and(a.mask(both), b.mask(both), inter);
  const int i = cv::countNonZero(inter);
  return static_cast<double>(i) / (uni - i);
}

}  // namespace

absl::Status CulaneOptions::Validate() const {
  if (!(line_width_px >= 1) || !std::isfinite(line_width_px)) {
    return absl::InvalidArgumentError(
        absl::StrCat("CULane line width must be >= 1 px, got ", line_width_px));
  }
  if (reference_width <= 0) {
    return absl::InvalidArgumentError("CULane reference width must be positive");
  }
  if (!(iou_threshold > 0 && iou_threshold <= 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("CULane IoU threshold must be in (0, 1], got ", iou_threshold));
  }
  return absl::OkStatus();
}

cv::Size CulaneCanvasSize(int image_width, int image_height, const CulaneOptions& options) {
  const double s = Scale(image_width, options);
  return cv::Size(std::max(1, static_cast<int>(std::lround(image_width * s))),
                  std::max(1, static_cast<int>(std::lround(image_height * s))));
}

cv::Mat DrawLaneMask(const Curve& lane, int image_width, int image_height,
                     const CulaneOptions& options) {
  cv::Mat mask = cv::Mat::zeros(CulaneCanvasSize(image_width, image_height, options), CV_8U);
  const double s = Scale(image_width, options) * (1 << kShift);
  std::vector<cv::Point> points;
  for (const Eigen::Vector2d& p : lane.DrawPoints()) {
    const Eigen::Vector2d q = p * s;
    if (!q.allFinite() || q.cwiseAbs().maxCoeff() > kFar * (1 << kShift)) continue;
    points.emplace_back(static_cast<int>(std::lround(q.x())), static_cast<int>(std::lround(q.y())));
  }
  const int thickness = std::max(1, static_cast<int>(std::lround(options.line_width_px)));
  if (points.size() == 1) points.push_back(points.front());
  if (!points.empty()) {
    cv::polylines(mask, points, /*isClosed=*/false, cv::Scalar(255), thickness, cv::LINE_8, kShift);
  }
  return mask;
}

double MaskIoU(const cv::Mat& a, const cv::Mat& b) {
  CV_Assert(a.size() == b.size() && a.type() == CV_8U && b.type() == CV_8U);
  cv::Mat inter, uni;
  cv::bitwise_and(a, b, inter);
  cv::bitwise_or(a, b, uni);
  const int u = cv::countNonZero(uni);
  return u == 0 ? 0.0 : static_cast<double>(cv::countNonZero(inter)) / u;
}

std::vector<std::vector<double>> LaneIoUs(const std::vector<Curve>& detections,
                                          const std::vector<Curve>& labels, int image_width,
                                          int image_height, const CulaneOptions& options) {
  std::vector<LaneMask> label_masks;
  label_masks.reserve(labels.size());
  for (const Curve& l : labels) label_masks.push_back(Draw(l, image_width, image_height, options));
  std::vector<std::vector<double>> iou(detections.size(), std::vector<double>(labels.size(), 0));
  for (size_t d = 0; d < detections.size(); ++d) {
    const LaneMask det = Draw(detections[d], image_width, image_height, options);
    for (size_t l = 0; l < labels.size(); ++l) iou[d][l] = IoU(det, label_masks[l]);
  }
  return iou;
}

Matching MatchCulane(const std::vector<Curve>& detections, const std::vector<Curve>& labels,
                     int image_width, int image_height, const CulaneOptions& options) {
  Matching m;
  m.detection_label.assign(detections.size(), -1);
  m.label_detection.assign(labels.size(), -1);
  if (detections.empty() || labels.empty()) return m;
  std::vector<std::vector<double>> weight =
      LaneIoUs(detections, labels, image_width, image_height, options);
  for (auto& row : weight) {
    for (double& w : row) {
      if (w < options.iou_threshold) w = 0;
    }
  }
  const std::vector<int> assignment = MaxWeightAssignment(weight);
  for (size_t d = 0; d < assignment.size(); ++d) {
    const int l = assignment[d];
    if (l >= 0 && weight[d][l] >= options.iou_threshold) {
      m.detection_label[d] = l;
      m.label_detection[l] = static_cast<int>(d);
    }
  }
  return m;
}

}  // namespace lane::eval
