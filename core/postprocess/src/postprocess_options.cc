#include "lane/postprocess/postprocess_options.h"

#include <cmath>

#include "absl/strings/str_cat.h"

namespace lane {

absl::Status PostprocessOptions::Validate() const {
  auto bad = [](const char* name, double v, double lo, double hi) -> absl::Status {
    if (!(v >= lo && v <= hi)) {
      return absl::InvalidArgumentError(
          absl::StrCat("postprocess.", name, " must lie in [", lo, ", ", hi, "], got ", v));
    }
    return absl::OkStatus();
  };
  const struct {
    const char* name;
    double v, lo, hi;
  } checks[] = {
      {"ipm_max_angle_from_vertical_deg", ipm_max_angle_from_vertical_deg, 0, 90},
      {"min_straightness", min_straightness, -1, 1},
      {"min_length_fraction", min_length_fraction, 0, 10},
      {"ipm_extend_step_px", ipm_extend_step_px, 0.5, 100},
      {"ipm_normal_search_px", ipm_normal_search_px, 0, 100},
      {"backproject_samples", static_cast<double>(backproject_samples), 4, 1000},
      {"localize_points", static_cast<double>(localize_points), 4, 1000},
      {"localize_search_px", localize_search_px, 0, 500},
      {"profile_sigma_px", profile_sigma_px, 0, 50},
      {"localize_min_cos", localize_min_cos, -1, 1},
      {"extend_step_px", extend_step_px, 0.5, 500},
      {"extend_search_px", extend_search_px, 0, 500},
      {"continuation_threshold", continuation_threshold, 0, 10},
      {"extend_min_cos_up", extend_min_cos_up, -1, 1},
      {"extend_min_cos_down", extend_min_cos_down, -1, 1},
      {"min_image_length_px", min_image_length_px, 0, 1e5},
      {"side_offset_m", side_offset_m, 0, 10},
      {"min_side_contrast", min_side_contrast, 0, 1},
      {"min_bar_fraction", min_bar_fraction, 0.01, 1},
      {"extend_search_m", extend_search_m, 0.01, 10},
      {"min_ray_angle_deg", min_ray_angle_deg, 0, 90},
      {"max_ray_bend_m", max_ray_bend_m, 0, 10},
      {"max_bright_side_fraction", max_bright_side_fraction, 0, 1},
      {"max_redness", max_redness, -1, 1},
      {"localize_search_m", localize_search_m, 0.01, 10},
      {"localize_sigma_m", localize_sigma_m, 0, 2},
      {"extend_gap_m", extend_gap_m, 0, 100},
  };
  for (const auto& c : checks) {
    if (auto s = bad(c.name, c.v, c.lo, c.hi); !s.ok()) return s;
  }
  if (!std::isfinite(extend_min_row) || !std::isfinite(extend_max_row)) {
    return absl::InvalidArgumentError("postprocess.extend_*_row must be finite");
  }
  return absl::OkStatus();
}

}  // namespace lane
