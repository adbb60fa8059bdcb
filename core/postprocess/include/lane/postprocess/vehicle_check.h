// Stage 7, rejecting vehicles (not in the paper). The top view assumes that
// everything lies on the road. A vehicle's vertical edges, tail lights and
// bodywork do not: a point at height z above the road maps to the road point
// where the ray from the camera through it meets the road, farther out along
// the ray through its foot point. So a vertical object becomes a streak in
// the top view that points at the camera's foot point (the origin of the
// ground frame), while a marking runs parallel to the road.
#ifndef LANE_VEHICLE_CHECK_H_
#define LANE_VEHICLE_CHECK_H_

#include <Eigen/Core>
#include <cmath>
#include <opencv2/core.hpp>
#include <vector>

#include "lane/geometry/bezier.h"
#include "lane/geometry/ipm.h"

namespace lane {

// The straight line x = a + b y through a candidate's points on the ground
// (metres, x lateral, y ahead) against the two hypotheses at its middle
// point (x_m, y_m): a marking runs along the road (angle 0), a vertical
// object's streak along the ray from the camera's foot point through
// (x_m, y_m) (angle atan(x_m / y_m)).
struct RayTest {
  bool valid = false;
  double line_deg = 0;  // the line's angle from the road's direction, degrees
  double ray_deg = 0;   // the ray's
  double bend_m = 0;    // largest distance of a point from the line, metres
  // Closer to the ray than to the road (whose direction in this frame is
  // `road_deg`: yaw and curves tilt all markings alike), the two at least
  // `min_ray_angle_deg` apart (nearer the camera's axis they coincide), and
  // straight: a ray bends less than `max_bend_m`, markings on curves more.
  bool RayLike(double min_ray_angle_deg, double road_deg = 0, double max_bend_m = 0.15) const {
    return valid && std::abs(ray_deg - road_deg) >= min_ray_angle_deg && bend_m <= max_bend_m &&
           std::abs(line_deg - ray_deg) < std::abs(line_deg - road_deg);
  }
};
RayTest TestRay(const std::vector<Eigen::Vector2d>& ground_points);

// TestRay on 21 samples of a top-view spline mapped to the ground.
RayTest TestRay(const Bezier& ipm_spline, const IpmMapping& ipm);

// The road's direction in a frame, degrees from the ground's y axis: the
// median of the candidates' line angles (markings are parallel and agree;
// vehicle streaks point in all directions). 0 without candidates.
double RoadDirectionDeg(const std::vector<Bezier>& ipm_splines, const IpmMapping& ipm);

// The road's level in a top view: the median of its valid pixels (every 4th
// pixel; the road covers most of a top view, vehicles and verges less).
float RoadLevel(const cv::Mat& top_view, const cv::Mat& valid_mask);

// The fraction of samples along a top-view spline where a side, at
// `side_px` across, is brighter than the road's level by more than half the
// spline's own contrast over it (samples where the spline is not brighter
// than the road are skipped: gaps between dashes). A marking lies on the
// road, with road on both sides; the edge of a white vehicle's body, a
// sidewalk beside a curb or another bright object has it on one side. 0
// when no sample counts.
double BrightSideFraction(const Bezier& spline, const cv::Mat& top_view, float road_level,
                          double side_px, int samples = 20);

}  // namespace lane

#endif  // LANE_VEHICLE_CHECK_H_
