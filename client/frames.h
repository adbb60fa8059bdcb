// Frames for the service from the command line's INPUT arguments, as
// `lane detect` reads them (directories, list files, videos, image files), but
// without decoding what the server can decode: JPEG and PNG files keep their
// bytes.
#ifndef LANE_CLIENT_FRAMES_H_
#define LANE_CLIENT_FRAMES_H_

#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>
#include <string>
#include <vector>

#include "io/inputs.h"
#include "lane/v1/lane_service.pb.h"

namespace lane::client {

struct ClientFrame {
  // As in `lane detect` results (docs/results-format.md): the file name for a
  // file given directly or found in a directory, the list's line for an entry
  // of a list file, "video.mp4#000123" for a frame of a video.
  std::string name;
  // `name` made into a file name stem (overlays).
  std::string stem;
  // The bytes of a JPEG or PNG file, sent as they are ...
  std::string encoded;
  // ... or decoded pixels (CV_8UC3 BGR), sent raw: video frames, files with
  // --raw, and files that are neither JPEG nor PNG.
  cv::Mat bgr;
  // Why the frame could not be read (nothing is sent), or empty.
  std::string error;
};

class FrameSource {
 public:
  // Expands the inputs as `lane detect` does (io::ExpandInputs):
  //  * a directory: its .jpg/.jpeg/.png files (not recursive), sorted by name;
  //  * a .txt file: a list, one path a line, relative to the list's folder;
  //    blank lines and '#' comments skipped; entries may be any input;
  //  * .mp4/.avi/.mkv/.mov: a video, read frame by frame;
  //  * a URL, /dev/videoN or a GStreamer pipeline: a live source
  //    (io/video_input.h);
  //  * anything else: an image file.
  // `raw`: decode image files here and send pixels. `options`: a frame limit
  // and pacing (--max-frames, --fps, --realtime).
  FrameSource(const std::vector<std::string>& inputs, bool raw, io::ReadOptions options = {});
  ~FrameSource();
  FrameSource(const FrameSource&) = delete;
  FrameSource& operator=(const FrameSource&) = delete;

  // The next frame; false when every input is done. Reads one file (or one
  // video frame) per call.
  bool Next(ClientFrame* frame);
  // How many frames Next will hand out when that is known without reading
  // (files only, within --max-frames); 0 with a video or a live source.
  long long KnownFrameCount() const { return gate_.KnownFrameCount(entries_); }

 private:
  void ReadImage(const io::InputEntry& entry, ClientFrame* frame) const;
  bool NextUnpaced(ClientFrame* frame, double* source_fps);

  const bool raw_;
  std::vector<io::InputEntry> entries_;
  io::ReadGate gate_;
  size_t next_ = 0;
  std::unique_ptr<io::VideoInput> video_;
};

// "drive.mp4#000012" -> "drive_000012", "a/b.jpg" -> "a_b".
using io::MakeStem;

// True for the bytes of a JPEG or PNG file.
bool IsJpegOrPng(const std::string& bytes);

// Puts the frame's image into the request: `encoded` bytes, or `raw` BGR8.
void SetRequestImage(const ClientFrame& frame, lane::v1::FrameRequest* request);
// BGR8 raw image of a CV_8UC3 Mat (packed rows).
void SetRawBgr(const cv::Mat& bgr, lane::v1::FrameRequest* request);

// The request's image as a BGR (or grey) Mat, for drawing; empty if it
// cannot be decoded.
cv::Mat DecodeRequestImage(const lane::v1::FrameRequest& request);

}  // namespace lane::client

#endif  // LANE_CLIENT_FRAMES_H_
