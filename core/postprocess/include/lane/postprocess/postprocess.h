// Stage 7: post-processing (paper section II-E): localisation along normals,
// extension along the tangent, geometric checks with fallback to the RANSAC
// line. Done in the top view and again in the image. The top of the
// postprocess layer: PostprocessCandidates runs the steps and checks of the
// headers below it (postprocess_options.h, spline_walk.h, profile.h,
// candidate_checks.h, image_extension.h, marking_check.h, vehicle_check.h).
#ifndef LANE_POSTPROCESS_POSTPROCESS_H_
#define LANE_POSTPROCESS_POSTPROCESS_H_

#include <opencv2/core.hpp>
#include <vector>

#include "lane/geometry/channel_view.h"
#include "lane/geometry/ipm.h"
#include "lane/postprocess/postprocess_options.h"
#include "lane/stages/spline_candidate.h"

namespace lane {

// One frame's images that post-processing reads.
struct PostprocessFrame {
  const IpmMapping& ipm;
  const cv::Mat& top_view;     // CV_32F, mean removed
  const cv::Mat& filtered;     // the filter's response
  const ChannelView& channel;  // the detector's channel of the frame
  const cv::Mat& frame;        // the frame itself (colour checks)
};

// Stage 7: for each candidate, in order, in the top view: localise, check
// the shape (else fall back to its line), extend, check the direction and the
// top-view marking checks (candidate_checks.h); back-project into the image;
// there localise, extend and finish (clip, colour, ground angle); finally drop
// an image spline that lies along one kept before it. `marking_width_m` is
// the filter's marking width; `merge_distance_px` the spline RANSAC's
// duplicate distance (scaled to the image here). Returns the survivors with
// their image splines.
std::vector<SplineCandidate> PostprocessCandidates(const std::vector<SplineCandidate>& candidates,
                                                   const PostprocessFrame& frame,
                                                   const PostprocessOptions& options,
                                                   double marking_width_m,
                                                   double merge_distance_px);

}  // namespace lane

#endif  // LANE_POSTPROCESS_POSTPROCESS_H_
