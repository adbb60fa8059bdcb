#include "lane/eval/hungarian.h"

#include <cassert>
#include <cstddef>
#include <limits>

namespace lane::eval {

std::vector<int> MinCostAssignment(const std::vector<std::vector<double>>& cost) {
  const size_t rows = cost.size();
  if (rows == 0) return {};
  const size_t cols = cost[0].size();
  if (cols == 0) return std::vector<int>(rows, -1);
  if (rows > cols) {
    // Assign the columns to rows instead, then invert.
    std::vector<std::vector<double>> transposed(cols, std::vector<double>(rows));
    for (size_t r = 0; r < rows; ++r) {
      for (size_t c = 0; c < cols; ++c) transposed[c][r] = cost[r][c];
    }
    const std::vector<int> column_row = MinCostAssignment(transposed);
    std::vector<int> row_column(rows, -1);
    for (size_t c = 0; c < cols; ++c) {
      if (column_row[c] >= 0) row_column[column_row[c]] = static_cast<int>(c);
    }
    return row_column;
  }

  // rows <= cols. Rows and columns are numbered from 1; column 0 is a
  // virtual column that holds the row being inserted. Invariant: for every
  // row i and column j, cost(i, j) - u[i] - v[j] >= 0, with equality on
  // assigned pairs, so the assignment is optimal once every row is placed.
  constexpr double kInf = std::numeric_limits<double>::infinity();
  std::vector<double> u(rows + 1, 0.0), v(cols + 1, 0.0);
  std::vector<size_t> owner(cols + 1, 0);  // row assigned to column j, 0 = free
  std::vector<size_t> came_from(cols + 1, 0);
  for (size_t row = 1; row <= rows; ++row) {
    // Grow a tree of tight edges from `row` until it reaches a free column
    // (Dijkstra on reduced costs), then flip the path.
    owner[0] = row;
    size_t column = 0;
    std::vector<double> slack(cols + 1, kInf);
    std::vector<bool> in_tree(cols + 1, false);
    do {
      in_tree[column] = true;
      const size_t r = owner[column];
      double delta = kInf;
      size_t next = 0;
      for (size_t j = 1; j <= cols; ++j) {
        if (in_tree[j]) continue;
        const double reduced = cost[r - 1][j - 1] - u[r] - v[j];
        if (reduced < slack[j]) {
          slack[j] = reduced;
          came_from[j] = column;
        }
        if (slack[j] < delta) {
          delta = slack[j];
          next = j;
        }
      }
      assert(next != 0);  // cols >= rows, so a column outside the tree is left
      // Shift the potentials so the cheapest edge out of the tree is tight.
      for (size_t j = 0; j <= cols; ++j) {
        if (in_tree[j]) {
          u[owner[j]] += delta;
          v[j] -= delta;
        } else {
          slack[j] -= delta;
        }
      }
      column = next;
    } while (owner[column] != 0);
    // Augment: every column on the path takes the row of its predecessor.
    while (column != 0) {
      const size_t previous = came_from[column];
      owner[column] = owner[previous];
      column = previous;
    }
  }
  std::vector<int> assignment(rows, -1);
  for (size_t j = 1; j <= cols; ++j) {
    if (owner[j] != 0) assignment[owner[j] - 1] = static_cast<int>(j - 1);
  }
  return assignment;
}

std::vector<int> MaxWeightAssignment(const std::vector<std::vector<double>>& weight) {
  std::vector<std::vector<double>> cost = weight;
  for (auto& row : cost) {
    for (double& c : row) c = -c;
  }
  return MinCostAssignment(cost);
}

}  // namespace lane::eval
