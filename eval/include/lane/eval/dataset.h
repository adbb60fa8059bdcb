// A labelled data set on disk: its format, its clips and their frames.
//
// Recognised layouts (LoadDataset looks for them in this order):
//  * Caltech Lanes: a folder with `labels.ccvl` (and usually `list.txt`), or
//    a folder whose subfolders are such clips (cordova1, cordova2, ...).
//  * `lane render` output: a folder with `labels.jsonl`, or subfolders with
//    one.
//  * CULane: folders with images and `NNNNN.lines.txt` beside them; every
//    folder (the given one or below it, 4 levels deep) holding .lines.txt
//    files is a clip.
//  * TuSimple: `.json` label files (JSON Lines with lanes/h_samples/raw_file)
//    in the folder; each file is a clip, raw_file is relative to the folder.
#ifndef LANE_EVAL_DATASET_H_
#define LANE_EVAL_DATASET_H_

#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "lane/eval/labels.h"

namespace lane::eval {

enum class DatasetFormat { kCaltech, kCulane, kTusimple, kRender };
const char* DatasetFormatName(DatasetFormat format);  // "caltech", "culane", ...
std::optional<DatasetFormat> ParseDatasetFormat(const std::string& name);

struct Clip {
  // The clip's folder relative to the data set folder ("cordova1"), or, for
  // a data set that is a single clip, that folder's name. TuSimple: the label
  // file's name without ".json".
  std::string name;
  std::vector<LabelledFrame> frames;  // in the clip's frame order
};

struct Dataset {
  DatasetFormat format = DatasetFormat::kCulane;
  std::string root;         // the folder given
  std::vector<Clip> clips;  // sorted by name
  // Oddities that did not stop loading (labels without an image, list
  // entries without labels, clips whose labels repeat from frame to frame,
  // ...), one message each.
  std::vector<std::string> warnings;

  // Frames over all clips, in clip order then frame order: the order of the
  // original tool's results file.
  int FrameCount() const;
};

// Labelled frames of `clip` whose boundaries are exactly those of the
// labelled frame before them (same count, same kind, same points; frames
// without boundaries do not count). Hand labels never repeat to the last
// digit while the car moves: a run of them is one annotation copied over a
// standstill or past it. CULane's driver161 clip has 27 such frames of its
// 57 labelled ones, whose labels all meet at one vanishing point
// (docs/calibration.md).
struct RepeatedLabels {
  int labelled = 0;             // labelled frames with boundaries
  std::vector<size_t> indices;  // the repeating frames, into clip.frames, in order
};
RepeatedLabels FindRepeatedLabels(const Clip& clip);

// The format of the data set in `root`, or INVALID_ARGUMENT explaining what
// was looked for.
absl::StatusOr<DatasetFormat> DetectDatasetFormat(const std::string& root);

// Loads every clip's labels (images are not read). With `format`, skips the
// detection. Errors name the offending file (and line).
absl::StatusOr<Dataset> LoadDataset(const std::string& root,
                                    std::optional<DatasetFormat> format = std::nullopt);

}  // namespace lane::eval

#endif  // LANE_EVAL_DATASET_H_
