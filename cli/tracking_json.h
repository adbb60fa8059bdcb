// The tracking fields of results schema 1 (docs/results-format.md), shared
// by `lane detect --track` (cli/results_json.cc) and lane-client's results.
#ifndef LANE_CLI_TRACKING_JSON_H_
#define LANE_CLI_TRACKING_JSON_H_

#include <nlohmann/json.hpp>
#include <optional>

#include "lane/detector.h"

namespace lane_tools {

// Adds "id", "confirmed", "predicted", "color" and "type" to a lane object.
void AddLaneTrackingFields(const lane::Lane& lane, nlohmann::ordered_json& out);
// The frame's "ego" object (null when the ego lane was not found).
nlohmann::ordered_json EgoJson(const std::optional<lane::EgoLane>& ego);

}  // namespace lane_tools

#endif  // LANE_CLI_TRACKING_JSON_H_
