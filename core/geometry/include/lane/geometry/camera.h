// Pinhole camera over a flat road, as in Aly (IV 2008), section II-A.
//
// Frames:
//   * ground: x lateral (metres, positive to the right), y ahead (metres), the
//     road plane is z = -height_m below the camera's optical centre.
//   * image: u to the right, v down (pixels), origin at the top-left corner.
// The camera may pitch and yaw relative to the road but not roll.
#ifndef LANE_CAMERA_H_
#define LANE_CAMERA_H_

#include <Eigen/Core>
#include <cmath>

#include "absl/status/status.h"

namespace lane {

// Degrees to radians, for the angles of a camera and of lines.
inline constexpr double kDegToRad = M_PI / 180.0;

struct CameraModel {
  // Focal lengths in pixels. Defaults: the Caltech Lanes camera (640x480).
  double fu = 309.4362;
  double fv = 344.2161;
  // Optical centre in pixels.
  double cu = 317.9034;
  double cv = 256.5352;
  // Pitch in degrees, positive when the camera looks down at the road. The
  // horizon lies at v = cv - fv * tan(pitch).
  double pitch_deg = 14.0;
  // Yaw in degrees, positive when the camera looks to the right of the road
  // direction (ground x, right +): the road's vanishing point then lies left
  // of the optical centre. The vanishing point lies at u = cu - fu * tan(yaw) / cos(pitch).
  double yaw_deg = 0.0;
  // Height of the optical centre above the road, metres.
  double height_m = 2.1798;
  // Size of the frames the camera delivers, pixels.
  int image_width = 640;
  int image_height = 480;

  // OK, or INVALID_ARGUMENT naming the first field that makes no sense.
  absl::Status Validate() const;

  // The paper's ground->image transform (its matrix i_g T). `ground` is
  // (x, y) on the road plane in metres. Undefined for points behind the camera.
  Eigen::Vector2d GroundToImage(const Eigen::Vector2d& ground) const;
  // The paper's image->ground transform (its matrix g_i T). Only meaningful
  // below the horizon (v > HorizonRow()).
  Eigen::Vector2d ImageToGround(const Eigen::Vector2d& image) const;

  // Image row of the horizon (and of the vanishing point of the road).
  double HorizonRow() const;
  // Image position of the vanishing point of lines parallel to the y axis.
  Eigen::Vector2d VanishingPoint() const;
};

}  // namespace lane

#endif  // LANE_CAMERA_H_
