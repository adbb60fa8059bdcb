// Caltech Lanes labels and image lists.
//
// `labels.ccvl` is a MATLAB v5 MAT-file (read with libmatio) holding one
// struct `ld` (../shared/docs/reference-implementation-notes.md):
//   ld.version = 0, ld.source = 'image'
//   ld.frames(i).frame            image file name, e.g. 'f00000.png'
//   ld.frames(i).labels(k).points 4x2 Bezier control points [x y], image px
//   ld.frames(i).labels(k).type   'spline'
//   ld.frames(i).labels(k).subtype  'bw' | 'sw' | 'dy' | 'by' | 'sy'
//   ld.frames(i).labels(k).obj    []
// `list.txt` names the clip's images, one a line, in frame order.
#ifndef LANE_EVAL_CALTECH_H_
#define LANE_EVAL_CALTECH_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "lane/eval/labels.h"

namespace lane::eval {

struct CcvlFrame {
  std::string frame;                     // ld.frames(i).frame as written
  std::vector<LabelledBoundary> labels;  // type = the subtype
};

// Reads `ld` (or, failing that, the file's first struct variable). Tolerates
// what MATLAB may write differently: frames/labels as cell arrays of structs,
// empty labels as [] or a 0x0 struct, points as 2xN instead of Nx2, any
// numeric class. `points` with 4 rows is a Bezier; other counts (>= 2) are
// taken as a polyline. INVALID_ARGUMENT naming the file and the element
// ("labels.ccvl: ld.frames(3).labels(2).points is 1x2") otherwise.
absl::StatusOr<std::vector<CcvlFrame>> ReadCcvl(const std::string& path);

// The entries of an image list: one a line, surrounding blanks stripped,
// blank lines and lines starting with '#' skipped.
std::vector<std::string> ParseImageList(absl::string_view text);
absl::StatusOr<std::vector<std::string>> ReadImageList(const std::string& path);

}  // namespace lane::eval

#endif  // LANE_EVAL_CALTECH_H_
