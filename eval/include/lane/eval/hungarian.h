// Optimal one-to-one assignment (the Hungarian method with row and column
// potentials, O(n^2 m) for n <= m).
#ifndef LANE_EVAL_HUNGARIAN_H_
#define LANE_EVAL_HUNGARIAN_H_

#include <vector>

namespace lane::eval {

// `cost` is rows x cols (every row the same length, finite values). Returns,
// per row, the column assigned to it or -1: min(rows, cols) pairs are
// assigned so that their total cost is minimal.
std::vector<int> MinCostAssignment(const std::vector<std::vector<double>>& cost);

// The same, maximising the total weight.
std::vector<int> MaxWeightAssignment(const std::vector<std::vector<double>>& weight);

}  // namespace lane::eval

#endif  // LANE_EVAL_HUNGARIAN_H_
