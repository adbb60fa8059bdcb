#include "road_frames.h"

#include <cmath>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "lane/geometry/ipm.h"

namespace lane::testing {

lane::CameraModel ScaledCamera(double scale, double pitch_deg) {
  lane::CameraModel camera;
  camera.fu *= scale;
  camera.fv *= scale;
  camera.cu *= scale;
  camera.cv *= scale;
  camera.image_width = static_cast<int>(camera.image_width * scale);
  camera.image_height = static_cast<int>(camera.image_height * scale);
  camera.pitch_deg = pitch_deg;
  return camera;
}

v1::SessionConfig SessionConfigFor(const lane::CameraModel& camera) {
  v1::SessionConfig config;
  v1::CameraCalibration* c = config.mutable_camera();
  c->set_fu(camera.fu);
  c->set_fv(camera.fv);
  c->set_cu(camera.cu);
  c->set_cv(camera.cv);
  c->set_pitch_deg(camera.pitch_deg);
  c->set_yaw_deg(camera.yaw_deg);
  c->set_height_m(camera.height_m);
  c->set_image_width(camera.image_width);
  c->set_image_height(camera.image_height);
  const double scale = camera.image_width / 640.0;
  const lane::Roi roi;  // the default, for 640x480
  v1::Roi* r = config.mutable_ipm()->mutable_roi();
  r->set_left(roi.left * scale);
  r->set_right(roi.right * scale);
  r->set_top(roi.top * scale);
  r->set_bottom(roi.bottom * scale);
  return config;
}

cv::Mat RoadFrame(const lane::CameraModel& camera, const std::vector<double>& offsets, int seed) {
  cv::Mat frame(camera.image_height, camera.image_width, CV_8UC3, cv::Scalar(95, 100, 105));
  // Sky above the horizon.
  const int horizon = static_cast<int>(camera.HorizonRow());
  if (horizon > 0) {
    frame(cv::Rect(0, 0, frame.cols, std::min(horizon, frame.rows)))
        .setTo(cv::Scalar(200, 180, 160));
  }
  const double ys[] = {2, 3, 4, 5, 6, 8, 10, 13, 16, 20, 25, 30, 40, 60};
  const double half_width = 0.075;
  for (const double x : offsets) {
    for (size_t i = 0; i + 1 < std::size(ys); ++i) {
      const Eigen::Vector2d corners[4] = {
          camera.GroundToImage({x - half_width, ys[i]}),
          camera.GroundToImage({x + half_width, ys[i]}),
          camera.GroundToImage({x + half_width, ys[i + 1]}),
          camera.GroundToImage({x - half_width, ys[i + 1]}),
      };
      // Sub-pixel polygon (4 fractional bits) so thin far markings survive.
      std::vector<cv::Point> poly;
      for (const Eigen::Vector2d& p : corners) {
        poly.emplace_back(static_cast<int>(std::lround(p.x() * 16)),
                          static_cast<int>(std::lround(p.y() * 16)));
      }
      cv::fillConvexPoly(frame, poly, cv::Scalar(235, 235, 235), cv::LINE_AA, 4);
    }
  }
  if (seed != 0) {
    cv::Mat noise(frame.size(), CV_16SC3);
    cv::theRNG().state = static_cast<uint64_t>(seed);
    cv::randn(noise, 0, 3);
    cv::Mat noisy;
    frame.convertTo(noisy, CV_16SC3);
    noisy += noise;
    noisy.convertTo(frame, CV_8UC3);
  }
  return frame;
}

std::string EncodeJpeg(const cv::Mat& image, int quality) {
  std::vector<uchar> bytes;
  cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, quality});
  return std::string(bytes.begin(), bytes.end());
}

std::string EncodePng(const cv::Mat& image) {
  std::vector<uchar> bytes;
  cv::imencode(".png", image, bytes);
  return std::string(bytes.begin(), bytes.end());
}

v1::FrameRequest JpegRequest(const std::string& camera_id, uint64_t frame_id,
                             const std::string& jpeg) {
  v1::FrameRequest request;
  request.set_camera_id(camera_id);
  request.set_frame_id(frame_id);
  request.set_capture_time_unix_ns(static_cast<int64_t>(1'700'000'000'000'000'000 + frame_id));
  request.set_encoded(jpeg);
  return request;
}

}  // namespace lane::testing
