// The Hungarian assignment against exhaustive search.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <numeric>
#include <random>

#include "lane/eval/hungarian.h"

namespace lane::eval {
namespace {

using Matrix = std::vector<std::vector<double>>;

double Total(const Matrix& cost, const std::vector<int>& assignment) {
  double total = 0;
  for (size_t r = 0; r < assignment.size(); ++r) {
    if (assignment[r] >= 0) total += cost[r][assignment[r]];
  }
  return total;
}

// Minimum total cost over all assignments of min(rows, cols) pairs.
double BruteForceMin(const Matrix& cost) {
  const size_t rows = cost.size(), cols = cost[0].size();
  const size_t n = std::max(rows, cols);
  std::vector<int> perm(n);
  std::iota(perm.begin(), perm.end(), 0);
  double best = std::numeric_limits<double>::infinity();
  do {
    double total = 0;
    for (size_t r = 0; r < rows; ++r) {
      if (perm[r] < static_cast<int>(cols)) total += cost[r][perm[r]];
    }
    best = std::min(best, total);
  } while (std::next_permutation(perm.begin(), perm.end()));
  return best;
}

void ExpectValid(const std::vector<int>& assignment, size_t rows, size_t cols) {
  ASSERT_EQ(assignment.size(), rows);
  std::vector<bool> used(cols, false);
  size_t assigned = 0;
  for (int c : assignment) {
    if (c < 0) continue;
    ASSERT_LT(c, static_cast<int>(cols));
    ASSERT_FALSE(used[c]) << "column " << c << " assigned twice";
    used[c] = true;
    ++assigned;
  }
  EXPECT_EQ(assigned, std::min(rows, cols));
}

TEST(HungarianTest, KnownSquareCase) {
  const Matrix cost = {{4, 1, 3}, {2, 0, 5}, {3, 2, 2}};
  const std::vector<int> a = MinCostAssignment(cost);
  EXPECT_EQ(a, (std::vector<int>{1, 0, 2}));  // 1 + 2 + 2 = 5
  EXPECT_DOUBLE_EQ(Total(cost, a), 5);
}

TEST(HungarianTest, GreedyWouldBeWrong) {
  // The largest weight (0.7) is row 0 / column 1; taking it leaves row 1
  // with nothing. The optimum pairs 0-0 and 1-1 (0.6 + 0.65).
  const Matrix weight = {{0.6, 0.7}, {0.0, 0.65}};
  EXPECT_EQ(MaxWeightAssignment(weight), (std::vector<int>{0, 1}));
}

TEST(HungarianTest, RectangularAndEmpty) {
  EXPECT_TRUE(MinCostAssignment({}).empty());
  EXPECT_EQ(MinCostAssignment({{}, {}}), (std::vector<int>{-1, -1}));
  // More rows than columns: one row stays unassigned.
  const Matrix tall = {{5, 9}, {1, 8}, {7, 2}};
  const std::vector<int> a = MinCostAssignment(tall);
  EXPECT_EQ(a, (std::vector<int>{-1, 0, 1}));
  const Matrix wide = {{5, 1, 7}, {9, 8, 2}};
  EXPECT_EQ(MinCostAssignment(wide), (std::vector<int>{1, 2}));
}

TEST(HungarianTest, MatchesExhaustiveSearchOnRandomMatrices) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> value(-5, 10);
  std::uniform_int_distribution<int> size(1, 6);
  for (int trial = 0; trial < 300; ++trial) {
    const size_t rows = size(rng), cols = size(rng);
    Matrix cost(rows, std::vector<double>(cols));
    for (auto& row : cost) {
      for (double& c : row) c = (trial % 3 == 0) ? std::round(value(rng)) : value(rng);  // ties
    }
    const std::vector<int> a = MinCostAssignment(cost);
    ExpectValid(a, rows, cols);
    ASSERT_NEAR(Total(cost, a), BruteForceMin(cost), 1e-9) << "trial " << trial;
  }
}

}  // namespace
}  // namespace lane::eval
