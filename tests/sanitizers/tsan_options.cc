// Built into every test binary only with LANE_SANITIZE=thread: points TSan at this
// folder's suppressions (Debian's gRPC and Abseil are not TSan-instrumented;
// see tsan.supp). TSAN_OPTIONS set by the user still apply on top.
extern "C" const char* __tsan_default_options() {
  return "suppressions=" LANE_SOURCE_DIR "/tests/sanitizers/tsan.supp";
}
