#include "lane/eval/culane.h"

#include <cmath>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "lane/eval/text_file.h"

namespace lane::eval {

absl::StatusOr<std::vector<Curve>> ParseCulaneLines(absl::string_view text,
                                                    absl::string_view source) {
  std::vector<Curve> lanes;
  int line_number = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_number;
    const auto where = [&] { return absl::StrCat(source, ":", line_number, ": "); };
    std::vector<double> values;
    for (absl::string_view token :
         absl::StrSplit(line, absl::ByAnyChar(" \t\r"), absl::SkipEmpty())) {
      double v = 0;
      if (!absl::SimpleAtod(token, &v) || !std::isfinite(v)) {
        return absl::InvalidArgumentError(
            absl::StrCat(where(), "\"", token, "\" is not a finite number"));
      }
      values.push_back(v);
    }
    if (values.empty()) continue;
    if (values.size() % 2 != 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          where(), values.size(), " values: expected x y pairs (an even number of values)"));
    }
    if (values.size() < 4) {
      return absl::InvalidArgumentError(
          absl::StrCat(where(), "a lane needs at least 2 points, got 1"));
    }
    std::vector<Eigen::Vector2d> points;
    points.reserve(values.size() / 2);
    for (size_t i = 0; i < values.size(); i += 2) points.emplace_back(values[i], values[i + 1]);
    lanes.push_back(Curve::Polyline(std::move(points)));
  }
  return lanes;
}

absl::StatusOr<std::vector<Curve>> ReadCulaneLines(const std::string& path) {
  absl::StatusOr<std::string> text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  return ParseCulaneLines(*text, path);
}

std::string CulaneLabelName(const std::string& image_name) {
  const size_t dot = image_name.find_last_of('.');
  const size_t slash = image_name.find_last_of('/');
  const bool has_ext = dot != std::string::npos && (slash == std::string::npos || dot > slash);
  return absl::StrCat(has_ext ? image_name.substr(0, dot) : image_name, ".lines.txt");
}

}  // namespace lane::eval
