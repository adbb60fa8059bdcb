// Stage 7, the checks that drop candidates which are not lane markings (not
// in the paper, which names vehicles, curbs and writing as its false
// positives): grouped here so that PostprocessCandidates (postprocess.cc)
// calls one function per frame of reference. The checks themselves live in
// vehicle_check.h and marking_check.h; their options in PostprocessOptions.
#ifndef LANE_CANDIDATE_CHECKS_H_
#define LANE_CANDIDATE_CHECKS_H_

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "lane/geometry/bezier.h"
#include "lane/geometry/camera.h"
#include "lane/geometry/channel_view.h"
#include "lane/geometry/ipm.h"
#include "lane/postprocess/postprocess_options.h"

namespace lane {

// What the top-view checks need to know about the whole frame.
struct TopViewCheckContext {
  double road_deg = 0;   // the road's direction (RoadDirectionDeg)
  float road_level = 0;  // the road's level in the top view (RoadLevel)
};
TopViewCheckContext MakeTopViewCheckContext(const std::vector<Bezier>& ipm_splines,
                                            const cv::Mat& top_view, const IpmMapping& ipm,
                                            const PostprocessOptions& pp);

// The bright-side and ray tests on a top-view spline: true to keep it.
bool PassesTopViewChecks(const Bezier& ipm_spline, const cv::Mat& top_view, const IpmMapping& ipm,
                         const PostprocessOptions& pp, const TopViewCheckContext& context);

// The final image spline: cut to the image content (clip_to_image), checked
// against the road's direction on the ground (check_ground_angle) and for
// colour (max_redness, on BGR frames). nullopt to drop it. `scale` is the
// image width / 640. With extend_to_max_row (a labelling convention that
// runs every lane on to that row, through the hood), rows below
// `road_bottom_row`, the lowest the top view reads from the road, are not
// cut for being black (ClipToImageContent).
std::optional<Bezier> FinishImageSpline(const Bezier& image_spline, const ChannelView& channel,
                                        const cv::Mat& frame, const CameraModel& camera,
                                        const PostprocessOptions& pp, double scale,
                                        double road_bottom_row);

}  // namespace lane

#endif  // LANE_CANDIDATE_CHECKS_H_
