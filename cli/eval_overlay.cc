#include "eval_overlay.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <string>

#include "absl/strings/str_cat.h"

namespace lane::cli {
namespace {

using lane::eval::Curve;

// BGR.
const cv::Scalar kGreen(0, 200, 0);
const cv::Scalar kRed(0, 0, 255);
const cv::Scalar kBlue(255, 80, 0);
const cv::Scalar kGrey(170, 170, 170);
const cv::Scalar kOrange(0, 140, 255);
const cv::Scalar kWhite(255, 255, 255);

constexpr int kShift = 4;  // sub-pixel drawing
constexpr double kOne = 1 << kShift;

void DrawCurve(cv::Mat& canvas, const Curve& curve, const cv::Scalar& colour, int thickness) {
  std::vector<cv::Point> points;
  for (const Eigen::Vector2d& p : curve.DrawPoints(50)) {
    if (!p.allFinite() || p.cwiseAbs().maxCoeff() > 1e5) continue;
    points.emplace_back(static_cast<int>(std::lround(p.x() * kOne)),
                        static_cast<int>(std::lround(p.y() * kOne)));
  }
  if (points.size() >= 2) {
    cv::polylines(canvas, points, /*isClosed=*/false, colour, thickness, cv::LINE_AA, kShift);
  }
}

void DashedRow(cv::Mat& canvas, int y, const cv::Scalar& colour, int thickness) {
  if (y < 0 || y >= canvas.rows) return;
  const int dash = std::max(6, canvas.cols / 100);
  for (int x = 0; x < canvas.cols; x += 2 * dash) {
    cv::line(canvas, {x, y}, {std::min(x + dash, canvas.cols - 1), y}, colour, thickness);
  }
}

// White text on a dark box, top-left corner at (x, y); returns the box's
// bottom.
int Caption(cv::Mat& canvas, const std::string& text, int x, int y, double scale,
            const cv::Scalar& colour) {
  int baseline = 0;
  const int thickness = std::max(1, static_cast<int>(std::lround(scale * 1.5)));
  const cv::Size size =
      cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, thickness, &baseline);
  const int pad = std::max(2, static_cast<int>(std::lround(4 * scale)));
  cv::rectangle(canvas, {x, y}, {x + size.width + 2 * pad, y + size.height + baseline + 2 * pad},
                cv::Scalar(0, 0, 0), cv::FILLED);
  cv::putText(canvas, text, {x + pad, y + pad + size.height}, cv::FONT_HERSHEY_SIMPLEX, scale,
              colour, thickness, cv::LINE_AA);
  return y + size.height + baseline + 2 * pad;
}

// Draws a scored frame's labels and detections in their colours; returns its counts line.
std::string DrawScoredFrame(cv::Mat& canvas, const lane::eval::FrameOutcome& outcome,
                            const lane::eval::EvalOptions& options, int thin, int thick) {
  const lane::eval::LabelledFrame& labelled = *outcome.frame;
  const lane::eval::FrameScore& score = *outcome.score;
  std::vector<bool> scored(labelled.boundaries.size(), false);
  for (int i : score.scored_labels) scored[i] = true;
  for (size_t i = 0; i < labelled.boundaries.size(); ++i) {
    if (!scored[i]) DrawCurve(canvas, labelled.boundaries[i].curve, kGrey, thin);
  }
  if (options.mode == lane::Mode::kTwo) {
    const double row =
        options.ego_row >= 0 ? std::min(options.ego_row, canvas.rows - 1.0) : canvas.rows - 1.0;
    DashedRow(canvas, static_cast<int>(std::lround(row)), kGrey, thin);
    const int cx = canvas.cols / 2;
    cv::line(canvas, {cx, static_cast<int>(row) - 4 * thick},
             {cx, static_cast<int>(row) + 4 * thick}, kGrey, thin);
  }
  // Missed labels first, then detections, then matched labels on top so a
  // correct detection shows its label inside it.
  for (size_t k = 0; k < score.scored_labels.size(); ++k) {
    if (score.paper.label_detection[k] < 0) {
      DrawCurve(canvas, labelled.boundaries[score.scored_labels[k]].curve, kBlue, thick);
    }
  }
  for (size_t d = 0; d < outcome.lanes.size(); ++d) {
    const bool correct = score.paper.detection_label[d] >= 0;
    DrawCurve(canvas, outcome.lanes[d].curve, correct ? kGreen : kRed, thick);
  }
  for (size_t k = 0; k < score.scored_labels.size(); ++k) {
    if (score.paper.label_detection[k] >= 0) {
      DrawCurve(canvas, labelled.boundaries[score.scored_labels[k]].curve,
                cv::Scalar(150, 255, 150), thin);
    }
  }
  return absl::StrCat("paper: ", score.paper.MatchedLabels(), "/", score.scored_labels.size(),
                      " found, ", score.paper.FalsePositives(), " FP   CULane: TP ",
                      score.culane.MatchedDetections(), " FP ", score.culane.FalsePositives(),
                      " FN ", score.culane.Misses());
}

// Writes the detections' scores in their colours at row y; returns the row below them.
int DrawLaneScores(cv::Mat& canvas, const lane::eval::FrameOutcome& outcome, int margin, int y,
                   double text_scale) {
  std::string text = "scores:";
  int x = margin;
  int baseline = 0;
  const int text_thickness = std::max(1, static_cast<int>(std::lround(text_scale * 1.5)));
  const auto width = [&](const std::string& t) {
    return cv::getTextSize(t, cv::FONT_HERSHEY_SIMPLEX, text_scale, text_thickness, &baseline)
               .width +
           2 * std::max(2, static_cast<int>(std::lround(4 * text_scale)));
  };
  int bottom = Caption(canvas, text, x, y, text_scale, kWhite);
  x += width(text);
  for (size_t d = 0; d < outcome.lanes.size(); ++d) {
    cv::Scalar colour = kOrange;
    if (outcome.score) colour = outcome.score->paper.detection_label[d] >= 0 ? kGreen : kRed;
    char score[32];
    std::snprintf(score, sizeof(score), "%.1f", outcome.lanes[d].score);
    Caption(canvas, score, x, y, text_scale, colour);
    x += width(score);
  }
  return bottom;
}

// Writes the legend in the colours it explains at row y.
void DrawLegend(cv::Mat& canvas, int margin, int y, double text_scale) {
  int x = margin;
  for (const auto& [text, colour] : {std::pair<const char*, cv::Scalar>{"label / correct", kGreen},
                                     {"false positive", kRed},
                                     {"miss", kBlue}}) {
    int baseline = 0;
    const int text_thickness = std::max(1, static_cast<int>(std::lround(text_scale * 1.5)));
    const cv::Size size =
        cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, text_scale, text_thickness, &baseline);
    Caption(canvas, text, x, y, text_scale, colour);
    x += size.width + 3 * margin;
  }
}

}  // namespace

cv::Mat DrawEvaluation(const cv::Mat& frame, const lane::eval::FrameOutcome& outcome,
                       const lane::eval::EvalOptions& options,
                       const std::optional<lane::Roi>& roi) {
  cv::Mat canvas;
  if (frame.channels() == 1) {
    cv::cvtColor(frame, canvas, cv::COLOR_GRAY2BGR);
  } else {
    canvas = frame.clone();
  }
  if (canvas.empty()) return canvas;
  const double s = canvas.cols / 640.0;
  const int thin = std::max(1, static_cast<int>(std::lround(1.5 * s)));
  const int thick = std::max(2, static_cast<int>(std::lround(3 * s)));

  if (roi) {
    cv::rectangle(canvas, cv::Point2d(roi->left, roi->top), cv::Point2d(roi->right, roi->bottom),
                  kGrey, 1);
  }
  const lane::eval::LabelledFrame& labelled = *outcome.frame;
  std::string counts;
  if (outcome.score) {
    counts = DrawScoredFrame(canvas, outcome, options, thin, thick);
  } else {
    for (const lane::eval::DetectedLane& lane : outcome.lanes) {
      DrawCurve(canvas, lane.curve, kOrange, thick);
    }
    counts = "no labels: not scored";
  }
  const double text_scale = std::max(0.4, 0.5 * s);
  const int margin = static_cast<int>(std::lround(4 * s));
  std::string title = labelled.name;
  if (!outcome.error.empty()) absl::StrAppend(&title, "  FAILED: ", outcome.error);
  if (outcome.missing_result) absl::StrAppend(&title, "  (no results record)");
  int y = Caption(canvas, title, margin, margin, text_scale, kWhite);
  y = Caption(canvas, counts, margin, y, text_scale, kWhite);
  if (!outcome.lanes.empty()) y = DrawLaneScores(canvas, outcome, margin, y, text_scale);
  DrawLegend(canvas, margin, y, text_scale);
  return canvas;
}

}  // namespace lane::cli
