// Synthetic road frames with exact ground truth, rendered through a camera
// model: painted markings on textured asphalt with shadows, occluding
// vehicles, sensor noise and JPEG artefacts.
#ifndef LANE_SYNTHETIC_H_
#define LANE_SYNTHETIC_H_

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "lane/geometry/camera.h"

namespace lane {

struct SyntheticOptions {
  // Number of lanes on the road (boundaries = lanes + 1). 0 = random in [1, 5].
  int num_lanes = 0;
  double lane_width_m = 3.6;
  // Curvature: radius is random with |R| >= min_radius_m; straight with
  // probability straight_probability.
  double min_radius_m = 150.0;
  double straight_probability = 0.4;
  // The road's heading relative to the camera's ground axis is uniform in
  // +-max_heading_rad (the car is never perfectly aligned with its lane).
  double max_heading_rad = 0.02;
  // Markings.
  double min_marking_width_m = 0.10;
  double max_marking_width_m = 0.15;
  double dashed_probability = 0.5;
  double yellow_probability = 0.25;
  // Clutter and degradations.
  int max_vehicles = 2;
  int max_shadows = 3;
  double noise_sigma = 4.0;  // grey levels
  int jpeg_quality = 80;     // 0 = no JPEG round trip
  // Roadside clutter that competes with the markings (calibration tests).
  // All 0 by default: the frame is then exactly as without these options.
  int extra_roadside_objects = 0;    // trees, buildings and poles beyond the usual 3-16
  double tree_row_probability = 0;   // a row of trees (white trunks half the time) along a verge
  double sign_probability = 0;       // a sign on two posts beside the road
  double guardrail_probability = 0;  // a guardrail along one road edge
  double worn_probability = 0;       // per boundary: the paint worn to 0-30 %, or gone
  // Per inner boundary (not the outermost two): a solid double line, two
  // lines of the boundary's width 0.10-0.20 m apart. Its truth runs along
  // its centre (docs/evaluation.md, "Double lines"). 0 by default: the
  // frame is then exactly as without it.
  double double_line_probability = 0;
  // Per inner boundary: raised pavement markers (Botts' dots) instead of
  // paint, as measured on issue 49's US highway frames: round, 0.09 m
  // across, grey 240-252, in groups of 4 dots 0.85-1.05 m apart, a group
  // every 12-13 m (about 14 times less marking per metre than dashes). Its
  // truth runs through the dots; its label's type is `dots`. 0 by default:
  // the frame is then exactly as without it.
  double botts_dots_probability = 0;
  // A concrete road, as under those dots: grey 140-160 (asphalt: 80-120),
  // little texture, darker tyre-polish stripes in every lane, dark slab
  // seams across the road every 4.5-6 m and along it 0.1-0.3 m beside each
  // boundary. Off by default: the frame is then exactly as without it.
  bool concrete = false;
  // Structure fixed to the camera: a card on the dashboard reflected in the
  // windscreen, a dark blue card with a row of bright digits seen in
  // perspective (its strokes meet about four card heights above it), at
  // the same image position in every frame: right of the centre, from 64 %
  // to 73 % of the image height. It is not labelled (it is not road), and
  // it would vote for its own vanishing point in every frame
  // (docs/calibration.md, "Static structure"). Off by default: the frame is
  // then exactly as without it.
  bool static_overlay = false;
  // Night, as measured on a CULane night clip (issue 49): the road lit by
  // the car's low beams (on the axis grey 150-160 at 12-15 m, 124 at 20 m,
  // 82 at 30, 52 at 40, 38 at 60 m; a pool about 1.6 m wide (sigma) at
  // 12 m, widening with the distance), unlit road 17 and markings +14
  // beside it, street lamps' pools (markings +28 to +33 under them),
  // markings' contrast falling to +14 beyond 50 m, 4-19 saturated blobs of
  // glare above the horizon (neon signs, up to 2,200 px at 1640x590),
  // oncoming headlights, and the sensor's noise 2.5 times up at mid grey.
  bool night = false;
  // Dashed markings' painted length and gap, metres (uniform in the
  // ranges; US MUTCD: 3 m + 9 m).
  double min_dash_m = 2.5, max_dash_m = 3.5;
  double min_gap_m = 6.0, max_gap_m = 9.0;
  // Ground truth covers the boundary from this far ahead (metres) ...
  double truth_near_m = 0.0;  // 0 = the bottom of the image
  // ... to this far ahead (metres).
  double truth_far_m = 40.0;
  // The car's hood, the renderer's only one: a dark, smooth, glossy region
  // (a static reflection of the sky, the same in every frame) below a
  // parabola through row `hood_top_row` at the principal point's column and
  // `hood_side_row` at the image's left and right edges (0: the image's
  // bottom). Rows, because rows are what one measures on a frame; a hood
  // known by the ground distance of its edge (CULane's cameras: "the road
  // nearer than 6 m") converts once through HoodRowsAtDistance. At night it
  // is lit by the sky's light only (Night::sky): black, as on CULane's night
  // clips. 0 = no hood. 0 by default: the frame is then exactly as without it.
  double hood_top_row = 0;
  double hood_side_row = 0;
  // Labels stop where the hood hides the road, as a fleet's labels would;
  // true: they run on to the image's bottom under the hood (CULane's
  // convention).
  bool labels_through_hood = false;
  // Dashed boundaries: > 0 places the dash pattern so that its first dash
  // ahead begins this far ahead (metres) and nothing is painted nearer
  // (a dashed line whose nearest dash lies beyond the hood). 0 = a random
  // phase.
  double first_dash_m = 0;
};

// The first image row of the hood in column u (HUGE_VAL without a hood).
// FitTruth (where labels stop), the hood's paint and the night's lighting
// all read the hood through this function.
double HoodRow(const CameraModel& camera, const SyntheticOptions& options, double u);

// A hood given by where its edge meets the road, converted to
// SyntheticOptions' rows for one camera.
struct HoodRows {
  double top_row = 0;   // SyntheticOptions::hood_top_row
  double side_row = 0;  // SyntheticOptions::hood_side_row
};
// The hood that covers the road nearer than `edge_m` metres ahead (`lane
// render --hood M`): its top row is the image row of the ground point
// `edge_m` straight ahead, its sides a twentieth of the image's height
// lower (a hood's arc). InvalidArgument unless 0 < edge_m <= 100 and that
// point lies below the horizon. The labels' convention is the caller's
// (CULane's run on through the hood: labels_through_hood).
absl::StatusOr<HoodRows> HoodRowsAtDistance(const CameraModel& camera, double edge_m);

// The clutter of `lane render --clutter` and the calibration clutter test:
// 10 extra roadside objects, a tree row in 60 % of the frames, a sign and a
// guardrail in 40 % each, up to 3 vehicles ahead, a quarter of the
// boundaries worn or gone.
void SetRoadsideClutter(SyntheticOptions* options);

// One painted boundary of the rendered road.
struct SyntheticBoundary {
  std::array<Eigen::Vector2d, 4> image;  // Bezier control points, image pixels
  bool dashed = false;
  bool yellow = false;
  bool double_line = false;     // two lines; `image` runs along their centre
  bool dots = false;            // Botts' dots (SyntheticOptions::botts_dots_probability)
  double lateral_offset_m = 0;  // at y = 0, metres (right +)
  // The boundary's index on the road, from the left: in a drive, the same
  // painted line keeps its id in every frame.
  int id = -1;
  // A drive: the pattern changes between dashed and solid within the view,
  // or passed under the camera less than SyntheticDriveOptions::
  // type_settle_s ago (`dashed` is the pattern nearest the camera).
  bool type_changes = false;
};

// The true ego lane of a drive's frame (EgoLane's definitions).
struct SyntheticEgo {
  int lane = -1;        // the lane the camera is in, from the left (0-based)
  double offset_m = 0;  // camera from the lane centre, right +
  double width_m = 0;
  double heading_deg = 0;      // lane direction from the optical axis on the ground, right +
  double curvature_per_m = 0;  // right +
  double offset_rate_mps = 0;  // lateral speed of the camera in the lane, right +
};

struct SyntheticFrame {
  cv::Mat bgr;  // CV_8UC3 of the camera's size
  std::vector<SyntheticBoundary> boundaries;
  int ego_left = -1;   // index of the ego lane's left boundary, or -1
  int ego_right = -1;  // index of the ego lane's right boundary, or -1
  // The asphalt's edges in view (unpainted boundaries, which the detector
  // may report as road edges): Bezier control points, image pixels.
  std::vector<std::array<Eigen::Vector2d, 4>> road_edges;
  // A drive's frame only.
  double time_s = 0;
  std::optional<SyntheticEgo> ego;
};

// Deterministic for a given camera, options and seed.
absl::StatusOr<SyntheticFrame> RenderSyntheticFrame(const CameraModel& camera,
                                                    const SyntheticOptions& options, uint64_t seed);

// One continuous drive through the camera (`lane render --sequence`): the
// car drives at a steady speed on a road of `num_lanes` lanes, weaving a
// little in its lane, through a right bend and a left bend, with one lane
// change to the right; vehicles occlude the markings for stretches (one
// overtaking on the left, one closing in ahead); a dashed line turns solid;
// the light changes (a darker stretch, tree shadows across the road). The
// leftmost boundary is a solid yellow line, the rightmost a solid white
// edge line, the others dashed white. Every event is placed at a fraction
// of the drive, so any count holds them all. Frame i is at time i / fps.
struct SyntheticDriveOptions {
  int count = 300;
  double fps = 30.0;
  double speed_mps = 15.0;
  int num_lanes = 3;  // >= 3: the car starts in lane 1 and changes to lane 2
  double lane_width_m = 3.6;
  double lane_change_s = 4.0;  // duration of the lane change (at most 0.4 of the drive)
  // `type_changes` stays set this long after a pattern change passed under
  // the camera (the time a tracker's votes take to follow).
  double type_settle_s = 1.5;
  // Markings' widths, noise, JPEG and the truth range; the frame's random
  // road, vehicles and shadows are replaced by the drive's.
  SyntheticOptions frame;

  absl::Status Validate() const;
};

// Frame `index` (0 .. count - 1) of the drive given by the options and the
// seed; deterministic, and independent of the other frames.
absl::StatusOr<SyntheticFrame> RenderSyntheticDriveFrame(const CameraModel& camera,
                                                         const SyntheticDriveOptions& options,
                                                         uint64_t seed, int index);

}  // namespace lane

#endif  // LANE_SYNTHETIC_H_
