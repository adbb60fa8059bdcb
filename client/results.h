// `lane-client stream` results: JSON Lines, one object per frame, schema 1
// (docs/client.md).
#ifndef LANE_CLIENT_RESULTS_H_
#define LANE_CLIENT_RESULTS_H_

#include <cstdint>
#include <string>

#include "lane/detector.h"
#include "lane/v1/lane_service.pb.h"

namespace lane_client {

inline constexpr int kStreamResultsSchema = 1;

// "OK", "INVALID_ARGUMENT", "DROPPED", "INTERNAL" (the FrameCode without its
// prefix), or "UNKNOWN_<n>".
std::string FrameCodeName(lane::v1::FrameCode code);

// One line (without the newline) for a frame the server answered.
// `latency_ms`: from the client's last send of the frame to its response;
// `attempts`: how many times it was sent; `connection`: which of the
// stream's calls answered it (1, 2, ...; 0 = not written).
std::string ResponseJsonLine(const std::string& frame_name, const lane::v1::FrameResponse& response,
                             double latency_ms, int attempts, uint64_t connection = 0);

// One line for a frame that could not be read here and was not sent:
// status "CLIENT_ERROR".
std::string ClientErrorJsonLine(const std::string& frame_name, const std::string& camera_id,
                                uint64_t frame_id, const std::string& error);

// The lanes of a response as a core Detection (for the overlay drawings).
lane::Detection DetectionFromResponse(const lane::v1::FrameResponse& response);

}  // namespace lane_client

#endif  // LANE_CLIENT_RESULTS_H_
