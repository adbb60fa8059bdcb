// The real definition of an interposed function, for the TSan models
// (tsan_absl_sync.cc, tsan_grpc_sync.cc): the next definition of `symbol`
// after this binary's own, found with dlsym(RTLD_NEXT). Aborts with the
// symbol's name when it is missing (another gRPC or Abseil version: the
// mangled names must be derived again).
#ifndef LANE_TESTS_SANITIZERS_TSAN_REAL_H_
#define LANE_TESTS_SANITIZERS_TSAN_REAL_H_

#include <dlfcn.h>

#include <cstdio>
#include <cstdlib>

namespace lane::tsan {

template <typename F>
F Real(const char* symbol) {
  void* f = dlsym(RTLD_NEXT, symbol);
  if (f == nullptr) {
    std::fprintf(stderr, "lane tsan model: cannot find %s\n", symbol);
    std::abort();
  }
  return reinterpret_cast<F>(f);
}

}  // namespace lane::tsan

#endif  // LANE_TESTS_SANITIZERS_TSAN_REAL_H_
