#include "lane/eval/results_txt.h"

#include <cmath>
#include <cstdio>
#include <optional>
#include <set>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "lane/eval/text_file.h"

namespace lane::eval {
namespace {

// "NAME#<int> has <int> WORD[ ...]": the two integers and the rest after WORD.
struct Header {
  int number = 0;
  int count = 0;
  std::vector<absl::string_view> rest;
};

std::optional<Header> ParseHeader(absl::string_view line, absl::string_view name,
                                  absl::string_view word) {
  if (!absl::ConsumePrefix(&line, name) || !absl::ConsumePrefix(&line, "#")) return std::nullopt;
  const std::vector<absl::string_view> tokens =
      absl::StrSplit(line, absl::ByAnyChar(" \t"), absl::SkipEmpty());
  // "frame#N has K splines ...": tokens N, has, K, splines, ... ("1 spline"
  // is accepted too).
  Header h;
  if (tokens.size() < 4 || tokens[1] != "has" || !absl::SimpleAtoi(tokens[0], &h.number) ||
      !absl::SimpleAtoi(tokens[2], &h.count) ||
      (tokens[3] != word && tokens[3] != word.substr(0, word.size() - 1))) {
    return std::nullopt;
  }
  h.rest.assign(tokens.begin() + 4, tokens.end());
  return h;
}

}  // namespace

std::string ResultsTxtFrame(int index, const std::vector<DetectedLane>& lanes) {
  char buf[128];
  std::snprintf(buf, sizeof(buf), "frame#%08d has %zu splines\n", index, lanes.size());
  std::string out = buf;
  for (size_t k = 0; k < lanes.size(); ++k) {
    const std::vector<Eigen::Vector2d>& points = lanes[k].curve.points;
    std::snprintf(buf, sizeof(buf), "\tspline#%zu has %zu points and score %.6g\n", k + 1,
                  points.size(), lanes[k].score);
    out += buf;
    for (const Eigen::Vector2d& p : points) {
      std::snprintf(buf, sizeof(buf), "\t\t%.3f, %.3f\n", p.x(), p.y());
      out += buf;
    }
  }
  return out;
}

absl::StatusOr<std::vector<FrameResult>> ParseResultsTxt(absl::string_view text,
                                                         absl::string_view source) {
  std::vector<FrameResult> frames;
  std::set<int> seen;
  const std::vector<absl::string_view> lines = absl::StrSplit(text, '\n');
  size_t i = 0;
  const auto error = [&](size_t line_index, const std::string& message) {
    return absl::InvalidArgumentError(absl::StrCat(source, ":", line_index + 1, ": ", message));
  };
  // The next non-blank line (its index in `line_index`), or nullopt at the end.
  const auto next = [&](size_t* line_index) -> std::optional<absl::string_view> {
    while (i < lines.size()) {
      const absl::string_view line = absl::StripAsciiWhitespace(lines[i]);
      *line_index = i++;
      if (!line.empty()) return line;
    }
    return std::nullopt;
  };
  size_t at = 0;
  while (std::optional<absl::string_view> line = next(&at)) {
    const std::optional<Header> frame_header = ParseHeader(*line, "frame", "splines");
    if (!frame_header || frame_header->number < 0 || frame_header->count < 0) {
      return error(at, absl::StrCat("expected \"frame#N has K splines\", got \"", *line, "\""));
    }
    if (!seen.insert(frame_header->number).second) {
      return error(at, absl::StrCat("frame#", frame_header->number, " appears twice"));
    }
    FrameResult result;
    result.index = frame_header->number;
    result.frame = absl::StrCat("#", frame_header->number);
    for (int k = 0; k < frame_header->count; ++k) {
      const std::optional<absl::string_view> spline_line = next(&at);
      if (!spline_line) {
        return error(at, absl::StrCat("frame#", frame_header->number, " announces ",
                                      frame_header->count, " splines, the file ends after ", k));
      }
      const std::optional<Header> spline = ParseHeader(*spline_line, "spline", "points");
      if (!spline || spline->count < 2) {
        return error(
            at, absl::StrCat("expected \"spline#N has P points and score S\" with P >= 2, got \"",
                             *spline_line, "\""));
      }
      DetectedLane lane;
      // "and score S" (optional in what we accept).
      if (spline->rest.size() >= 3 && spline->rest[0] == "and" && spline->rest[1] == "score") {
        if (!absl::SimpleAtod(spline->rest[2], &lane.score)) {
          return error(at, absl::StrCat("bad score \"", spline->rest[2], "\""));
        }
      }
      std::vector<Eigen::Vector2d> points;
      for (int p = 0; p < spline->count; ++p) {
        const std::optional<absl::string_view> point_line = next(&at);
        const std::vector<absl::string_view> xy =
            point_line ? absl::StrSplit(*point_line, absl::ByAnyChar(", \t"), absl::SkipEmpty())
                       : std::vector<absl::string_view>();
        double x = 0, y = 0;
        if (xy.size() != 2 || !absl::SimpleAtod(xy[0], &x) || !absl::SimpleAtod(xy[1], &y) ||
            !std::isfinite(x) || !std::isfinite(y)) {
          return error(
              at, absl::StrCat("spline#", spline->number, " of frame#", frame_header->number,
                               ": expected point ", p + 1, " of ", spline->count,
                               " as \"x, y\", got \"", point_line.value_or("end of file"), "\""));
        }
        points.emplace_back(x, y);
      }
      lane.curve = points.size() == 4 ? Curve::FromBezier(std::array<Eigen::Vector2d, 4>{
                                            points[0], points[1], points[2], points[3]})
                                      : Curve::Polyline(std::move(points));
      result.lanes.push_back(std::move(lane));
    }
    frames.push_back(std::move(result));
  }
  return frames;
}

absl::StatusOr<std::vector<FrameResult>> ReadResultsTxt(const std::string& path) {
  absl::StatusOr<std::string> text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  return ParseResultsTxt(*text, path);
}

}  // namespace lane::eval
