// IpmOptions: validation and the static mask (lane/geometry/ipm.h).
#include <cmath>

#include "absl/strings/str_cat.h"
#include "ipm_internal.h"
#include "lane/geometry/ipm.h"

namespace lane {

absl::Status IpmOptions::Validate() const {
  if (!std::isfinite(horizon_margin_px) || horizon_margin_px < 0) {
    return absl::InvalidArgumentError("ipm.horizon_margin_px must be a finite number >= 0");
  }
  if (static_cast<int>(static_mask.size()) > kMaxStaticMaskBoxes) {
    return absl::InvalidArgumentError(absl::StrCat("ipm.static_mask holds ", static_mask.size(),
                                                   " rectangles, more than the limit of ",
                                                   kMaxStaticMaskBoxes));
  }
  for (size_t i = 0; i < static_mask.size(); ++i) {
    const Roi& b = static_mask[i];
    if (!std::isfinite(b.left) || !std::isfinite(b.right) || !std::isfinite(b.top) ||
        !std::isfinite(b.bottom) || b.right < b.left || b.bottom < b.top) {
      return absl::InvalidArgumentError(absl::StrCat(
          "ipm.static_mask[", i, "] must be finite with right >= left and bottom >= top, got left=",
          b.left, " right=", b.right, " top=", b.top, " bottom=", b.bottom));
    }
  }
  if (view == IpmView::kGround) {
    const GroundView& g = ground;
    const double v[] = {g.x_min_m, g.x_max_m,         g.y_min_m,
                        g.y_max_m, g.metres_per_px_x, g.metres_per_px_y};
    for (double x : v) {
      if (!std::isfinite(x)) return absl::InvalidArgumentError("ipm.ground values must be finite");
    }
    if (!(g.x_max_m > g.x_min_m) || !(g.y_min_m > 0) || !(g.y_max_m > g.y_min_m)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "ipm.ground must have x_max_m > x_min_m and y_max_m > y_min_m > 0 (metres ahead of "
          "the camera), got x ",
          g.x_min_m, "..", g.x_max_m, ", y ", g.y_min_m, "..", g.y_max_m));
    }
    if (!(g.metres_per_px_x >= 0.001 && g.metres_per_px_x <= 10 && g.metres_per_px_y >= 0.001 &&
          g.metres_per_px_y <= 10)) {
      return absl::InvalidArgumentError(
          absl::StrCat("ipm.ground.metres_per_px_x and _y must lie in [0.001, 10] metres, got ",
                       g.metres_per_px_x, " and ", g.metres_per_px_y));
    }
    const int w = ipm_internal::GroundPixels(g.x_max_m - g.x_min_m, g.metres_per_px_x);
    const int h = ipm_internal::GroundPixels(g.y_max_m - g.y_min_m, g.metres_per_px_y);
    if (w < 8 || h < 8 || w > 2048 || h > 2048) {
      return absl::InvalidArgumentError(absl::StrCat(
          "ipm.ground gives a ", w, "x", h,
          " pixel top view; ranges / metres_per_px must give 8..2048 pixels each way"));
    }
    return absl::OkStatus();
  }
  if (width < 8 || height < 8 || width > 2048 || height > 2048) {
    return absl::InvalidArgumentError(
        absl::StrCat("ipm size must be within 8..2048 pixels, got ", width, "x", height));
  }
  const double v[] = {roi.left, roi.right, roi.top, roi.bottom};
  for (double x : v) {
    if (!std::isfinite(x)) return absl::InvalidArgumentError("ipm.roi values must be finite");
  }
  if (roi.right <= roi.left || roi.bottom <= roi.top) {
    return absl::InvalidArgumentError(
        absl::StrCat("ipm.roi must have right > left and bottom > top, got left=", roi.left,
                     " right=", roi.right, " top=", roi.top, " bottom=", roi.bottom));
  }
  return absl::OkStatus();
}

bool IpmOptions::Masked(const Eigen::Vector2d& image) const {
  for (const Roi& b : static_mask) {
    if (image.x() >= b.left && image.x() <= b.right && image.y() >= b.top &&
        image.y() <= b.bottom) {
      return true;
    }
  }
  return false;
}

}  // namespace lane
