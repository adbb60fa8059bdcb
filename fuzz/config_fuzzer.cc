// Arbitrary bytes as a JSON config file (lane::ParseConfig), and the
// validation a session would run on it.
#include <cstddef>
#include <cstdint>
#include <string>

#include "lane/config/config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  absl::StatusOr<lane::Config> config = lane::ParseConfig(text);
  if (config.ok()) (void)config->Validate();
  return 0;
}
