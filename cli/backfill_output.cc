#include "backfill_output.h"

#include <fcntl.h>
#include <openssl/evp.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <nlohmann/json.hpp>
#include <random>
#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace lane::cli {
namespace {

namespace fs = std::filesystem;

std::string JoinOutputPath(const std::string& dir, const std::string& file) {
  return (fs::path(dir) / file).string();
}

absl::Status OutputErrno(const std::string& what, const std::string& path) {
  return absl::UnknownError(absl::StrCat(what, " ", path, ": ", std::strerror(errno)));
}

// SHA-256 through OpenSSL's EVP interface.
class OutputSha256 {
 public:
  OutputSha256() : ctx_(EVP_MD_CTX_new()) {
    ok_ = ctx_ != nullptr && EVP_DigestInit_ex(ctx_.get(), EVP_sha256(), nullptr) == 1;
  }
  void Update(const char* data, size_t n) {
    if (ok_ && n > 0) ok_ = EVP_DigestUpdate(ctx_.get(), data, n) == 1;
  }
  // The digest in lower-case hex; "" if OpenSSL failed.
  std::string Hex() {
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int len = 0;
    if (!ok_ || EVP_DigestFinal_ex(ctx_.get(), md, &len) != 1) return "";
    std::string hex;
    for (unsigned int i = 0; i < len; ++i) absl::StrAppendFormat(&hex, "%02x", md[i]);
    return hex;
  }

 private:
  struct Free {
    void operator()(EVP_MD_CTX* ctx) const { EVP_MD_CTX_free(ctx); }
  };
  std::unique_ptr<EVP_MD_CTX, Free> ctx_;
  bool ok_ = false;
};

absl::Status WriteAllBytes(int fd, const char* data, size_t n, const std::string& path) {
  while (n > 0) {
    const ssize_t w = ::write(fd, data, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return OutputErrno("cannot write", path);
    }
    data += w;
    n -= static_cast<size_t>(w);
  }
  return absl::OkStatus();
}

// A name no other process picks: PID.RANDOM (PID alone repeats across
// containers).
std::string UniqueSuffix() {
  std::random_device random;
  const uint64_t bits = (uint64_t{random()} << 32) ^ uint64_t { random() };
  return absl::StrFormat("%d.%016x", static_cast<int>(::getpid()), bits);
}

// A file created exclusively in `dir` as PREFIX.PID.RANDOM: its name and
// descriptor.
absl::StatusOr<std::pair<std::string, io::ScopedFd>> CreateUniqueFile(const std::string& dir,
                                                                      const std::string& prefix) {
  for (int attempt = 0;; ++attempt) {
    const std::string path = JoinOutputPath(dir, absl::StrCat(prefix, ".", UniqueSuffix()));
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (fd >= 0) return std::make_pair(path, io::ScopedFd(fd));
    if (errno != EEXIST || attempt >= 8) return OutputErrno("cannot create", path);
  }
}

// pread until `n` bytes or the end of the file: the bytes read.
absl::StatusOr<size_t> PreadUpTo(int fd, char* out, size_t n, int64_t offset) {
  size_t got = 0;
  while (got < n) {
    const ssize_t r = ::pread(fd, out + got, n - got, static_cast<off_t>(offset + got));
    if (r < 0) {
      if (errno == EINTR) continue;
      return absl::DataLossError(absl::StrCat("read error: ", std::strerror(errno)));
    }
    if (r == 0) break;
    got += static_cast<size_t>(r);
  }
  return got;
}

// ".NAME.jsonl.partial.PID.RANDOM" or ".NAME.jsonl.partial" -> NAME; "" for
// anything else.
std::string PartialOutputName(const std::string& file) {
  static constexpr char kPartial[] = ".jsonl.partial";
  if (file.size() < 2 || file[0] != '.') return "";
  absl::string_view rest(file);
  rest.remove_prefix(1);
  if (absl::EndsWith(rest, kPartial)) {
    rest.remove_suffix(sizeof(kPartial) - 1);
    return std::string(rest);
  }
  // .PID.RANDOM: digits, then 16 hex digits.
  const size_t dot2 = rest.rfind('.');
  if (dot2 == absl::string_view::npos || rest.size() - dot2 - 1 != 16) return "";
  const size_t dot1 = rest.rfind('.', dot2 - 1);
  if (dot1 == absl::string_view::npos || dot1 + 1 == dot2) return "";
  const absl::string_view pid = rest.substr(dot1 + 1, dot2 - dot1 - 1);
  const absl::string_view random = rest.substr(dot2 + 1);
  const auto all = [](absl::string_view s, int (*pred)(int)) {
    return std::all_of(s.begin(), s.end(),
                       [pred](char c) { return pred(static_cast<unsigned char>(c)) != 0; });
  };
  if (!all(pid, ::isdigit) || !all(random, ::isxdigit)) return "";
  rest = rest.substr(0, dot1);
  if (!absl::EndsWith(rest, kPartial)) return "";
  rest.remove_suffix(sizeof(kPartial) - 1);
  return std::string(rest);
}

}  // namespace

OutputCheck CheckBackfillOutput(const std::string& path) {
  using Json = nlohmann::json;
  OutputCheck check;
  const auto torn = [&check](std::string reason) {
    check.state = OutputCheck::kTorn;
    check.reason = std::move(reason);
    return check;
  };
  absl::StatusOr<io::OpenedFile> file = io::OpenRegularFile(path);
  if (!file.ok()) {
    if (absl::IsNotFound(file.status())) return check;  // missing
    return torn(std::string(file.status().message()));
  }
  const int64_t size = file->size;
  if (size == 0) return torn("empty");
  // The trailer is the last line, well under 4 KiB.
  constexpr int64_t kTail = 4096;
  const int64_t tail_at = size - std::min(size, kTail);
  std::string tail(static_cast<size_t>(size - tail_at), '\0');
  absl::StatusOr<size_t> got = PreadUpTo(file->fd.get(), tail.data(), tail.size(), tail_at);
  if (!got.ok()) return torn(std::string(got.status().message()));
  if (*got != tail.size()) return torn("changed while it was read");
  if (tail.back() != '\n') return torn("cut short: the last line has no newline");
  const size_t before = tail.size() >= 2 ? tail.rfind('\n', tail.size() - 2) : std::string::npos;
  if (before == std::string::npos && tail_at > 0) return torn("no trailer: the last line is long");
  const size_t trailer_in_tail = before == std::string::npos ? 0 : before + 1;
  const int64_t trailer_at = tail_at + static_cast<int64_t>(trailer_in_tail);
  const Json j = Json::parse(tail.begin() + static_cast<std::ptrdiff_t>(trailer_in_tail),
                             tail.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object() || !j.contains("trailer") || !j["trailer"].is_object()) {
    return torn("no trailer (cut short, or written before outputs had one)");
  }
  const Json& t = j["trailer"];
  if (!t.contains("frames") || !t["frames"].is_number_integer() || !t.contains("sha256") ||
      !t["sha256"].is_string()) {
    return torn("a malformed trailer");
  }
  // The lines before the trailer, hashed and counted in bounded chunks.
  OutputSha256 sha;
  long lines = 0;
  std::string chunk(1 << 20, '\0');
  for (int64_t at = 0; at < trailer_at;) {
    const size_t want = static_cast<size_t>(std::min<int64_t>(chunk.size(), trailer_at - at));
    got = PreadUpTo(file->fd.get(), chunk.data(), want, at);
    if (!got.ok()) return torn(std::string(got.status().message()));
    if (*got != want) return torn("changed while it was read");
    sha.Update(chunk.data(), want);
    lines +=
        static_cast<long>(std::count(chunk.begin(), chunk.begin() + static_cast<long>(want), '\n'));
    at += static_cast<int64_t>(want);
  }
  const long frames = t["frames"].get<long>();
  if (lines != frames) {
    return torn(absl::StrCat("the trailer counts ", frames, " lines, the file has ", lines));
  }
  if (sha.Hex() != t["sha256"].get<std::string>()) {
    return torn("the lines do not hash to the trailer's sha256");
  }
  check.state = OutputCheck::kOk;
  check.frames = frames;
  return check;
}

absl::StatusOr<std::optional<OutputClaim>> OutputClaim::Acquire(const std::string& dir,
                                                                const std::string& name,
                                                                bool wait) {
  const std::string path = JoinOutputPath(dir, absl::StrCat(".", name, ".jsonl.lock"));
  for (;;) {
    const int raw = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (raw < 0) return OutputErrno("cannot open the lock", path);
    io::ScopedFd fd(raw);
    int r;
    do {
      r = ::flock(fd.get(), wait ? LOCK_EX : LOCK_EX | LOCK_NB);
    } while (r != 0 && errno == EINTR);
    if (r != 0) {
      const int err = errno;
      if (err == EWOULDBLOCK) return std::optional<OutputClaim>();
      if (err == ENOLCK || err == EOPNOTSUPP || err == ENOSYS || err == EINVAL) {
        // A file system without locks: the claim guards nothing, so its
        // holder must not take other processes' partial files for stale.
        static std::once_flag warned;
        std::call_once(warned, [&path, err] {
          std::fprintf(stderr,
                       "lane backfill: warning: %s: no flock here (%s): two processes on one "
                       "shard are not safe on this file system\n",
                       path.c_str(), std::strerror(err));
        });
        return std::optional<OutputClaim>(OutputClaim(path, std::move(fd), /*exclusive=*/false));
      }
      errno = err;
      return OutputErrno("cannot lock", path);
    }
    // The holder before us removes the lock file as it releases it: a lock
    // on a file no longer at `path` guards nothing, so take the one there.
    struct stat held, now;
    if (::fstat(fd.get(), &held) != 0) return OutputErrno("cannot stat", path);
    if (::stat(path.c_str(), &now) == 0 && now.st_dev == held.st_dev && now.st_ino == held.st_ino) {
      return std::optional<OutputClaim>(OutputClaim(path, std::move(fd), /*exclusive=*/true));
    }
  }
}

OutputClaim::~OutputClaim() {
  // Removed while still held: whoever waits on this file then sees it gone
  // and takes the one at the path (Acquire).
  if (fd_.valid()) ::unlink(path_.c_str());
}

std::map<std::string, std::vector<std::string>> ListPartialOutputs(const std::string& dir) {
  std::map<std::string, std::vector<std::string>> partials;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string file = it->path().filename().string();
    const std::string name = PartialOutputName(file);
    if (!name.empty()) partials[name].push_back(it->path().string());
  }
  return partials;
}

class PartialOutput::Impl {
 public:
  Impl(std::string dir, std::string name, std::string path, io::ScopedFd fd)
      : dir_(std::move(dir)),
        final_path_(JoinOutputPath(dir_, name + ".jsonl")),
        path_(std::move(path)),
        fd_(std::move(fd)) {}
  ~Impl() {
    fd_ = io::ScopedFd();
    if (!published_) ::unlink(path_.c_str());
  }

  void WriteLine(absl::string_view line) {
    if (!status_.ok()) return;
    sha_.Update(line.data(), line.size());
    sha_.Update("\n", 1);
    buffer_.append(line.data(), line.size());
    buffer_.push_back('\n');
    ++lines_;
    if (buffer_.size() >= (1 << 20)) Flush();
  }

  absl::Status Finish(long failed_frames, const std::string& version) {
    const std::string digest = sha_.Hex();
    if (status_.ok() && digest.empty()) status_ = absl::InternalError("SHA-256 failed (OpenSSL)");
    nlohmann::json trailer = nlohmann::json::object();
    trailer["schema"] = 1;
    trailer["frames"] = lines_;
    trailer["failed_frames"] = failed_frames;
    trailer["sha256"] = digest;
    trailer["version"] = version;
    const std::string line = nlohmann::json{{"trailer", trailer}}.dump();
    buffer_.append(line);
    buffer_.push_back('\n');
    Flush();
    if (status_.ok() && ::fsync(fd_.get()) != 0) status_ = OutputErrno("cannot fsync", path_);
    if (status_.ok() && ::close(fd_.Release()) != 0) status_ = OutputErrno("cannot close", path_);
    return status_;
  }

  absl::Status Publish() {
    if (!status_.ok()) return status_;
    if (::renameat2(AT_FDCWD, path_.c_str(), AT_FDCWD, final_path_.c_str(), RENAME_NOREPLACE) !=
        0) {
      if (errno == EEXIST) {
        return absl::AlreadyExistsError(absl::StrCat(final_path_, " exists"));
      }
      if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP) {
        return OutputErrno("cannot rename into place", path_);
      }
      // No RENAME_NOREPLACE here (some network file systems): a hard link
      // fails the same way when the name is taken.
      if (::link(path_.c_str(), final_path_.c_str()) != 0) {
        if (errno == EEXIST) return absl::AlreadyExistsError(absl::StrCat(final_path_, " exists"));
        return OutputErrno("cannot link into place", path_);
      }
      ::unlink(path_.c_str());
    }
    published_ = true;
    return SyncDirectory(dir_);
  }

  const std::string& path() const { return path_; }

 private:
  void Flush() {
    if (status_.ok()) status_ = WriteAllBytes(fd_.get(), buffer_.data(), buffer_.size(), path_);
    buffer_.clear();
  }

  std::string dir_;
  std::string final_path_;
  std::string path_;
  io::ScopedFd fd_;
  std::string buffer_;
  OutputSha256 sha_;
  long lines_ = 0;
  absl::Status status_;
  bool published_ = false;
};

PartialOutput::PartialOutput(std::unique_ptr<Impl> impl)
    : impl_(std::move(impl)), partial_path_(impl_->path()) {}

PartialOutput::~PartialOutput() = default;

absl::StatusOr<std::unique_ptr<PartialOutput>> PartialOutput::Create(const std::string& dir,
                                                                     const std::string& name) {
  auto file = CreateUniqueFile(dir, absl::StrCat(".", name, ".jsonl.partial"));
  if (!file.ok()) return file.status();
  return std::unique_ptr<PartialOutput>(new PartialOutput(
      std::make_unique<Impl>(dir, name, std::move(file->first), std::move(file->second))));
}

void PartialOutput::WriteLine(absl::string_view line) { impl_->WriteLine(line); }

absl::Status PartialOutput::Finish(long failed_frames, const std::string& version) {
  return impl_->Finish(failed_frames, version);
}

absl::Status PartialOutput::Publish() { return impl_->Publish(); }

absl::Status SyncDirectory(const std::string& dir) {
  const int raw = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (raw < 0) return OutputErrno("cannot open", dir);
  io::ScopedFd fd(raw);
  // EINVAL: a file system that cannot sync a directory (it needs none).
  if (::fsync(fd.get()) != 0 && errno != EINVAL) return OutputErrno("cannot fsync", dir);
  return absl::OkStatus();
}

absl::Status ReplaceFileDurably(const std::string& dir, const std::string& file,
                                absl::string_view text) {
  auto tmp = CreateUniqueFile(dir, absl::StrCat(".", file, ".partial"));
  if (!tmp.ok()) return tmp.status();
  const std::string& tmp_path = tmp->first;
  absl::Status status = WriteAllBytes(tmp->second.get(), text.data(), text.size(), tmp_path);
  if (status.ok() && ::fsync(tmp->second.get()) != 0)
    status = OutputErrno("cannot fsync", tmp_path);
  if (status.ok() && ::close(tmp->second.Release()) != 0) {
    status = OutputErrno("cannot close", tmp_path);
  }
  const std::string path = JoinOutputPath(dir, file);
  if (status.ok() && ::rename(tmp_path.c_str(), path.c_str()) != 0) {
    status = OutputErrno("cannot rename into place", tmp_path);
  }
  if (!status.ok()) {
    ::unlink(tmp_path.c_str());
    return status;
  }
  return SyncDirectory(dir);
}

}  // namespace lane::cli
