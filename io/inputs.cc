#include "io/inputs.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <system_error>
#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/time/time.h"
#include "io/input_file.h"
#include "lane/decode/detector_region.h"

namespace lane::io {
namespace {

namespace fs = std::filesystem;

// Lists may name lists; this stops a list that names itself.
constexpr int kMaxListDepth = 8;
// A list file's line: a path (PATH_MAX is 4096).
constexpr size_t kMaxListLineBytes = 4096;

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// " (path)" when the path differs from the name the frame is reported as.
std::string PathNote(const std::string& path, const std::string& name) {
  return path == name ? std::string() : absl::StrCat(" (", path, ")");
}

}  // namespace

std::string VideoFrameName(const std::string& video_name, int index) {
  char digits[32];
  std::snprintf(digits, sizeof(digits), "%06d", index);
  return absl::StrCat(video_name, "#", digits);
}

bool OpenOutputFile(const std::string& path, std::ofstream* file) {
  const fs::path parent = fs::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) fs::create_directories(parent, ec);
  file->open(path, std::ios::binary | std::ios::trunc);
  return static_cast<bool>(*file);
}

std::string LowerExtension(const std::string& path) {
  return absl::AsciiStrToLower(fs::path(path).extension().string());
}

bool IsImageExtension(const std::string& ext) {
  return ext == ".jpg" || ext == ".jpeg" || ext == ".png";
}

bool IsVideoExtension(const std::string& ext) {
  return ext == ".mp4" || ext == ".avi" || ext == ".mkv" || ext == ".mov";
}

namespace {

void ExpandInto(const std::string& path, const std::string& name, bool top_level, int depth,
                std::vector<InputEntry>& entries);

}  // namespace

std::vector<InputEntry> ExpandInputs(const std::vector<std::string>& inputs) {
  std::vector<InputEntry> entries;
  for (const std::string& input : inputs) ExpandInto(input, input, /*top_level=*/true, 0, entries);
  return entries;
}

std::string MakeStem(const std::string& name) {
  std::string stem = name;
  const size_t slash = stem.find_last_of('/');
  const size_t dot = stem.find_last_of('.');
  const size_t hash = stem.find_last_of('#');
  // The extension of the last path component (for "video.mp4#000012", of the
  // video's name).
  if (dot != std::string::npos && dot > 0 && (slash == std::string::npos || dot > slash)) {
    if (hash != std::string::npos && hash > dot) {
      stem.erase(dot, hash - dot);
    } else {
      stem.resize(dot);
    }
  }
  for (char& c : stem) {
    if (c == '/' || c == '\\' || c == '#' || c == ':' || c == ' ') c = '_';
  }
  const size_t first = stem.find_first_not_of("._");
  stem = first == std::string::npos ? std::string() : stem.substr(first);
  return stem.empty() ? std::string("frame") : stem;
}

std::string UniqueStem(const std::string& stem, std::set<std::string>& used) {
  std::string candidate = stem;
  for (int i = 2; !used.insert(candidate).second; ++i) candidate = absl::StrCat(stem, "-", i);
  return candidate;
}

FrameReader::FrameReader(const std::vector<std::string>& inputs, ReadOptions options)
    : entries_(ExpandInputs(inputs)), max_image_bytes_(options.max_image_bytes), gate_(options) {}

FrameReader::~FrameReader() = default;

namespace {

// A list file's entries, each expanded as ExpandInto does. Opened without
// blocking and read line by line within bounds: a list that is a FIFO, a
// device or a /proc file, or that holds one endless line, is an error
// entry, not a hang or all of memory.
void ExpandListFile(const std::string& path, const std::string& name, int depth,
                    std::vector<InputEntry>& entries) {
  if (depth >= kMaxListDepth) {
    entries.push_back({InputEntry::kError, path, name,
                       absl::StrCat("lists nested too deeply", PathNote(path, name))});
    return;
  }
  absl::StatusOr<OpenedFile> list = OpenRegularFile(path);
  if (list.ok() && list->size > kMaxListFileBytes) {
    list = absl::OutOfRangeError(absl::StrCat(path, ": ", list->size, " bytes, over the cap of ",
                                              kMaxListFileBytes, " bytes for a list"));
  }
  if (!list.ok()) {
    entries.push_back({InputEntry::kError, path, name,
                       absl::StrCat("cannot read list ", list.status().message())});
    return;
  }
  const fs::path folder = fs::path(path).parent_path();
  BoundedLineReader lines(std::move(list->fd), kMaxListLineBytes);
  for (;;) {
    absl::StatusOr<std::optional<std::string>> line = lines.Next();
    if (!line.ok()) {
      entries.push_back({InputEntry::kError, path, name,
                         absl::StrCat("cannot read list ", path, ": ", line.status().message())});
      return;
    }
    if (!line->has_value()) break;
    const std::string entry = std::string(absl::StripAsciiWhitespace(**line));
    if (entry.empty() || entry[0] == '#') continue;
    const fs::path entry_path(entry);
    const std::string resolved =
        entry_path.is_absolute() ? entry : (folder / entry_path).lexically_normal().string();
    ExpandInto(resolved, entry, /*top_level=*/false, depth + 1, entries);
  }
}

void ExpandInto(const std::string& path, const std::string& name, bool top_level, int depth,
                std::vector<InputEntry>& entries) {
  if (const std::optional<LiveSource> live = ClassifyLiveSource(path)) {
    // Reported as given (a URL's or a pipeline's "file name" means nothing).
    entries.push_back({InputEntry::kVideo, path, name, "", live->api, true});
    return;
  }
  // Given directly, a file is reported by its file name; inside a list, by
  // the list's line.
  const std::string file_name = fs::path(path).filename().string();
  const std::string reported = top_level && !file_name.empty() ? file_name : name;
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) {
    entries.push_back({InputEntry::kError, path, reported,
                       absl::StrCat("no such file or directory", PathNote(path, reported))});
    return;
  }
  if (fs::is_directory(status)) {
    std::vector<std::string> files;
    for (fs::directory_iterator it(path, ec), end; !ec && it != end; it.increment(ec)) {
      const std::string file = it->path().filename().string();
      // The entry's type from the listing (d_type): no stat per file.
      std::error_code type_ec;
      if (IsImageExtension(LowerExtension(file)) && !it->is_directory(type_ec)) {
        files.push_back(file);
      }
    }
    if (ec) {
      entries.push_back(
          {InputEntry::kError, path, name,
           absl::StrCat("cannot list directory", PathNote(path, name), ": ", ec.message())});
      return;
    }
    if (files.empty()) {
      std::fprintf(stderr, "warning: no .jpg/.jpeg/.png files in %s\n", path.c_str());
    }
    std::sort(files.begin(), files.end());
    for (const std::string& file : files) {
      const std::string entry_name =
          top_level ? file
                    : absl::StrCat(name, name.empty() || name.back() == '/' ? "" : "/", file);
      entries.push_back({InputEntry::kImage, (fs::path(path) / file).string(), entry_name, ""});
    }
    return;
  }
  const std::string ext = LowerExtension(path);
  if (ext == ".txt") {
    ExpandListFile(path, name, depth, entries);
    return;
  }
  entries.push_back(
      {IsVideoExtension(ext) ? InputEntry::kVideo : InputEntry::kImage, path, reported, ""});
}

}  // namespace

void FrameReader::DecodeOnly(const lane::FrameNeeds& needs, int width, int height) {
  needs_ = needs;
  width_ = width;
  height_ = height;
}

void FrameReader::ReadImage(const InputEntry& entry, InputFrame* frame) const {
  const auto start = std::chrono::steady_clock::now();
  // Every image is read here, within bounds, and decoded from memory: a
  // FIFO, a device or a /proc file fails without blocking, a file over the
  // cap before it is read (io/input_file.h).
  absl::StatusOr<std::string> read = ReadRegularFile(entry.path, max_image_bytes_);
  if (!read.ok()) {
    frame->error = absl::StrCat("cannot read image ", read.status().message());
    return;
  }
  const std::string& bytes = *read;
  if (bytes.empty()) {
    frame->error = absl::StrCat("empty image file", PathNote(entry.path, entry.name));
    return;
  }
  if (bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max())) {
    // Only with a cap raised past 2 GiB: OpenCV's buffers are int-sized.
    frame->error = absl::StrCat("image file over 2 GiB", PathNote(entry.path, entry.name));
    return;
  }
  const absl::StatusOr<lane::decode::EncodedHeader> header = lane::decode::ReadEncodedHeader(bytes);
  // A frame bigger than the cap decoded is refused before it is decoded (a
  // small PNG can declare a huge frame).
  if (header.ok() && int64_t{header->width} * header->height * 3 > max_image_bytes_) {
    frame->error = absl::StrCat("image of ", header->width, "x", header->height,
                                " pixels: over the cap of ", max_image_bytes_,
                                " bytes decoded (3 a pixel)", PathNote(entry.path, entry.name));
    return;
  }
  // JPEG only: lane/decode's PNG reader (libpng's push reader, which bounds
  // decompression bombs for the service) must inflate every row above the
  // region anyway, and is slower than OpenCV's (2026-12-02, cordova1's
  // 640x480 PNGs: 11-12 against 8.5-9 ms).
  if (needs_ && header.ok() && header->format == lane::decode::EncodedFormat::kJpeg &&
      header->width == width_ && header->height == height_) {
    lane::decode::DecodeOptions options;
    options.width = width_;
    options.height = height_;
    options.max_pixels = int64_t{width_} * height_;
    options.cpu_budget = absl::InfiniteDuration();  // a file on disk, not a client
    options.accept_damaged = true;                  // as cv::imread does
    absl::StatusOr<cv::Mat> decoded = lane::decode::DecodeForDetector(bytes, options, *needs_);
    frame->decode_ms = MillisecondsSince(start);
    if (decoded.ok()) {
      frame->bgr = *std::move(decoded);
    } else {
      frame->error = absl::StrCat(decoded.status().message(), PathNote(entry.path, entry.name));
    }
    return;
  }
  try {
    // Wraps the bytes without copying them (imdecode only reads them).
    const cv::Mat encoded(1, static_cast<int>(bytes.size()), CV_8UC1,
                          const_cast<char*>(bytes.data()));
    frame->bgr = cv::imdecode(encoded, cv::IMREAD_COLOR);
  } catch (const cv::Exception&) {
    frame->bgr.release();  // e.g. a size over OpenCV's own pixel limit
  }
  frame->decode_ms = MillisecondsSince(start);
  if (frame->bgr.empty()) {
    frame->error = absl::StrCat("cannot decode image", PathNote(entry.path, entry.name));
  }
}

long long ReadGate::KnownFrameCount(const std::vector<InputEntry>& entries) const {
  for (const InputEntry& entry : entries) {
    if (entry.kind == InputEntry::kVideo) return 0;
  }
  const long long n = static_cast<long long>(entries.size());
  return options_.max_frames > 0 ? std::min(n, options_.max_frames) : n;
}

bool FrameReader::Next(InputFrame* frame) {
  if (gate_.Closed()) return false;
  double source_fps = 0;
  if (!NextUnpaced(frame, &source_fps)) return false;
  frame->source_fps = source_fps;
  gate_.HandOut(frame->error.empty(), source_fps);
  return true;
}

bool FrameReader::NextUnpaced(InputFrame* frame, double* source_fps) {
  while (next_ < entries_.size()) {
    const InputEntry& entry = entries_[next_];
    *frame = InputFrame();
    frame->name = entry.name;
    frame->stem = MakeStem(entry.name);
    switch (entry.kind) {
      case InputEntry::kError:
        frame->error = entry.error;
        ++next_;
        return true;
      case InputEntry::kImage:
        ReadImage(entry, frame);
        ++next_;
        return true;
      case InputEntry::kVideo: {
        const char* what = entry.live ? "cannot open live source" : "cannot open video";
        if (!video_ && !entry.live) {
          // OpenCV's backends block on a FIFO and read a device or /proc file
          // as if it were a video: only a regular file goes to them.
          if (absl::Status file = OpenRegularFile(entry.path).status(); !file.ok()) {
            frame->error = absl::StrCat(what, " ", file.message());
            ++next_;
            return true;
          }
        }
        if (!video_) {
          video_ = VideoInput::Open(entry.path, entry.api);
          if (!video_) {
            frame->error = absl::StrCat(what, PathNote(entry.path, entry.name));
            ++next_;
            return true;
          }
        }
        const auto start = std::chrono::steady_clock::now();
        const int index = video_->frames_read();
        if (video_->Read(&frame->bgr)) {
          frame->decode_ms = MillisecondsSince(start);
          frame->name = VideoFrameName(entry.name, index);
          frame->stem = MakeStem(frame->name);
          *source_fps = entry.live ? 0 : video_->fps();
          return true;
        }
        const bool empty_video = index == 0;
        video_.reset();
        ++next_;
        if (empty_video) {
          frame->error =
              absl::StrCat("no frame could be decoded from ", entry.live ? "live source" : "video",
                           PathNote(entry.path, entry.name));
          return true;
        }
        continue;  // the video is done
      }
    }
  }
  return false;
}

}  // namespace lane::io
