// Every error the service reports, and how it reaches the client: the ONE
// place that maps absl::Status (the core library's and the server's) to gRPC
// status codes and to per-frame statuses. docs/service.md has the table.
//
// absl::StatusCode and grpc::StatusCode share their numbering, so the mapping
// is one-to-one; only the per-frame codes are a subset (see FrameCode in
// proto/lane/v1/lane_service.proto).
#ifndef LANE_WIRE_STATUS_MAP_H_
#define LANE_WIRE_STATUS_MAP_H_

#include <grpcpp/support/status.h>

#include <cstdint>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "lane/v1/lane_service.pb.h"

namespace lane::wire {

// ---- Errors of the service (constructors, so the codes live here) ----------

// NOT_FOUND: GetSession / DeleteSession of a camera without a session.
absl::Status SessionNotFound(absl::string_view camera_id);
// FAILED_PRECONDITION: a frame (StreamFrames, Detect) for a camera that has no
// session yet. Ends a stream.
absl::Status NoSessionForFrame(absl::string_view camera_id);
// ALREADY_EXISTS: CreateSession with a different config, without `replace`.
absl::Status SessionConfigConflict(absl::string_view camera_id, uint64_t version);
// RESOURCE_EXHAUSTED: the session cap is reached.
absl::Status TooManySessions(size_t max_sessions);
// RESOURCE_EXHAUSTED: a new session's detector would take the sessions'
// memory beyond --max_session_memory_mib.
absl::Status SessionMemoryExhausted(uint64_t need_bytes, uint64_t held_bytes,
                                    uint64_t budget_bytes);
// RESOURCE_EXHAUSTED: the worker pool's queue is full (unary Detect).
absl::Status WorkerQueueFull();
// UNAVAILABLE: the server is starting or draining.
absl::Status ServerStarting();
absl::Status ServerDraining();
// ABORTED: a frame dropped unprocessed by drop_oldest backpressure.
absl::Status FrameDropped(uint32_t max_inflight);
// INVALID_ARGUMENT: a bad frame, camera id or request field.
absl::Status InvalidFrame(absl::string_view message);
absl::Status InvalidRequest(absl::string_view message);

// ---- Conversions ----------------------------------------------------------

// Every status message leaving the server is cut to this many bytes: a
// default gRPC client refuses status metadata beyond about 8 kB, and then
// reports RESOURCE_EXHAUSTED instead of the real code. Messages that quote
// client input quote a short excerpt (lane/base/excerpt.h); this is the backstop.
inline constexpr size_t kMaxStatusMessageBytes = 1024;

// Stream-level and unary statuses: the same code and message.
grpc::Status ToGrpcStatus(const absl::Status& status);

// Per-frame status: OK, INVALID_ARGUMENT (and OUT_OF_RANGE) -> their frame
// codes, ABORTED -> FRAME_CODE_DROPPED, everything else -> FRAME_CODE_INTERNAL
// (the message keeps the original code's name).
v1::FrameCode ToFrameCode(absl::StatusCode code);
void ToFrameStatus(const absl::Status& status, v1::FrameStatus* out);
// Back from a frame code (Detect returns the frame's status as its own).
absl::Status FromFrameStatus(const v1::FrameStatus& status);

// Value of the `result` label of lanesvc_frames_total.
enum class FrameResult { kOk, kInvalid, kDropped, kError };
inline constexpr FrameResult kAllFrameResults[] = {FrameResult::kOk, FrameResult::kInvalid,
                                                   FrameResult::kDropped, FrameResult::kError};
FrameResult ToFrameResult(v1::FrameCode code);
const char* FrameResultLabel(FrameResult result);

// "OK", "INVALID_ARGUMENT", ... as in grpc_server_handled_total{grpc_code}.
const char* GrpcCodeName(grpc::StatusCode code);

}  // namespace lane::wire

#endif  // LANE_WIRE_STATUS_MAP_H_
