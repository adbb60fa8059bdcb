// Video inputs of `lane detect` and `lane-client stream`: video files, and
// live sources through OpenCV's VideoCapture backends (Debian's OpenCV has
// FFmpeg, GStreamer and V4L2):
//
//   rtsp://, rtsps://, rtmp://, http://, https://, udp://, tcp://, srt://
//       a network stream (MJPEG over HTTP, RTSP cameras, ...), with FFmpeg;
//   /dev/videoN
//       a V4L2 device (a USB camera, a capture card), with V4L2;
//   a GStreamer pipeline: any INPUT with " ! " in it, ending in an appsink
//       ("videotestsrc num-buffers=30 ! videoconvert ! appsink"), with
//       GStreamer.
//
// A live source is read until it ends (the server closes it, the pipeline
// reaches end-of-stream) or --max-frames.
#ifndef LANE_IO_VIDEO_INPUT_H_
#define LANE_IO_VIDEO_INPUT_H_

#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>
#include <optional>
#include <string>

namespace lane::io {

struct LiveSource {
  int api = cv::CAP_ANY;  // the VideoCapture backend to open it with
  const char* kind = "";  // "stream", "device" or "pipeline", for messages
};

// The backend of a live INPUT (see above), or nullopt for a path.
std::optional<LiveSource> ClassifyLiveSource(const std::string& input);

// One video file or live source, frame by frame.
class VideoInput {
 public:
  // Opens `path` (with OpenCV's backend chatter silenced: the caller reports
  // the failure itself); nullptr when it cannot be opened.
  static std::unique_ptr<VideoInput> Open(const std::string& path, int api = cv::CAP_ANY);

  // The next frame as 8-bit BGR (grey sources are converted); false at the
  // end of the video or stream.
  bool Read(cv::Mat* bgr);
  // Frames read so far: the index of the next one.
  int frames_read() const { return frames_read_; }
  // The source's frame rate, or 0 when it does not say.
  double fps() const { return fps_; }

 private:
  explicit VideoInput(std::unique_ptr<cv::VideoCapture> capture);
  std::unique_ptr<cv::VideoCapture> capture_;
  int frames_read_ = 0;
  double fps_ = 0;
};

}  // namespace lane::io

#endif  // LANE_IO_VIDEO_INPUT_H_
