#include "lane/eval/caltech.h"

#include <matio.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "lane/eval/text_file.h"

namespace lane::eval {
namespace {

struct MatCloser {
  void operator()(mat_t* mat) const { Mat_Close(mat); }
};
struct VarFreer {
  void operator()(matvar_t* var) const { Mat_VarFree(var); }
};
using MatFile = std::unique_ptr<mat_t, MatCloser>;
using MatVar = std::unique_ptr<matvar_t, VarFreer>;

size_t ElementCount(const matvar_t* var) {
  if (var == nullptr || var->rank <= 0 || var->dims == nullptr) return 0;
  size_t n = 1;
  for (int i = 0; i < var->rank; ++i) n *= var->dims[i];
  return n;
}

std::string Shape(const matvar_t* var) {
  if (var == nullptr || var->rank <= 0 || var->dims == nullptr) return "empty";
  std::string s;
  for (int i = 0; i < var->rank; ++i) absl::StrAppend(&s, i ? "x" : "", var->dims[i]);
  return s;
}

// Field `name` of element `index` of a struct array, or of the struct in
// cell `index` of a cell array. nullptr when absent.
matvar_t* Field(matvar_t* var, const char* name, size_t index) {
  if (var == nullptr) return nullptr;
  if (var->class_type == MAT_C_STRUCT) {
    return Mat_VarGetStructFieldByName(var, name, index);
  }
  if (var->class_type == MAT_C_CELL) {
    matvar_t* cell = Mat_VarGetCell(var, static_cast<int>(index));
    if (cell == nullptr || cell->class_type != MAT_C_STRUCT) return nullptr;
    return Mat_VarGetStructFieldByName(cell, name, 0);
  }
  return nullptr;
}

// Elements of a struct array, or structs of a cell array (0 for [] etc.).
size_t StructCount(const matvar_t* var) {
  if (var == nullptr) return 0;
  if (var->class_type == MAT_C_STRUCT || var->class_type == MAT_C_CELL) return ElementCount(var);
  return 0;
}

void AppendUtf8(uint32_t c, std::string* out) {
  if (c < 0x80) {
    out->push_back(static_cast<char>(c));
  } else if (c < 0x800) {
    out->push_back(static_cast<char>(0xC0 | (c >> 6)));
    out->push_back(static_cast<char>(0x80 | (c & 0x3F)));
  } else if (c < 0x10000) {
    out->push_back(static_cast<char>(0xE0 | (c >> 12)));
    out->push_back(static_cast<char>(0x80 | ((c >> 6) & 0x3F)));
    out->push_back(static_cast<char>(0x80 | (c & 0x3F)));
  } else {
    out->push_back(static_cast<char>(0xF0 | (c >> 18)));
    out->push_back(static_cast<char>(0x80 | ((c >> 12) & 0x3F)));
    out->push_back(static_cast<char>(0x80 | ((c >> 6) & 0x3F)));
    out->push_back(static_cast<char>(0x80 | (c & 0x3F)));
  }
}

// A MATLAB char array as UTF-8 (its first row if it has several rows).
// nullopt when `var` is not a char array.
std::optional<std::string> CharString(const matvar_t* var) {
  if (var == nullptr) return std::nullopt;
  if (var->class_type == MAT_C_EMPTY || ElementCount(var) == 0) return std::string();
  if (var->class_type != MAT_C_CHAR || var->data == nullptr) return std::nullopt;
  const size_t n = ElementCount(var);
  const size_t rows = var->rank >= 2 ? var->dims[0] : 1;
  const size_t cols = var->rank >= 2 ? var->dims[1] : n;
  // Column-major: a 1xN or Nx1 string is linear; of a matrix, row 0.
  const bool linear = rows == 1 || cols == 1;
  const size_t count = linear ? n : cols;
  const auto index = [&](size_t j) { return linear ? j : j * rows; };
  std::string out;
  switch (var->data_size) {
    case 1: {
      const auto* d = static_cast<const unsigned char*>(var->data);
      for (size_t j = 0; j < count; ++j) out.push_back(static_cast<char>(d[index(j)]));
      break;
    }
    case 2: {
      const auto* d = static_cast<const uint16_t*>(var->data);
      for (size_t j = 0; j < count; ++j) {
        uint32_t c = d[index(j)];
        if (c >= 0xD800 && c < 0xDC00 && j + 1 < count) {  // surrogate pair
          const uint32_t low = d[index(j + 1)];
          if (low >= 0xDC00 && low < 0xE000) {
            c = 0x10000 + ((c - 0xD800) << 10) + (low - 0xDC00);
            ++j;
          }
        }
        AppendUtf8(c, &out);
      }
      break;
    }
    case 4: {
      const auto* d = static_cast<const uint32_t*>(var->data);
      for (size_t j = 0; j < count; ++j) AppendUtf8(d[index(j)], &out);
      break;
    }
    default:
      return std::nullopt;
  }
  // MATLAB pads char matrices with blanks; names never end in one.
  while (!out.empty() && (out.back() == ' ' || out.back() == '\0')) out.pop_back();
  return out;
}

// The elements of a real numeric array as doubles, column-major. nullopt
// for other classes.
std::optional<std::vector<double>> Numbers(const matvar_t* var) {
  if (var == nullptr || var->isComplex) return std::nullopt;
  const size_t n = ElementCount(var);
  std::vector<double> out(n);
  if (n == 0) return out;
  if (var->data == nullptr) return std::nullopt;
  const auto copy = [&](auto type_tag) {
    using T = decltype(type_tag);
    const T* d = static_cast<const T*>(var->data);
    for (size_t i = 0; i < n; ++i) out[i] = static_cast<double>(d[i]);
  };
  switch (var->class_type) {
    case MAT_C_DOUBLE:
      copy(double());
      break;
    case MAT_C_SINGLE:
      copy(float());
      break;
    case MAT_C_INT8:
      copy(int8_t());
      break;
    case MAT_C_UINT8:
      copy(uint8_t());
      break;
    case MAT_C_INT16:
      copy(int16_t());
      break;
    case MAT_C_UINT16:
      copy(uint16_t());
      break;
    case MAT_C_INT32:
      copy(int32_t());
      break;
    case MAT_C_UINT32:
      copy(uint32_t());
      break;
    case MAT_C_INT64:
      copy(int64_t());
      break;
    case MAT_C_UINT64:
      copy(uint64_t());
      break;
    default:
      return std::nullopt;
  }
  return out;
}

}  // namespace

absl::StatusOr<std::vector<CcvlFrame>> ReadCcvl(const std::string& path) {
  const MatFile mat(Mat_Open(path.c_str(), MAT_ACC_RDONLY));
  if (!mat) {
    return absl::InvalidArgumentError(absl::StrCat("cannot open ", path, " as a MAT-file"));
  }
  MatVar ld(Mat_VarRead(mat.get(), "ld"));
  if (!ld) {  // another name: the first struct in the file
    Mat_Rewind(mat.get());
    while (matvar_t* var = Mat_VarReadNext(mat.get())) {
      MatVar next(var);
      if (next->class_type == MAT_C_STRUCT) {
        ld = std::move(next);
        break;
      }
    }
  }
  if (!ld || ld->class_type != MAT_C_STRUCT || ElementCount(ld.get()) < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": no struct `ld` (expected the Caltech Lanes label layout)"));
  }
  matvar_t* frames = Mat_VarGetStructFieldByName(ld.get(), "frames", 0);
  if (frames == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": ld has no field `frames`"));
  }
  if (frames->class_type != MAT_C_STRUCT && frames->class_type != MAT_C_CELL &&
      ElementCount(frames) != 0) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": ld.frames is not a struct array"));
  }
  std::vector<CcvlFrame> out;
  const size_t frame_count = StructCount(frames);
  out.reserve(frame_count);
  for (size_t i = 0; i < frame_count; ++i) {
    const std::string where = absl::StrCat(path, ": ld.frames(", i + 1, ")");
    CcvlFrame frame;
    const std::optional<std::string> name = CharString(Field(frames, "frame", i));
    if (!name || name->empty()) {
      return absl::InvalidArgumentError(absl::StrCat(where, ".frame must be a file name"));
    }
    frame.frame = *name;
    matvar_t* labels = Field(frames, "labels", i);
    const size_t label_count = StructCount(labels);
    for (size_t k = 0; k < label_count; ++k) {
      const std::string label_where = absl::StrCat(where, ".labels(", k + 1, ")");
      const matvar_t* points_var = Field(labels, "points", k);
      const std::optional<std::vector<double>> values = Numbers(points_var);
      if (!values || points_var->rank != 2) {
        return absl::InvalidArgumentError(
            absl::StrCat(label_where, ".points must be a numeric Nx2 array"));
      }
      const size_t rows = points_var->dims[0];
      const size_t cols = points_var->dims[1];
      std::vector<Eigen::Vector2d> points;
      if (cols == 2 && rows >= 2) {
        for (size_t r = 0; r < rows; ++r) points.emplace_back((*values)[r], (*values)[r + rows]);
      } else if (rows == 2 && cols >= 2) {
        for (size_t c = 0; c < cols; ++c) {
          points.emplace_back((*values)[2 * c], (*values)[2 * c + 1]);
        }
      } else {
        return absl::InvalidArgumentError(
            absl::StrCat(label_where, ".points is ", Shape(points_var), ", expected 4x2"));
      }
      for (const Eigen::Vector2d& p : points) {
        if (!p.allFinite()) {
          return absl::InvalidArgumentError(
              absl::StrCat(label_where, ".points holds a non-finite value"));
        }
      }
      LabelledBoundary label;
      label.curve = points.size() == 4 ? Curve::FromBezier(std::array<Eigen::Vector2d, 4>{
                                             points[0], points[1], points[2], points[3]})
                                       : Curve::Polyline(std::move(points));
      label.type = CharString(Field(labels, "subtype", k)).value_or("");
      frame.labels.push_back(std::move(label));
    }
    out.push_back(std::move(frame));
  }
  return out;
}

std::vector<std::string> ParseImageList(absl::string_view text) {
  std::vector<std::string> entries;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    line = absl::StripAsciiWhitespace(line);
    if (line.empty() || line[0] == '#') continue;
    entries.emplace_back(line);
  }
  return entries;
}

absl::StatusOr<std::vector<std::string>> ReadImageList(const std::string& path) {
  absl::StatusOr<std::string> text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  return ParseImageList(*text);
}

}  // namespace lane::eval
