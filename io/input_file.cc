#include "io/input_file.h"

#include <fcntl.h>
#include <linux/magic.h>
#include <sys/stat.h>
#include <sys/statfs.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>

#include "absl/strings/str_cat.h"

namespace lane::io {
namespace {

// The kernel's pseudo-file systems: their files report a size of 0 (or
// 4096) whatever they hold, and reading them does what the kernel makes of
// it (/proc/self/mem: EIO at the first unmapped page; /proc/kmsg: blocks).
const char* PseudoFileSystemName(int64_t type) {
  switch (type) {
    case PROC_SUPER_MAGIC:
      return "/proc";
    case SYSFS_MAGIC:
      return "/sys";
    case DEBUGFS_MAGIC:
      return "debugfs";
    case TRACEFS_MAGIC:
      return "tracefs";
    case SECURITYFS_MAGIC:
      return "securityfs";
    case CGROUP_SUPER_MAGIC:
    case CGROUP2_SUPER_MAGIC:
      return "cgroupfs";
    case EFIVARFS_MAGIC:
      return "efivarfs";
    case BPF_FS_MAGIC:
      return "bpffs";
    case DEVPTS_SUPER_MAGIC:
      return "devpts";
    default:
      return nullptr;
  }
}

absl::Status OpenErrorStatus(const std::string& path, int err) {
  const std::string message = absl::StrCat(path, ": cannot open: ", std::strerror(err));
  if (err == ENOENT || err == ENOTDIR) return absl::NotFoundError(message);
  if (err == EACCES || err == EPERM) return absl::PermissionDeniedError(message);
  return absl::FailedPreconditionError(message);
}

// Opens `path` with `flags` | O_NONBLOCK and checks what was opened: of the
// kind `want` (S_IFREG or S_IFDIR), on a real file system. O_NONBLOCK is
// cleared again before the descriptor is handed out.
absl::StatusOr<OpenedFile> OpenChecked(const std::string& path, int flags, unsigned want) {
  // A symbolic link is followed, as every reader does: what counts is what
  // the open gives, checked with fstat below.
  int fd;
  do {
    fd = ::open(path.c_str(), flags | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) {
    const int err = errno;
    // open fails on a socket with ENXIO, which says little: say what it is.
    struct stat st;
    if (err == ENXIO && ::stat(path.c_str(), &st) == 0 && S_ISSOCK(st.st_mode)) {
      return absl::FailedPreconditionError(absl::StrCat(
          path, ": is a socket, not ", want == S_IFDIR ? "a directory" : "a regular file"));
    }
    return OpenErrorStatus(path, err);
  }
  OpenedFile file{ScopedFd(fd), 0};
  struct stat st;
  if (::fstat(fd, &st) != 0) {
    return absl::UnknownError(absl::StrCat(path, ": fstat: ", std::strerror(errno)));
  }
  if ((st.st_mode & S_IFMT) != want) {
    return absl::FailedPreconditionError(
        absl::StrCat(path, ": is ", FileKindName(st.st_mode), ", not ",
                     want == S_IFDIR ? "a directory" : "a regular file"));
  }
  struct statfs fs;
  if (::fstatfs(fd, &fs) != 0) {
    return absl::UnknownError(absl::StrCat(path, ": fstatfs: ", std::strerror(errno)));
  }
  if (const char* pseudo = PseudoFileSystemName(static_cast<int64_t>(fs.f_type))) {
    return absl::FailedPreconditionError(
        absl::StrCat(path, ": is on ", pseudo,
                     ", a kernel pseudo-file system (its files are not regular data)"));
  }
  const int fl = ::fcntl(fd, F_GETFL);
  if (fl < 0 || ::fcntl(fd, F_SETFL, fl & ~O_NONBLOCK) != 0) {
    return absl::UnknownError(absl::StrCat(path, ": fcntl: ", std::strerror(errno)));
  }
  file.size = static_cast<int64_t>(st.st_size);
  return file;
}

// read(2) until `n` bytes or the end of the file; the bytes read, or an
// error.
absl::StatusOr<size_t> ReadUpTo(int fd, char* out, size_t n) {
  size_t got = 0;
  while (got < n) {
    const ssize_t r = ::read(fd, out + got, n - got);
    if (r < 0) {
      if (errno == EINTR) continue;
      return absl::DataLossError(absl::StrCat("read error: ", std::strerror(errno)));
    }
    if (r == 0) break;
    got += static_cast<size_t>(r);
  }
  return got;
}

}  // namespace

ScopedFd& ScopedFd::operator=(ScopedFd&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = other.Release();
  }
  return *this;
}

ScopedFd::~ScopedFd() {
  if (fd_ >= 0) ::close(fd_);
}

std::string FileKindName(unsigned mode) {
  switch (mode & S_IFMT) {
    case S_IFREG:
      return "a regular file";
    case S_IFDIR:
      return "a directory";
    case S_IFIFO:
      return "a FIFO";
    case S_IFSOCK:
      return "a socket";
    case S_IFCHR:
      return "a character device";
    case S_IFBLK:
      return "a block device";
    case S_IFLNK:
      return "a symbolic link";
    default:
      return "not a file";
  }
}

absl::StatusOr<OpenedFile> OpenRegularFile(const std::string& path) {
  return OpenChecked(path, O_RDONLY, S_IFREG);
}

absl::Status CheckDirectory(const std::string& path) {
  return OpenChecked(path, O_RDONLY | O_DIRECTORY, S_IFDIR).status();
}

absl::StatusOr<std::string> ReadRegularFile(const std::string& path, int64_t max_bytes) {
  absl::StatusOr<OpenedFile> file = OpenRegularFile(path);
  if (!file.ok()) return file.status();
  if (file->size > max_bytes) {
    return absl::OutOfRangeError(
        absl::StrCat(path, ": ", file->size, " bytes, over the cap of ", max_bytes, " bytes"));
  }
  std::string bytes;
  // One byte past the size seen: a file that grew shows it.
  bytes.resize(static_cast<size_t>(file->size) + 1);
  size_t got = 0;
  for (;;) {
    absl::StatusOr<size_t> n = ReadUpTo(file->fd.get(), bytes.data() + got, bytes.size() - got);
    if (!n.ok())
      return absl::Status(n.status().code(), absl::StrCat(path, ": ", n.status().message()));
    got += *n;
    if (got < bytes.size()) break;  // the end of the file
    if (static_cast<int64_t>(got) > max_bytes) {
      return absl::OutOfRangeError(
          absl::StrCat(path, ": grew past the cap of ", max_bytes, " bytes while it was read"));
    }
    bytes.resize(std::min<size_t>(bytes.size() * 2, static_cast<size_t>(max_bytes) + 1));
  }
  bytes.resize(got);
  return bytes;
}

BoundedLineReader::BoundedLineReader(ScopedFd fd, size_t max_line_bytes)
    : fd_(std::move(fd)), max_line_bytes_(max_line_bytes) {}

absl::StatusOr<std::optional<std::string>> BoundedLineReader::Next() {
  constexpr size_t kChunk = 64 * 1024;
  for (;;) {
    const size_t newline = buffer_.find('\n', scanned_);
    if (newline != std::string::npos) {
      ++line_number_;
      if (newline - start_ > max_line_bytes_) {
        return absl::OutOfRangeError(
            absl::StrCat("line ", line_number_, " is longer than ", max_line_bytes_, " bytes"));
      }
      std::string line = buffer_.substr(start_, newline - start_);
      start_ = scanned_ = newline + 1;
      return std::optional<std::string>(std::move(line));
    }
    scanned_ = buffer_.size();
    if (buffer_.size() - start_ > max_line_bytes_) {
      return absl::OutOfRangeError(
          absl::StrCat("line ", line_number_ + 1, " is longer than ", max_line_bytes_, " bytes"));
    }
    if (eof_) {
      if (start_ == buffer_.size()) return std::optional<std::string>();
      ++line_number_;  // the last line, without a '\n'
      std::string line = buffer_.substr(start_);
      start_ = scanned_ = buffer_.size();
      return std::optional<std::string>(std::move(line));
    }
    // What is handed out already goes before the next read.
    buffer_.erase(0, start_);
    scanned_ -= start_;
    start_ = 0;
    const size_t old = buffer_.size();
    buffer_.resize(old + kChunk);
    absl::StatusOr<size_t> n = ReadUpTo(fd_.get(), buffer_.data() + old, kChunk);
    if (!n.ok()) {
      buffer_.resize(old);
      return absl::Status(n.status().code(),
                          absl::StrCat("line ", line_number_ + 1, ": ", n.status().message()));
    }
    buffer_.resize(old + *n);
    if (*n < kChunk) eof_ = true;
  }
}

}  // namespace lane::io
