// Frames from the command line's INPUT arguments: image files, directories of
// images, list files and videos.
#ifndef LANE_IO_INPUTS_H_
#define LANE_IO_INPUTS_H_

#include <cstdint>
#include <fstream>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "io/input_file.h"
#include "io/pacer.h"
#include "io/video_input.h"
#include "lane/detector/detector.h"

namespace lane::io {

struct InputFrame {
  // The frame's name in results: the file name for a file given directly or
  // found in a directory, the line for an entry of a list file, and
  // "video.mp4#000123" (0-based frame index) for a frame of a video.
  std::string name;
  // `name` made into a file name stem: extension dropped, '/' and '#' -> '_'.
  std::string stem;
  // CV_8UC3; empty when `error` is set. With FrameReader::DecodeOnly, an
  // image file's frame may hold only the detector's rows, and be CV_8UC1
  // (its channel).
  cv::Mat bgr;
  std::string error;  // why the frame could not be read, or empty
  double decode_ms = 0;
  double source_fps = 0;  // a video file's frame rate, when it says; else 0
};

// What a reader's Next hands out: limits and pacing shared by `lane detect`
// and `lane-client stream`.
struct ReadOptions {
  // Frames handed out at most (errors included); 0 = all. Live sources run
  // until they end, so this is how a run on one stops.
  long long max_frames = 0;
  // --fps / --realtime (io/pacer.h).
  Pacer pacer;
  // An image file larger than this fails before it is read, and one whose
  // header declares a frame of more than this many bytes as BGR (width x
  // height x 3) before it is decoded (io/input_file.h).
  int64_t max_image_bytes = kDefaultMaxImageBytes;
};

// One input after expansion: an image file, a video, or an error to report.
struct InputEntry {
  enum Kind { kImage, kVideo, kError } kind = kImage;
  std::string path;   // to open
  std::string name;   // to report (see InputFrame::name)
  std::string error;  // kError: why
  // kVideo: the VideoCapture backend, and whether it is a live source
  // (io/video_input.h), which is not paced.
  int api = cv::CAP_ANY;
  bool live = false;
};

// ReadOptions applied as a reader hands out frames: the count against
// max_frames, and the pacing. Shared by FrameReader and lane-client's
// FrameSource.
class ReadGate {
 public:
  explicit ReadGate(ReadOptions options) : options_(options) {}
  // max_frames handed out already: the reader is done.
  bool Closed() const { return options_.max_frames > 0 && handed_out_ >= options_.max_frames; }
  // Counts a frame handed out; one that was read (not an error) waits for
  // its time at the source's rate.
  void HandOut(bool read, double source_fps) {
    ++handed_out_;
    if (read) options_.pacer.Wait(source_fps);
  }
  // How many frames the entries give, when known without reading them
  // (image files and errors only, within max_frames); 0 with a video or a
  // live source.
  long long KnownFrameCount(const std::vector<InputEntry>& entries) const;

 private:
  ReadOptions options_;
  long long handed_out_ = 0;
};

// Expands the INPUT arguments, following the rules of FrameReader below,
// without opening any image or video. Shared by `lane` and `lane-client`.
std::vector<InputEntry> ExpandInputs(const std::vector<std::string>& inputs);

// A frame name made into a file name stem: the extension of the last path
// component dropped ("video.mp4#000012" -> "video_000012"), '/', '\', '#',
// ':' and ' ' -> '_', leading '.' and '_' removed; "frame" if nothing is left.
std::string MakeStem(const std::string& name);

// A stem not used yet in this run: "name", "name-2", "name-3", ...; the one
// returned is added to `used`.
std::string UniqueStem(const std::string& stem, std::set<std::string>& used);

// Expands the INPUT arguments:
//  * an existing directory: its .jpg/.jpeg/.png files (not recursive), sorted
//    by name;
//  * a .txt file: a list, one path a line; relative paths are resolved
//    against the list's folder; blank lines and lines starting with '#' are
//    skipped; entries may themselves be images, videos, directories or lists;
//  * .mp4/.avi/.mkv/.mov: a video, read frame by frame with cv::VideoCapture;
//  * a URL, /dev/videoN or a GStreamer pipeline: a live source
//    (io/video_input.h), never looked up as a file;
//  * anything else: an image file decoded with cv::imread.
// A missing path, an unreadable list or video, or an undecodable image
// becomes an InputFrame with `error` set, so the caller reports it and goes
// on. Frames are decoded one at a time.
//
// Image files, list files and video files must be regular files
// (io/input_file.h): a FIFO, a socket, a device or a /proc file is that
// frame's error, found without blocking and without reading it. An image
// file over ReadOptions::max_image_bytes fails before it is read, an empty
// one fails without decoding; a list file may hold at most
// kMaxListFileBytes, and lines of at most 4096 bytes.
class FrameReader {
 public:
  explicit FrameReader(const std::vector<std::string>& inputs, ReadOptions options = {});
  ~FrameReader();

  // Fills `frame` with the next frame; false when all inputs are done.
  bool Next(InputFrame* frame);
  // How many frames Next will hand out, when that is known without reading
  // (image files and errors only, within --max-frames); 0 with a video or a
  // live source.
  long long KnownFrameCount() const { return gate_.KnownFrameCount(entries_); }

  // From now on, JPEG files of width x height are decoded only where `needs`
  // (a detector's) says, through lane/decode: the rows it reads and, where it
  // needs one, only its channel. Same lanes, less decoding. Other formats
  // (PNG: see ReadImage) and sizes, and videos, are decoded whole.
  void DecodeOnly(const lane::FrameNeeds& needs, int width, int height);

 private:
  // An image file: read whole (at most max_image_bytes), then decoded
  // through lane/decode's region decoding when asked to and it is a JPEG of
  // the camera's size, else with cv::imdecode (what cv::imread does with the
  // file's bytes).
  void ReadImage(const InputEntry& entry, InputFrame* frame) const;

  // The next frame, before the limit and pacing.
  bool NextUnpaced(InputFrame* frame, double* source_fps);

  std::vector<InputEntry> entries_;
  int64_t max_image_bytes_;
  ReadGate gate_;
  std::optional<lane::FrameNeeds> needs_;
  int width_ = 0, height_ = 0;
  size_t next_ = 0;
  std::unique_ptr<VideoInput> video_;  // the video being read
};

// A video frame's name and stem: "drive.mp4#000012", "drive_000012".
std::string VideoFrameName(const std::string& video_name, int index);

// Opens `path` for writing results (truncating), creating its folder first,
// as the overlay folders are. False when it cannot be opened.
bool OpenOutputFile(const std::string& path, std::ofstream* file);

// Lower-case extension with the dot (".png"), or "".
std::string LowerExtension(const std::string& path);
bool IsImageExtension(const std::string& ext);
bool IsVideoExtension(const std::string& ext);

}  // namespace lane::io

#endif  // LANE_IO_INPUTS_H_
