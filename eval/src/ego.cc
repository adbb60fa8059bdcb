#include "lane/eval/ego.h"

#include <optional>

namespace lane::eval {

EgoBoundaries SelectEgoBoundaries(const std::vector<Curve>& labels, double centre_x, double row) {
  EgoBoundaries ego;
  double left_x = 0, right_x = 0;
  for (size_t i = 0; i < labels.size(); ++i) {
    const std::optional<double> x = XAtRow(labels[i].Sample(), row);
    if (!x) continue;
    const int index = static_cast<int>(i);
    if (*x < centre_x) {
      if (ego.left < 0 || *x > left_x) ego.left = index, left_x = *x;
    } else if (ego.right < 0 || *x < right_x) {
      ego.right = index, right_x = *x;
    }
  }
  return ego;
}

}  // namespace lane::eval
