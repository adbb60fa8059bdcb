// Pictures of a detection for people: the frame with the lanes drawn on it,
// and the detector's top view with the lanes drawn in it.
#ifndef LANE_IO_OVERLAY_H_
#define LANE_IO_OVERLAY_H_

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>

#include "lane/detector/detector.h"
#include "lane/track/tracked_frame.h"

namespace lane::io {

// Colour (BGR) of the i-th lane: a fixed palette of distinct colours.
cv::Scalar LaneColour(int i);

// A BGR copy of `frame` (CV_8UC3 or CV_8UC1) with: the mapped ROI as a thin
// red rectangle, the horizon row as a thin grey dashed line, each lane as a
// 2 px polyline through 50 samples of its image Bezier with its control
// points as small circles, and a caption in the top-left corner: the frame's
// name (when given); the mode, the lane count and each lane's score, left to
// right, in the lane's colour; then `details` (when given: the latency).
// A tracked frame's lanes are also labelled "#id colour type" at their lower
// end ('?' until confirmed, "predicted" for a track's prediction), and its
// ego lane is captioned.
cv::Mat DrawLanesOnImage(const cv::Mat& frame, const lane::Detection& detection,
                         const lane::Detector& detector, const std::string& frame_name = "",
                         const std::string& details = "");
cv::Mat DrawLanesOnImage(const cv::Mat& frame, const lane::TrackedFrame& tracked,
                         const lane::Detector& detector, const std::string& frame_name = "",
                         const std::string& details = "");

// White (or `colour`) text on a black box with its top-left corner at (x, y),
// scaled to the frame; returns the box's right edge and bottom.
cv::Point DrawCaption(cv::Mat& canvas, const std::string& text, int x, int y,
                      const cv::Scalar& colour = cv::Scalar(255, 255, 255));

// The detector's top view of `frame` (its channel through the IPM),
// stretched to 0..255, enlarged `scale` times (nearest neighbour), in BGR,
// with each lane's IPM Bezier drawn in its colour.
cv::Mat DrawIpmView(const cv::Mat& frame, const lane::Detection& detection,
                    const lane::Detector& detector, int scale = 4);
cv::Mat DrawIpmView(const cv::Mat& frame, const lane::TrackedFrame& tracked,
                    const lane::Detector& detector, int scale = 4);

// Writes DIR/STEM.png (DrawLanesOnImage) and DIR/STEM_ipm.png
// (DrawIpmView), captioned with `frame_name` and `details`; an error message
// or "".
std::string WriteOverlays(const std::filesystem::path& dir, const std::string& stem,
                          const cv::Mat& frame, const lane::Detection& detection,
                          const lane::Detector& detector, const std::string& frame_name = "",
                          const std::string& details = "");
std::string WriteOverlays(const std::filesystem::path& dir, const std::string& stem,
                          const cv::Mat& frame, const lane::TrackedFrame& tracked,
                          const lane::Detector& detector, const std::string& frame_name = "",
                          const std::string& details = "");

}  // namespace lane::io

#endif  // LANE_IO_OVERLAY_H_
