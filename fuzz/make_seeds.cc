// Writes the synthetic seeds of fuzz/corpus/: small JPEG/PNG frames of the
// synthetic camera's size and serialized FrameRequests.
//
//   make_seeds OUT_DIR   (OUT_DIR/frame_decode, OUT_DIR/frame_request)
#include <cstdio>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "lane/v1/lane_service.pb.h"

namespace {

void Write(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

std::string Encode(const std::string& ext, const cv::Mat& image, std::vector<int> params) {
  std::vector<uchar> out;
  cv::imencode(ext, image, out, params);
  return std::string(out.begin(), out.end());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_seeds OUT_DIR\n");
    return 2;
  }
  const std::string out = argv[1];
  // A dark road with two bright lines converging to the horizon.
  cv::Mat road(480, 640, CV_8UC3, cv::Scalar(60, 60, 60));
  cv::line(road, {150, 479}, {310, 250}, cv::Scalar(230, 230, 230), 6);
  cv::line(road, {490, 479}, {330, 250}, cv::Scalar(230, 230, 230), 6);
  const std::string jpeg = Encode(".jpg", road, {cv::IMWRITE_JPEG_QUALITY, 20});
  cv::Mat grey;
  cv::cvtColor(road, grey, cv::COLOR_BGR2GRAY);
  const std::string png = Encode(".png", grey, {cv::IMWRITE_PNG_COMPRESSION, 9});
  const std::string tiny = Encode(".jpg", cv::Mat(8, 8, CV_8UC3, cv::Scalar(1, 2, 3)), {});
  Write(out + "/frame_decode/road.jpg", jpeg);
  Write(out + "/frame_decode/road.png", png);
  Write(out + "/frame_decode/tiny.jpg", tiny);

  lane::v1::FrameRequest request;
  request.set_camera_id("fuzz");
  request.set_frame_id(1);
  request.set_encoded(jpeg);
  Write(out + "/frame_request/jpeg.pb", request.SerializeAsString());
  lane::v1::FrameRequest raw;
  raw.set_camera_id("fuzz");
  raw.set_frame_id(2);
  raw.mutable_raw()->set_width(8);
  raw.mutable_raw()->set_height(8);
  raw.mutable_raw()->set_pixel_format(lane::v1::PIXEL_FORMAT_GRAY8);
  raw.mutable_raw()->set_data(std::string(64, '\x40'));
  raw.mutable_session_config()->mutable_camera()->set_pitch_deg(10);
  raw.mutable_session_config()->mutable_ipm()->set_width(64);
  Write(out + "/frame_request/raw_with_config.pb", raw.SerializeAsString());

  // A tracker's state with two confirmed lanes 3.6 m apart.
  lane::v1::TrackerState state;
  state.set_version(1);
  state.set_lineage(0x5eed);
  state.set_frames(40);
  state.set_next_id(3);
  state.set_started(true);
  state.set_time_s(1.3);
  for (int id = 1; id <= 2; ++id) {
    lane::v1::TrackedLane* t = state.add_tracks();
    t->set_id(static_cast<uint32_t>(id));
    t->set_confirmed(true);
    t->set_hits(40);
    t->set_age_frames(40);
    for (float v : {id == 1 ? -1.8f : 1.8f, 0.01f, 0.0001f, 5.0f, 30.0f}) t->add_curve(v);
    for (float v : {0.01f, 0.0f, 0.0f, 0.0001f, 0.0f, 1e-7f}) t->add_covariance(v);
    for (float v : {30.0f, 0.0f, 0.0f, 2.0f, 0.5f, 0.0f, 0.0f}) t->add_votes(v);
  }
  Write(out + "/resume_state/two_lanes.pb", state.SerializeAsString());
  return 0;
}
