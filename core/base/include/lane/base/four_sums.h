// A sum in four partial sums, so that the additions do not wait on each
// other (a loop-carried chain of double additions bounds the speed of the
// RANSAC scores and the top view's mean). Term k goes into partial sum
// k % 4, the tail into the first; the total is (s0 + s1) + (s2 + s3).
// Sums of thresholded float pixels in double are exact unless a term is
// tiny against the total (2^-29 of it), so for them the order does not
// change the result.
#ifndef LANE_CORE_SRC_FOUR_SUMS_H_
#define LANE_CORE_SRC_FOUR_SUMS_H_

#include <cstddef>

namespace lane::internal {

// term(k) for k = 0 .. n - 1, each called once, in order.
template <typename Term>
double SumInFourParts(size_t n, const Term& term) {
  double s[4] = {0, 0, 0, 0};
  size_t k = 0;
  for (; k + 4 <= n; k += 4) {
    s[0] += term(k);
    s[1] += term(k + 1);
    s[2] += term(k + 2);
    s[3] += term(k + 3);
  }
  for (; k < n; ++k) s[0] += term(k);
  return (s[0] + s[1]) + (s[2] + s[3]);
}

}  // namespace lane::internal

#endif  // LANE_CORE_SRC_FOUR_SUMS_H_
