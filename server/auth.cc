#include "auth.h"

#include <fstream>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace lane::server {

bool ConstantTimeEquals(absl::string_view a, absl::string_view b) {
  const size_t n = a.size() > b.size() ? a.size() : b.size();
  unsigned diff = a.size() == b.size() ? 0u : 1u;
  for (size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    diff |= static_cast<unsigned>(x ^ y);
  }
  return diff == 0;
}

absl::StatusOr<std::vector<std::string>> ReadTokenFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot read token file ", path));
  std::vector<std::string> tokens;
  std::string line;
  while (std::getline(in, line)) {
    const absl::string_view token = absl::StripAsciiWhitespace(line);
    if (token.empty() || absl::StartsWith(token, "#")) continue;
    tokens.emplace_back(token);
  }
  if (tokens.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("token file ", path, " has no token"));
  }
  return tokens;
}

std::vector<std::string> ParseTokenList(absl::string_view list) {
  std::vector<std::string> tokens;
  for (absl::string_view part : absl::StrSplit(list, ',')) {
    part = absl::StripAsciiWhitespace(part);
    if (!part.empty()) tokens.emplace_back(part);
  }
  return tokens;
}

bool IsAcceptedToken(absl::string_view presented, const std::vector<std::string>& tokens) {
  bool match = false;
  // Every token is compared (no early exit), each in constant time.
  for (const std::string& token : tokens) match |= ConstantTimeEquals(presented, token);
  return match;
}

absl::Status CheckBearerValue(absl::string_view authorization,
                              const std::vector<std::string>& tokens) {
  if (tokens.empty()) return absl::OkStatus();
  if (authorization.empty()) {
    return absl::UnauthenticatedError("missing authorization metadata (Bearer token)");
  }
  absl::string_view presented = authorization;
  if (!absl::ConsumePrefix(&presented, "Bearer ") && !absl::ConsumePrefix(&presented, "bearer ")) {
    return absl::UnauthenticatedError("authorization metadata is not a Bearer token");
  }
  if (!IsAcceptedToken(presented, tokens)) {
    return absl::UnauthenticatedError("invalid Bearer token");
  }
  return absl::OkStatus();
}

absl::Status CheckBearerToken(const grpc::ServerContextBase& context,
                              const std::vector<std::string>& tokens) {
  if (tokens.empty()) return absl::OkStatus();
  const auto& metadata = context.client_metadata();
  const auto it = metadata.find("authorization");
  if (it == metadata.end()) {
    return absl::UnauthenticatedError("missing authorization metadata (Bearer token)");
  }
  return CheckBearerValue(absl::string_view(it->second.data(), it->second.size()), tokens);
}

}  // namespace lane::server
