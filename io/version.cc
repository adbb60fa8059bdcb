// The version --version prints. LANE_VERSION and LANE_GIT_REVISION come from
// io/CMakeLists.txt (the project version, `git describe` at configure time).
#include <string>

#include "io/command_line.h"

#ifndef LANE_VERSION
#define LANE_VERSION "unknown"
#endif
#ifndef LANE_GIT_REVISION
#define LANE_GIT_REVISION "unknown"
#endif

namespace lane::io {

std::string VersionString() { return std::string(LANE_VERSION) + " (git " LANE_GIT_REVISION ")"; }

}  // namespace lane::io
