// Shared set-up of the fuzz targets: the session of configs/synthetic.json
// (640x480), built once.
#ifndef LANE_FUZZ_FUZZ_COMMON_H_
#define LANE_FUZZ_FUZZ_COMMON_H_

#include <cstdlib>
#include <memory>
#include <string>

#include "lane/config/config.h"
#include "session_registry.h"

#ifndef LANE_SOURCE_DIR
#define LANE_SOURCE_DIR "."
#endif

namespace lane::fuzz {

inline lane::Config SyntheticConfig() {
  absl::StatusOr<lane::Config> config =
      lane::LoadConfigFile(std::string(LANE_SOURCE_DIR) + "/configs/synthetic.json");
  if (!config.ok()) std::abort();
  return *config;
}

inline std::shared_ptr<lane::server::Session> SyntheticSession() {
  static lane::server::SessionRegistry* registry =
      new lane::server::SessionRegistry(lane::server::SessionRegistry::Options());
  static std::shared_ptr<lane::server::Session> session = [] {
    lane::server::SessionSpec spec;
    spec.config = SyntheticConfig();
    auto created = registry->Create("fuzz", spec, false);
    if (!created.ok()) std::abort();
    return created->session;
  }();
  return session;
}

}  // namespace lane::fuzz

#endif  // LANE_FUZZ_FUZZ_COMMON_H_
