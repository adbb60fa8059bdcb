// --overlay-video FILE of `lane detect` and `lane-client stream`: the frames
// with their lanes drawn (DrawLanesOnImage) written as one video through
// OpenCV's VideoWriter (FFmpeg).
#ifndef LANE_IO_OVERLAY_VIDEO_H_
#define LANE_IO_OVERLAY_VIDEO_H_

#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>
#include <string>

namespace lane::io {

class OverlayVideo {
 public:
  // The codec follows the extension: .mp4, .mov and .mkv get MPEG-4 Part 2
  // ("mp4v", which every player reads), .avi Motion JPEG. `fps` is the
  // video's frame rate (the source's when known).
  OverlayVideo(std::string path, double fps);
  ~OverlayVideo();

  // Appends a drawn frame (BGR). The first frame fixes the size; frames of
  // another size are scaled to it. An error message or "".
  std::string Add(const cv::Mat& bgr);
  // Finishes the file. An error message or "".
  std::string Close();
  int frames() const { return frames_; }

  // "" if `path` has an extension the writer knows, else why not.
  static std::string CheckPath(const std::string& path);

 private:
  const std::string path_;
  const double fps_;
  std::unique_ptr<cv::VideoWriter> writer_;
  cv::Size size_;
  int frames_ = 0;
  bool failed_ = false;
};

}  // namespace lane::io

#endif  // LANE_IO_OVERLAY_VIDEO_H_
