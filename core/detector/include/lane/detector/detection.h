// What the detector finds and how it is configured: its options (one
// struct per stage, DetectorOptions), a frame's lanes (Lane, Detection), what
// it reads of a frame (FrameNeeds) and a tracker's prediction for it
// (DetectionPrior). The Detector itself is lane/detector/detector.h; the
// stages that fill a Detection are core/detector/src/pipeline.cc's table.
#ifndef LANE_DETECTOR_DETECTION_H_
#define LANE_DETECTOR_DETECTION_H_

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "lane/detector/road_model.h"
#include "lane/detector/stage_timings.h"
#include "lane/geometry/bezier.h"
#include "lane/geometry/camera.h"
#include "lane/geometry/ground_curve.h"
#include "lane/geometry/ipm.h"
#include "lane/postprocess/postprocess.h"
#include "lane/stages/filter.h"
#include "lane/stages/line_detection.h"
#include "lane/stages/line_fit.h"
#include "lane/stages/spline_fit.h"
#include "lane/stages/threshold.h"
#include "lane/stages/two_lanes.h"

namespace lane {

// kAll: every visible boundary. kTwo: the ego lane's left and right boundary.
enum class Mode { kAll, kTwo };
const char* ModeName(Mode mode);
std::optional<Mode> ParseMode(const std::string& name);

// Which channel of a BGR frame feeds the detector. The paper uses red: it
// shows white and yellow paint brighter against asphalt than grey does.
// kMinRedGreen is min(red, green) per pixel, the paper's "use the colour"
// (section IV): white and yellow paint are bright in both red and green,
// whereas red vehicles, tail lights and brake lights (bright in red only),
// vegetation (green only) and sky or blue signs are not.
enum class Channel { kRed, kGreen, kBlue, kGray, kMinRedGreen };
const char* ChannelName(Channel channel);
std::optional<Channel> ParseChannel(const std::string& name);

struct DetectorOptions {
  Mode mode = Mode::kAll;
  Channel channel = Channel::kRed;
  FilterOptions filter;
  ThresholdOptions threshold;
  HoughOptions hough;
  LineRansacOptions line_ransac;
  SplineRansacOptions spline_ransac;
  PostprocessOptions postprocess;
  TwoLaneOptions two_lanes;
  RoadModelOptions road_model;
  // Seed of the RANSAC sampler. The same frame, options and seed always give
  // the same lanes.
  uint64_t seed = 1;
  // Keep the intermediate images and candidates in Detection::debug.
  bool keep_intermediates = false;

  // The reference defaults for a mode (2-lanes uses narrower windows, a
  // higher quantile and more spline iterations).
  static DetectorOptions ForMode(Mode mode);
  absl::Status Validate() const;
};

struct Lane {
  // Cubic Bezier control points of the same boundary in three frames:
  std::array<Eigen::Vector2d, 4> image;   // image pixels
  std::array<Eigen::Vector2d, 4> ipm;     // IPM pixels (may lie outside the view after extension)
  std::array<Eigen::Vector2d, 4> ground;  // metres: x lateral (right +), y ahead
  double score = 0;                       // spline score in the top view
  // Not seen in this frame: inferred by the road model (lane/detector/road_model.h)
  // half-way between two found boundaries two lane widths apart, where a
  // vehicle hides it. Its score is the weaker neighbour's.
  bool inferred = false;
  // Refitted in a tracker's window (DetectionPrior::refit), not found by the
  // search.
  bool refit = false;
};

// What a tracker adds to a frame's lanes (ids, colours, types, predicted
// lanes, the ego lane) is in lane/track/tracked_frame.h.

struct Intermediates {
  cv::Mat ipm;          // CV_32F top view, mean removed
  cv::Mat filtered;     // CV_32F filter response
  cv::Mat thresholded;  // CV_32F after the quantile threshold
  float threshold = 0;
  std::vector<ColumnPeak> peaks;
  std::vector<IpmLine> lines;       // from the column peaks, then from the prior
  std::vector<Bezier> ipm_splines;  // after RANSAC, before post-processing
};

struct Detection {
  std::vector<Lane> lanes;  // sorted left to right at the bottom of the image
  StageTimings timings;
  std::optional<Intermediates> debug;
  // With a prior that allows refits: how many of `lanes` were refitted in
  // their tracked windows, and how many such windows failed to refit and
  // were searched instead (Detect's step 3b).
  int refit_lanes = 0;
  int refit_failed = 0;
};

// How many of a frame's lanes each path found: refitted in a tracked window
// (Lane::refit), or the search. Inferred lanes were not found in this frame
// and count in neither (nor do a tracker's predicted lanes, which are not
// the detection's). What `lane detect --track`, the service's lanes_found
// counter and the tracked benchmark report.
struct LanePathCounts {
  int refit = 0;
  int searched = 0;
};
LanePathCounts CountLanePaths(const Detection& detection);

// A lane drawn along `curve` over its extent, where it lies below the
// horizon: its ground, image and top-view Beziers fitted to 12 points of
// it, near end first or far end first (the detector's own lanes run far to
// near); none when fewer than 4 of them project into the image.
std::optional<Lane> LaneAlongCurve(const GroundCurve& curve, const IpmMapping& ipm,
                                   bool near_first);

// What the detector reads of a frame: rows [top, bottom) (every column) and
// which pixels. The detector never reads outside these rows, so a decoder
// that produces only them (lane/decode's DecodeImageRegion) gives exactly the
// lanes of a whole frame with the same pixels there.
struct FrameNeeds {
  enum class Pixels {
    kBgr,  // all three channels: the colour check, or a channel computed from
           // them (grey is the BT.601 grey of the decoded colour, as for a
           // whole frame: a JPEG's own luma differs from it by rounding,
           // enough to change RANSAC's draws)
    kRed,  // the red channel alone (channel red, colour check off)
  };
  int top = 0;
  int bottom = 0;
  Pixels pixels = Pixels::kBgr;
};

// What a tracker expects in the next frame (lane/track/sequence_tracker.h,
// SequenceTracker::Prior): each confirmed lane's predicted line in the top
// view, with a search window around it. Detect fits a RANSAC line in the
// window of each predicted lane that the column-sum Hough did not find this
// frame, as if a peak had been there, so that a lane whose column sum fell
// short (a worn or occluded marking, a dashed line between its dashes) is
// found again. The window still needs evidence: the line and spline RANSAC
// and the post-processing checks decide on it as on any other candidate,
// and nothing is added where the window is empty.
//
// With `refit` set, a window whose `refit` is set (a confirmed lane seen in
// the last frame) is not searched: its lane is refitted to this frame's
// response near its predicted curve (a shift and a turn, by weighted least
// squares over each row's localised peak), the column-sum Hough's peaks in
// its window are not searched, and what the search finds along the refitted
// lane is dropped as that lane again. A window that does not refit (too
// little support, or points off one curve) is searched as without `refit`.
struct DetectionPrior {
  struct Window {
    IpmLine line;  // top on row 0, bottom on the last row of the top view
    double half_width_m = 0.5;
    std::optional<GroundCurve> curve;  // the tracked curve, for a refit
    bool refit = false;                // may be refitted (with DetectionPrior::refit)
  };
  std::vector<Window> windows;
  bool refit = false;
};

}  // namespace lane

#endif  // LANE_DETECTOR_DETECTION_H_
