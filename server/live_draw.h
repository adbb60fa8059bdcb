// The live view's pictures of one sample (live_feed.h), drawn on the live
// view's own thread, never on a frame worker.
//
//   frame: the decoded frame at its own size (rows the server did not decode
//          dark grey), the ego lane shaded, each lane as its image Bezier in
//          its colour (dashed when predicted or inferred, labelled "#id"),
//          the horizon (dashed) and the vanishing point of the session's
//          camera;
//   top:   the detector's top view of that frame (its channel through the
//          IPM, stretched to 0..255, enlarged) with each lane's IPM Bezier.
#ifndef LANE_SERVER_LIVE_DRAW_H_
#define LANE_SERVER_LIVE_DRAW_H_

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "lane/detector/detector.h"
#include "lane/v1/lane_service.pb.h"
#include "live_feed.h"

namespace lane::server {

struct LiveDrawing {
  cv::Mat frame;  // CV_8UC3, the frame's size
  cv::Mat top;    // CV_8UC3
};

// The top view is enlarged to about this width.
inline constexpr int kLiveTopViewWidth = 480;

LiveDrawing DrawLiveSample(const LiveSample& sample, const lane::Detector& detector);

// The palette slot of each lane of a response: by its tracking id when it
// has one (so a lane keeps its colour from frame to frame), else by its
// index; a slot another lane of the response took goes to the next free one,
// so that the lanes of one frame differ (up to the palette's 8 colours).
// The picture and the page's table both use it.
std::vector<int> LiveLaneSlots(const v1::FrameResponse& response);
// A slot's colour, BGR and as "#rrggbb".
cv::Scalar LiveSlotColour(int slot);
std::string LiveSlotHex(int slot);

// Bytes drawing and keeping the pictures of a camera may hold: the
// pictures' JPEGs (each refused beyond its raw size) and the canvases, for
// a `width` x `height` frame and its detector's top view.
uint64_t LivePictureBytes(int width, int height, const lane::Detector& detector);

}  // namespace lane::server

#endif  // LANE_SERVER_LIVE_DRAW_H_
