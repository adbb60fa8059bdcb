// What a lane's marking looks like in the frame: its colour (white, yellow)
// and pattern (solid, dashed, double, road edge), read from the image along
// the lane.
#ifndef LANE_TRACK_MARKING_READER_H_
#define LANE_TRACK_MARKING_READER_H_

#include <opencv2/core.hpp>
#include <vector>

#include "lane/detector/detector.h"
#include "lane/geometry/camera.h"
#include "lane/track/marking.h"

namespace lane {

// A marking's colour from the image along it: the paint's yellowness
// (min(R, G) - B) against the road's beside it, as a share of the paint's
// brightness above the road, so that a white balance shifting both alike
// cancels. Unknown when the paint is not brighter than the road (a road
// edge, a worn marking) or the samples disagree.
// Only rows [top_row, bottom_row) are read (a region-decoded frame); a
// frame that is not BGR gives unknown.
MarkingColor MarkingColorOf(const cv::Mat& bgr, const Lane& lane, const CameraModel& camera,
                            int top_row = 0, int bottom_row = -1);

// A marking's pattern from the image along it, every 0.4 m of road: a bar
// (paint brighter than the road on both sides) at 85 % of the samples with
// no gap of 1 m is solid; gaps of 1.5 m or more between painted runs of
// 0.5 m or more, dashed; two bars 0.1..0.45 m apart across the lane at 40 %
// of the samples wide enough to tell, double; no paint but a brightness
// step along it, a road edge. Reads BGR or one-channel frames, only rows
// [top_row, bottom_row).
MarkingType MarkingTypeOf(const cv::Mat& frame, const Lane& lane, const CameraModel& camera,
                          int top_row = 0, int bottom_row = -1);

// Every lane's colour and type in this frame (MarkingColorOf,
// MarkingTypeOf), one a lane, reading rows [top_row, bottom_row) only. An
// inferred lane's are unknown: what lies there is not its paint.
std::vector<Marking> ReadMarkings(const cv::Mat& frame, const CameraModel& camera,
                                  const std::vector<Lane>& lanes, int top_row = 0,
                                  int bottom_row = -1);

}  // namespace lane

#endif  // LANE_TRACK_MARKING_READER_H_
