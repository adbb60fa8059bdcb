// Input files opened without surprises: opening never blocks (a FIFO with no
// writer), only regular files on a real file system are read (not a device,
// a socket, a FIFO, nor a /proc or /sys file whose size and reads are not a
// file's), and never more bytes than a cap, checked with fstat before
// anything is read. Errors are absl::Status values, never exceptions.
#ifndef LANE_IO_INPUT_FILE_H_
#define LANE_IO_INPUT_FILE_H_

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace lane::io {

// The largest image file read by default, and the largest frame decoded
// from one (width x height x 3 bytes, as BGR): 64 MiB. A 16-megapixel frame
// is 48 MiB raw (3 bytes a pixel); even stored without compression, a PNG of
// it is that plus under 0.1% (a filter byte a row, deflate's block headers,
// the chunks' framing); 64 MiB leaves a third again for metadata and margin.
// (A camera's JPEG of it is a fraction of that; only pure noise at quality
// 100 without chroma subsampling exceeds the raw size, at 1.4x.)
// `lane backfill --max-image-bytes` changes it.
inline constexpr int64_t kDefaultMaxImageBytes = int64_t{64} << 20;

// The largest list file (.txt, one path a line) read: 64 MiB, about 600,000
// paths of 100 characters.
inline constexpr int64_t kMaxListFileBytes = int64_t{64} << 20;

// An open file descriptor, closed when it goes.
class ScopedFd {
 public:
  ScopedFd() = default;
  explicit ScopedFd(int fd) : fd_(fd) {}
  ScopedFd(ScopedFd&& other) noexcept : fd_(other.Release()) {}
  ScopedFd& operator=(ScopedFd&& other) noexcept;
  ScopedFd(const ScopedFd&) = delete;
  ScopedFd& operator=(const ScopedFd&) = delete;
  ~ScopedFd();

  int get() const { return fd_; }
  bool valid() const { return fd_ >= 0; }
  int Release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }

 private:
  int fd_ = -1;
};

// A regular file open for reading, and its size when it was opened.
struct OpenedFile {
  ScopedFd fd;
  int64_t size = 0;
};

// What a stat mode is, for messages: "a FIFO", "a socket", "a character
// device", "a block device", "a directory", "a regular file", ...
std::string FileKindName(unsigned mode);

// Opens `path` read-only for reading a regular file: with O_NONBLOCK (so a
// FIFO cannot block the open; cleared once open), then fstat and fstatfs on
// what was opened. FAILED_PRECONDITION, with the reason ("is a FIFO, not a
// regular file"; "is on /proc, a kernel pseudo-file system"), for anything
// but a regular file on a real file system; NOT_FOUND or PERMISSION_DENIED
// and the system's message when it cannot be opened.
absl::StatusOr<OpenedFile> OpenRegularFile(const std::string& path);

// OK if `path` is a directory on a real file system (opened as
// OpenRegularFile does: without blocking, then fstat and fstatfs).
absl::Status CheckDirectory(const std::string& path);

// The whole of a regular file (OpenRegularFile), at most `max_bytes`:
// a larger file is refused before any of it is read (OUT_OF_RANGE, the
// message says both sizes), and one that grows past the cap while it is
// read is refused too. A read error (EIO) is an error, never an exception.
absl::StatusOr<std::string> ReadRegularFile(const std::string& path, int64_t max_bytes);

// Reads lines from an open file, each at most `max_line_bytes` long without
// its '\n': a longer line is an error as soon as that many bytes have come
// without a newline, before the line is kept whole. Memory is bounded by
// max_line_bytes plus a read buffer, whatever the file holds.
class BoundedLineReader {
 public:
  BoundedLineReader(ScopedFd fd, size_t max_line_bytes);

  // The next line, without its '\n'; nullopt at the end of the file.
  // OUT_OF_RANGE for a line over the bound, an I/O error's status
  // otherwise (both with the line's number, from 1).
  absl::StatusOr<std::optional<std::string>> Next();
  // The number of the line Next returned last (from 1).
  int line_number() const { return line_number_; }

 private:
  ScopedFd fd_;
  size_t max_line_bytes_;
  std::string buffer_;  // bytes read; those before start_ are handed out
  size_t start_ = 0;    // where the next line begins in buffer_
  size_t scanned_ = 0;  // buffer_[start_, scanned_) holds no '\n'
  bool eof_ = false;
  int line_number_ = 0;
};

}  // namespace lane::io

#endif  // LANE_IO_INPUT_FILE_H_
