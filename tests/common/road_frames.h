// Synthetic road frames, encoded frames and session configs for the tests of
// the wire library, the server and the client.
#ifndef LANE_TESTS_COMMON_ROAD_FRAMES_H_
#define LANE_TESTS_COMMON_ROAD_FRAMES_H_

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "lane/geometry/camera.h"
#include "lane/v1/lane_service.pb.h"

namespace lane::testing {

// The Caltech camera scaled by `scale` (frame size, focal lengths and optical
// centre), pitched `pitch_deg` down.
lane::CameraModel ScaledCamera(double scale, double pitch_deg = 14.0);

// A session config for the camera: its calibration, the default IPM with the
// ROI scaled like the camera, the default detector.
v1::SessionConfig SessionConfigFor(const lane::CameraModel& camera);

// Lateral offsets (metres) of the painted lines in RoadFrame.
inline const std::vector<double> kLineOffsets = {-5.4, -1.8, 1.8, 5.4};

// A grey road with white markings 15 cm wide at `offsets` metres, from 2 m to
// 60 m ahead, seen by the camera (BGR). `seed` adds a little noise.
cv::Mat RoadFrame(const lane::CameraModel& camera, const std::vector<double>& offsets,
                  int seed = 0);

std::string EncodeJpeg(const cv::Mat& image, int quality = 90);
std::string EncodePng(const cv::Mat& image);

v1::FrameRequest JpegRequest(const std::string& camera_id, uint64_t frame_id,
                             const std::string& jpeg);

}  // namespace lane::testing

#endif  // LANE_TESTS_COMMON_ROAD_FRAMES_H_
