// Built into every test binary only with LANE_SANITIZE=thread: tells
// ThreadSanitizer that a gRPC batch's completion happens after the batch was
// started, and that a server call's OnDone happens after its last callback:
// the ordering guarantees of gRPC's API that cross threads through code TSan
// cannot see.
//
// Debian's libgrpc is not instrumented, and hands a finished batch to the
// thread that completes it through lock-free queues (the transport's
// combiner), which no lock model (tsan_absl_sync.cc) covers. So the gRPC code
// inlined into our binaries (grpcpp's CallOpSet, interceptor state, the
// message a read deserialises into) is written by the thread that starts a
// batch and read by the thread that runs its completion with no edge between
// them.
//
// Both ends pass through exported functions, and both carry the same tag:
//   start  grpc_call_start_batch(call, ops, n, tag, ...)  -> release(tag)
//   end    callback API: tag->functor_run(tag, ok), i.e. the StaticRun of
//          CallbackWithSuccessTag / CallbackWithStatusTag -> acquire(tag)
//          completion queues: grpc_completion_queue_pluck/next returning an
//          event for tag -> acquire(tag)
// And one hand-off inside libgrpc++: a server call's OnDone, once its last
// reference is gone, is sent to gRPC's executor (ServerCallbackCall::
// ScheduleOnDone), which TSan does not see ordered after the callbacks that
// dropped the references (the last one may be dropped in libgrpc++'s own
// code). ScheduleOnDone is defined here instead: it acquires the reference
// counter (every callback releases it), then runs an inline
// OnDone inline, as gRPC does, and any other on a thread of its own
// started by this (instrumented) code, an order TSan sees.
//
// grpc_call_start_batch and the completion-queue functions are interposed
// (libgrpc++ calls them across a library boundary) and forwarded with
// dlsym(RTLD_NEXT). The two StaticRun functions are inline in grpcpp's
// headers, so every test object file carries a weak copy; the strong
// definitions here (by their mangled names, which is why this file must not
// use them itself) replace those copies at link time and do exactly what
// grpcpp's do, after the acquire.
#include <grpc/grpc.h>
#include <grpcpp/support/callback_common.h>
#include <grpcpp/support/server_callback.h>
#include <sanitizer/tsan_interface.h>

#include <thread>

#include "tsan_real.h"

namespace {

using lane::tsan::Real;

// Run(bool), the body of both StaticRun functions, is private. An explicit
// template instantiation may name private members ([temp.explicit]), which
// is how the member pointers below are taken.
template <typename Tag, typename Tag::type Member>
struct PrivateMember {
  friend typename Tag::type Get(Tag) { return Member; }
};
struct SuccessTagRun {
  using type = void (grpc::internal::CallbackWithSuccessTag::*)(bool);
  friend type Get(SuccessTagRun);
};
struct StatusTagRun {
  using type = void (grpc::internal::CallbackWithStatusTag::*)(bool);
  friend type Get(StatusTagRun);
};
template struct PrivateMember<SuccessTagRun, &grpc::internal::CallbackWithSuccessTag::Run>;
template struct PrivateMember<StatusTagRun, &grpc::internal::CallbackWithStatusTag::Run>;

}  // namespace

extern "C" {

grpc_call_error grpc_call_start_batch(grpc_call* call, const grpc_op* ops, size_t nops, void* tag,
                                      void* reserved) {
  static const auto real =
      Real<grpc_call_error (*)(grpc_call*, const grpc_op*, size_t, void*, void*)>(
          "grpc_call_start_batch");
  if (tag != nullptr) __tsan_release(tag);
  return real(call, ops, nops, tag, reserved);
}

grpc_event grpc_completion_queue_pluck(grpc_completion_queue* cq, void* tag, gpr_timespec deadline,
                                       void* reserved) {
  static const auto real = Real<grpc_event (*)(grpc_completion_queue*, void*, gpr_timespec, void*)>(
      "grpc_completion_queue_pluck");
  const grpc_event event = real(cq, tag, deadline, reserved);
  if (event.type == GRPC_OP_COMPLETE && event.tag != nullptr) __tsan_acquire(event.tag);
  return event;
}

grpc_event grpc_completion_queue_next(grpc_completion_queue* cq, gpr_timespec deadline,
                                      void* reserved) {
  static const auto real = Real<grpc_event (*)(grpc_completion_queue*, gpr_timespec, void*)>(
      "grpc_completion_queue_next");
  const grpc_event event = real(cq, deadline, reserved);
  if (event.type == GRPC_OP_COMPLETE && event.tag != nullptr) __tsan_acquire(event.tag);
  return event;
}

// grpc::internal::CallbackWithSuccessTag::StaticRun(grpc_completion_queue_functor*, int)
void _ZN4grpc8internal22CallbackWithSuccessTag9StaticRunEP29grpc_completion_queue_functori(
    grpc_completion_queue_functor* cb, int ok) {
  __tsan_acquire(cb);
  auto* tag = static_cast<grpc::internal::CallbackWithSuccessTag*>(cb);
  (tag->*Get(SuccessTagRun()))(static_cast<bool>(ok));
}

// grpc::internal::CallbackWithStatusTag::StaticRun(grpc_completion_queue_functor*, int)
void _ZN4grpc8internal21CallbackWithStatusTag9StaticRunEP29grpc_completion_queue_functori(
    grpc_completion_queue_functor* cb, int ok) {
  __tsan_acquire(cb);
  auto* tag = static_cast<grpc::internal::CallbackWithStatusTag*>(cb);
  (tag->*Get(StatusTagRun()))(static_cast<bool>(ok));
}

}  // extern "C"

// grpc::internal::ServerCallbackCall::ScheduleOnDone(bool), exported by
// libgrpc++; the inline MaybeDone of every test object file calls it.
namespace grpc::internal {
void ServerCallbackCall::ScheduleOnDone(bool inline_ondone) {
  // Called after the last Unref (acq_rel) of callbacks_outstanding_. That
  // Unref may have run in libgrpc++'s own uninstrumented code; an acquire
  // load of the counter orders this thread after every instrumented Unref.
  (void)callbacks_outstanding_.load(std::memory_order_acquire);
  if (inline_ondone) {
    CallOnDone();
    return;
  }
  std::thread([this] { CallOnDone(); }).detach();
}
}  // namespace grpc::internal
