#include "wire/status_map.h"

#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "lane/base/excerpt.h"

namespace lane::wire {

namespace {

// A camera id in a message: ids are validated (at most 128 characters of
// [A-Za-z0-9._:/-]) before they are stored, but a lookup may quote anything.
std::string Id(absl::string_view camera_id) { return lane::Excerpt(camera_id); }

}  // namespace

absl::Status SessionNotFound(absl::string_view camera_id) {
  return absl::NotFoundError(absl::StrCat("no session for camera '", Id(camera_id), "'"));
}

absl::Status NoSessionForFrame(absl::string_view camera_id) {
  return absl::FailedPreconditionError(
      absl::StrCat("no session for camera '", Id(camera_id),
                   "': call CreateSession first, or send session_config with the "
                   "stream's first frame"));
}

absl::Status SessionConfigConflict(absl::string_view camera_id, uint64_t version) {
  return absl::AlreadyExistsError(
      absl::StrCat("camera '", Id(camera_id), "' already has a session (version ", version,
                   ") with a different config; set replace to replace it"));
}

absl::Status TooManySessions(size_t max_sessions) {
  return absl::ResourceExhaustedError(
      absl::StrCat("the server holds its maximum of ", max_sessions,
                   " sessions (--max_sessions); delete one or wait for idle ones to expire"));
}

absl::Status SessionMemoryExhausted(uint64_t need_bytes, uint64_t held_bytes,
                                    uint64_t budget_bytes) {
  auto mib = [](uint64_t bytes) { return absl::StrFormat("%.1f MiB", bytes / 1048576.0); };
  return absl::ResourceExhaustedError(
      absl::StrCat("the session would hold ", mib(need_bytes), " and the server's sessions hold ",
                   mib(held_bytes), " of their budget of ", mib(budget_bytes),
                   " (--max_session_memory_mib); delete sessions or use a smaller top view"));
}

absl::Status WorkerQueueFull() {
  return absl::ResourceExhaustedError("the worker pool's queue is full; retry later");
}

absl::Status ServerStarting() { return absl::UnavailableError("the server is starting"); }

absl::Status ServerDraining() {
  return absl::UnavailableError("the server is draining (shutting down)");
}

absl::Status FrameDropped(uint32_t max_inflight) {
  return absl::AbortedError(absl::StrCat("dropped: the stream had ", max_inflight,
                                         " frames in flight (backpressure drop_oldest)"));
}

absl::Status InvalidFrame(absl::string_view message) { return absl::InvalidArgumentError(message); }

absl::Status InvalidRequest(absl::string_view message) {
  return absl::InvalidArgumentError(message);
}

grpc::Status ToGrpcStatus(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  // The numbering is shared (both follow google.rpc.Code).
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()),
                      lane::CapMessage(status.message(), kMaxStatusMessageBytes));
}

v1::FrameCode ToFrameCode(absl::StatusCode code) {
  switch (code) {
    case absl::StatusCode::kOk:
      return v1::FRAME_CODE_OK;
    case absl::StatusCode::kInvalidArgument:
    case absl::StatusCode::kOutOfRange:
      return v1::FRAME_CODE_INVALID_ARGUMENT;
    case absl::StatusCode::kResourceExhausted:
      return v1::FRAME_CODE_RESOURCE_EXHAUSTED;
    case absl::StatusCode::kAborted:
      return v1::FRAME_CODE_DROPPED;
    default:
      return v1::FRAME_CODE_INTERNAL;
  }
}

void ToFrameStatus(const absl::Status& status, v1::FrameStatus* out) {
  const v1::FrameCode code = ToFrameCode(status.code());
  out->set_code(code);
  if (status.ok()) {
    out->clear_message();
  } else if (code == v1::FRAME_CODE_INTERNAL && status.code() != absl::StatusCode::kInternal) {
    out->set_message(lane::CapMessage(
        absl::StrCat(absl::StatusCodeToString(status.code()), ": ", status.message()),
        kMaxStatusMessageBytes));
  } else {
    out->set_message(lane::CapMessage(status.message(), kMaxStatusMessageBytes));
  }
}

absl::Status FromFrameStatus(const v1::FrameStatus& status) {
  switch (status.code()) {
    case v1::FRAME_CODE_OK:
      return absl::OkStatus();
    case v1::FRAME_CODE_INVALID_ARGUMENT:
      return absl::InvalidArgumentError(status.message());
    case v1::FRAME_CODE_RESOURCE_EXHAUSTED:
      return absl::ResourceExhaustedError(status.message());
    case v1::FRAME_CODE_DROPPED:
      return absl::AbortedError(status.message());
    default:
      return absl::InternalError(status.message());
  }
}

FrameResult ToFrameResult(v1::FrameCode code) {
  switch (code) {
    case v1::FRAME_CODE_OK:
      return FrameResult::kOk;
    case v1::FRAME_CODE_INVALID_ARGUMENT:
    case v1::FRAME_CODE_RESOURCE_EXHAUSTED:
      return FrameResult::kInvalid;
    case v1::FRAME_CODE_DROPPED:
      return FrameResult::kDropped;
    default:
      return FrameResult::kError;
  }
}

const char* FrameResultLabel(FrameResult result) {
  switch (result) {
    case FrameResult::kOk:
      return "ok";
    case FrameResult::kInvalid:
      return "invalid";
    case FrameResult::kDropped:
      return "dropped";
    case FrameResult::kError:
      return "error";
  }
  return "error";
}

const char* GrpcCodeName(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK:
      return "OK";
    case grpc::StatusCode::CANCELLED:
      return "CANCELLED";
    case grpc::StatusCode::UNKNOWN:
      return "UNKNOWN";
    case grpc::StatusCode::INVALID_ARGUMENT:
      return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND:
      return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS:
      return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED:
      return "PERMISSION_DENIED";
    case grpc::StatusCode::UNAUTHENTICATED:
      return "UNAUTHENTICATED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION:
      return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED:
      return "ABORTED";
    case grpc::StatusCode::OUT_OF_RANGE:
      return "OUT_OF_RANGE";
    case grpc::StatusCode::UNIMPLEMENTED:
      return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL:
      return "INTERNAL";
    case grpc::StatusCode::UNAVAILABLE:
      return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS:
      return "DATA_LOSS";
    default:
      return "UNKNOWN";
  }
}

}  // namespace lane::wire
