// The results file of `lane detect`: JSON Lines, one object per frame.
// docs/results-format.md describes schema 1.
#ifndef LANE_CLI_RESULTS_JSON_H_
#define LANE_CLI_RESULTS_JSON_H_

#include <string>

#include "lane/detector.h"

namespace lane_tools {

inline constexpr int kResultsSchema = 1;

// {"schema":1,"frame":...,"width":W,"height":H,"mode":"all","lanes":[...],
//  "timing_ms":{...}} on one line, without the newline. Image and IPM
// coordinates are rounded to 3 decimals, ground coordinates to 4.
// With `tracked` (lane detect --track), each lane also has "id",
// "confirmed" and "color", and the frame an "ego" object (null when the ego
// lane is not found).
std::string DetectionJsonLine(const std::string& frame, int width, int height, lane::Mode mode,
                              const lane::Detection& detection, double decode_ms,
                              bool tracked = false);

// {"schema":1,"frame":...,["width":W,"height":H,]"mode":"all","error":"..."}
// for a frame that could not be read or processed. width/height are written
// when positive.
std::string ErrorJsonLine(const std::string& frame, int width, int height, lane::Mode mode,
                          const std::string& error);

}  // namespace lane_tools

#endif  // LANE_CLI_RESULTS_JSON_H_
