// The results of a frame as schema 1 JSON (docs/results-format.md), one
// object per frame, one a line: the one writer of `lane detect` (with and
// without --track), `lane backfill`, `lane eval --output` and `lane-client
// stream` (which adds its own fields, client/results.h).
#ifndef LANE_IO_RESULTS_JSON_H_
#define LANE_IO_RESULTS_JSON_H_

#include <nlohmann/json.hpp>
#include <string>

#include "lane/detector/detector.h"
#include "lane/track/tracked_frame.h"

namespace lane::io {

inline constexpr int kResultsSchema = 1;

// What a record says of the frame itself: its name, size and the mode used.
// The size is written when positive.
struct ResultsFrame {
  std::string name;
  int width = 0;
  int height = 0;
  lane::Mode mode = lane::Mode::kAll;
};

// {"schema":1,"frame":...,"width":W,"height":H,"mode":"all","lanes":[...],
//  "timing_ms":{...}}. Image and IPM coordinates are rounded to 3 decimals,
// ground coordinates to 4; each lane has "image", "ipm", "ground", "score"
// and "inferred"; "timing_ms" has "decode" (`decode_ms`), the detector's
// stages and "total".
nlohmann::ordered_json DetectionJson(const ResultsFrame& frame, const lane::Detection& detection,
                                     double decode_ms);
// The same for a tracked frame (lane detect --track): its lanes (the
// predicted ones too) each also have "id", "confirmed", "predicted",
// "color", "type" and "refit", and the frame an "ego" object (null when the
// ego lane is not found); the timings are its detection's.
nlohmann::ordered_json DetectionJson(const ResultsFrame& frame, const lane::TrackedFrame& tracked,
                                     double decode_ms);

// {"schema":1,"frame":...,["width":W,"height":H,]"mode":"all","error":"..."}
// for a frame that could not be read or processed.
nlohmann::ordered_json ErrorJson(const ResultsFrame& frame, const std::string& error);

// `record` on one line, without the newline (invalid UTF-8, as in a file
// name, replaced).
std::string JsonLine(const nlohmann::ordered_json& record);

// A value rounded to `decimals` decimals as the records round (no "-0").
double RoundTo(double value, int decimals);

}  // namespace lane::io

#endif  // LANE_IO_RESULTS_JSON_H_
