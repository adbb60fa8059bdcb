// Bearer-token authentication of the lane service: the accepted tokens, read
// from a file or an environment variable (never from the command line), and
// the one check every LaneService call goes through (LaneServiceImpl).
#ifndef LANE_SERVER_AUTH_H_
#define LANE_SERVER_AUTH_H_

#include <grpcpp/grpcpp.h>

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace lane::server {

// Equal in time that depends only on the lengths (never on where the
// contents first differ).
bool ConstantTimeEquals(absl::string_view a, absl::string_view b);

// Tokens of a file, one per line (blank lines and lines starting with '#'
// skipped, surrounding whitespace stripped). Errors name the file, never a
// token.
absl::StatusOr<std::vector<std::string>> ReadTokenFile(const std::string& path);
// Tokens of a comma-separated list (empty entries skipped).
std::vector<std::string> ParseTokenList(absl::string_view list);

// OK when `tokens` is empty (auth off) or the call's `authorization`
// metadata is "Bearer T" for one of `tokens`; UNAUTHENTICATED otherwise.
absl::Status CheckBearerToken(const grpc::ServerContextBase& context,
                              const std::vector<std::string>& tokens);

// The same check on an `Authorization` header's value (the live view's HTTP
// requests; empty: no header). Messages never quote the token.
absl::Status CheckBearerValue(absl::string_view authorization,
                              const std::vector<std::string>& tokens);
// True when `presented` is one of `tokens`: every token is compared, each in
// constant time (CheckBearerToken and CheckBearerValue use it).
bool IsAcceptedToken(absl::string_view presented, const std::vector<std::string>& tokens);

}  // namespace lane::server

#endif  // LANE_SERVER_AUTH_H_
