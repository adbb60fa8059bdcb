// Reading a rendered drive and a tracker's results for ScoreDrive (`lane
// eval --drive`): the labels `lane render --sequence` writes (labels.jsonl
// with boundary ids, the time and the true ego lane) and the JSON Lines of
// `lane detect --track` (lane ids, confirmed, colour, type and the ego lane).
#ifndef LANE_EVAL_DRIVE_IO_H_
#define LANE_EVAL_DRIVE_IO_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "lane/eval/drive.h"

namespace lane::eval {

struct DriveLabels {
  std::vector<std::string> frames;  // the "frame" of each line (an image file in the folder)
  std::vector<DriveTruthFrame> truth;
};

// One frame per line. Every line must be a drive frame's: "time_s" and
// "ego" besides the boundaries (each with "id"); "road_edges" is optional.
// INVALID_ARGUMENT "SOURCE:LINE: ..." otherwise.
absl::StatusOr<DriveLabels> ParseDriveLabels(absl::string_view text, absl::string_view source);
absl::StatusOr<DriveLabels> ReadDriveLabels(const std::string& path);

struct DriveResults {
  std::vector<std::string> frames;  // each record's "frame"
  std::vector<DriveOutput> outputs;
  // Whether the records carry tracking fields (lane "id", frame "ego"):
  // `lane detect --track`.
  bool tracked = false;
};

// Schema 1 records (docs/results-format.md); a record with "error" gives a
// frame without lanes. Lanes keep their image Bezier and, when present, id,
// confirmed, predicted, colour and type; the ego lane's boundaries are
// found among the frame's lanes by their ids.
absl::StatusOr<DriveResults> ParseDriveResults(absl::string_view text, absl::string_view source);
absl::StatusOr<DriveResults> ReadDriveResults(const std::string& path);

}  // namespace lane::eval

#endif  // LANE_EVAL_DRIVE_IO_H_
