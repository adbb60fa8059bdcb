#include "lane/postprocess/candidate_checks.h"

#include <cmath>
#include <limits>

#include "lane/postprocess/image_extension.h"
#include "lane/postprocess/marking_check.h"
#include "lane/postprocess/vehicle_check.h"

namespace lane {

TopViewCheckContext MakeTopViewCheckContext(const std::vector<Bezier>& ipm_splines,
                                            const cv::Mat& top_view, const IpmMapping& ipm,
                                            const PostprocessOptions& pp) {
  TopViewCheckContext context;
  if (pp.min_ray_angle_deg > 0) context.road_deg = RoadDirectionDeg(ipm_splines, ipm);
  if (pp.max_bright_side_fraction < 1) context.road_level = RoadLevel(top_view, ipm.valid_mask());
  return context;
}

bool PassesTopViewChecks(const Bezier& ipm_spline, const cv::Mat& top_view, const IpmMapping& ipm,
                         const PostprocessOptions& pp, const TopViewCheckContext& context) {
  if (pp.max_bright_side_fraction < 1 &&
      BrightSideFraction(ipm_spline, top_view, context.road_level,
                         pp.side_offset_m / ipm.metres_per_px_x()) > pp.max_bright_side_fraction) {
    return false;  // beside a bright object
  }
  if (pp.min_ray_angle_deg > 0 &&
      TestRay(ipm_spline, ipm).RayLike(pp.min_ray_angle_deg, context.road_deg, pp.max_ray_bend_m)) {
    return false;  // a vertical object's streak
  }
  return true;
}

std::optional<Bezier> FinishImageSpline(const Bezier& image_spline, const ChannelView& channel,
                                        const cv::Mat& frame, const CameraModel& camera,
                                        const PostprocessOptions& pp, double scale,
                                        double road_bottom_row) {
  Bezier s = image_spline;
  if (pp.clip_to_image) {
    // A black hood is no lens circle's outside: below the road the top view
    // reads, the convention's rows count as content.
    const std::optional<Bezier> clipped = ClipToImageContent(
        s, channel,
        pp.extend_to_max_row ? road_bottom_row : std::numeric_limits<double>::infinity());
    if (!clipped) return std::nullopt;
    s = *clipped;
    if (s.p[0].y() > s.p[3].y()) {  // keep the upper end first
      std::swap(s.p[0], s.p[3]);
      std::swap(s.p[1], s.p[2]);
    }
  }
  // The top view's direction check on the final spline: image localisation
  // and extension must not have turned it away from the road.
  if (pp.check_ground_angle &&
      GroundAngleFromRoadDeg(s, camera) > pp.ipm_max_angle_from_vertical_deg) {
    return std::nullopt;
  }
  if (pp.max_redness < 1 && frame.channels() == 3) {
    const double r = MedianRedness(s, frame, channel, 2 * scale);
    if (std::isfinite(r) && r > pp.max_redness) return std::nullopt;  // a red curb or vehicle
  }
  return s;
}

}  // namespace lane
