#include "wire/camera_id.h"

#include "absl/strings/str_cat.h"
#include "lane/base/excerpt.h"

namespace lane::wire {

absl::Status ValidateCameraId(absl::string_view camera_id) {
  if (camera_id.empty() || camera_id.size() > kMaxCameraIdBytes) {
    return absl::InvalidArgumentError(absl::StrCat("camera_id must have 1 to ", kMaxCameraIdBytes,
                                                   " characters, got ", camera_id.size()));
  }
  for (const char c : camera_id) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == ':' || c == '/' || c == '-';
    if (!ok) {
      return absl::InvalidArgumentError(absl::StrCat("camera_id '", lane::Excerpt(camera_id),
                                                     "' has a character outside [A-Za-z0-9._:/-]"));
    }
  }
  return absl::OkStatus();
}

}  // namespace lane::wire
