// Two doubles in one register (GCC/Clang vector types: SSE2 on x86-64, NEON
// on ARM) for the hand-blocked sums of the profile smoothing and the line
// RANSAC score. Each lane computes exactly what the scalar code would: no
// reassociation, no fused multiply-add beyond what the compiler does for
// scalars.
#ifndef LANE_CORE_SRC_DOUBLE_PAIR_H_
#define LANE_CORE_SRC_DOUBLE_PAIR_H_

#include <cstdint>
#include <cstring>

namespace lane::internal {

using DoublePair = double __attribute__((vector_size(16)));
using MaskPair = int64_t __attribute__((vector_size(16)));  // lane-wise comparisons

// p[0], p[1] (unaligned).
inline DoublePair LoadPair(const double* p) {
  DoublePair v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

}  // namespace lane::internal

#endif  // LANE_CORE_SRC_DOUBLE_PAIR_H_
