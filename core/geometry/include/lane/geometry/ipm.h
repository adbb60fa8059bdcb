// Inverse perspective mapping: a top view of a region of the road.
//
// The mapping is computed once per calibration (IpmMapping::Create) and then
// applied to every frame with a single cv::remap.
#ifndef LANE_IPM_H_
#define LANE_IPM_H_

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "lane/geometry/camera.h"

namespace lane {

// A rectangle in image pixels. right and bottom are inclusive coordinates.
struct Roi {
  double left = 100;
  double right = 460;
  double top = 220;
  double bottom = 350;
};

// kNearest and kBilinear read one point per top-view pixel. kArea averages
// the image over the pixel's footprint wherever that footprint spans more
// than one image pixel (anti-aliasing: otherwise a top view coarser than the
// image picks single pixels, and thin markings and asphalt texture alias),
// and is bilinear elsewhere.
enum class Interpolation { kNearest, kBilinear, kArea };

// How the top view is defined: by a rectangle of the image (the paper's and
// the reference code's form; the ground extent is the ROI's footprint and
// the resolution follows from width x height), or by a rectangle of the road
// in metres and a resolution in metres per pixel (the image ROI is then
// derived: the bounding box of the rectangle's projection).
enum class IpmView { kRoi, kGround };

// A rectangle of the road plane and the top view's resolution. Ground frame:
// x lateral (metres, positive to the right), y ahead of the camera's foot
// point (metres).
struct GroundView {
  // Lateral range. The default, +-7.5 m, holds the ego lane's boundaries
  // and the next boundary on each side (CULane labels at most these four)
  // for lanes up to 3.75 m wide with the car up to 1.9 m off the centre.
  double x_min_m = -7.5;
  double x_max_m = 7.5;
  // Distance range ahead. Near limit: where the car's own hood or the image
  // bottom ends the road (8 m for the CULane camera); far limit: short of
  // the vehicles ahead in dense traffic, whose edges and shadows otherwise
  // dominate the threshold (a 1-1.5 s gap at 30-50 km/h is 8-20 m), and deep
  // enough for a dash and a gap. docs/config.md, "Choosing a ground view".
  double y_min_m = 8.0;
  double y_max_m = 18.0;
  // Ground size of one top-view pixel across and along the road, metres.
  // Across: a 15 cm marking should span >= 2 px (<= 0.075 m). Along: the
  // filter smooths over 1 m along the road, so 0.125 m (8 px per sigma)
  // loses nothing.
  double metres_per_px_x = 0.0625;
  double metres_per_px_y = 0.125;
};

// At most this many rectangles in IpmOptions::static_mask.
inline constexpr int kMaxStaticMaskBoxes = 64;

struct IpmOptions {
  // kRoi: `roi`, `width` and `height` define the view. kGround: `ground`
  // does, and `roi`, `width` and `height` are ignored (derived). A config
  // file with a "ground" section and no "view" key selects kGround.
  IpmView view = IpmView::kRoi;
  // Size of the top view in pixels. 160x120 as in the paper: small enough for
  // real time, large enough for a 10 cm marking to cover ~1 pixel.
  int width = 160;
  int height = 120;
  // Region of the image that is mapped. It is clipped to the image and to
  // `horizon_margin_px` below the horizon.
  Roi roi;
  GroundView ground;
  // How far below the horizon the ROI must start, pixels. Rows nearer the
  // horizon map to ground points that are absurdly far away.
  double horizon_margin_px = 10.0;
  Interpolation interpolation = Interpolation::kBilinear;
  // Image rectangles the top view does not read: structure fixed to the
  // camera that is not road (a reflection in the windscreen, a sticker, a
  // timestamp overlay), as `lane calibrate` learns it from a drive
  // (docs/calibration.md, "Static structure"). A top-view pixel whose image
  // point lies in one is invalid, like one outside the ROI: it reads the
  // mean, and the filter's response there is zero. Applied when the mapping
  // is built, so it costs nothing per frame. Empty by default; at most
  // kMaxStaticMaskBoxes.
  std::vector<Roi> static_mask;

  absl::Status Validate() const;
  // True when `image` (pixels) lies in a rectangle of static_mask.
  bool Masked(const Eigen::Vector2d& image) const;
};

// The precomputed mapping between a camera's image and its top view.
// IPM pixel (col, row): row 0 is the farthest row, column 0 the leftmost.
class IpmMapping {
 public:
  // INVALID_ARGUMENT for a bad camera, bad options, or an ROI that has no
  // part inside the image and below the horizon.
  static absl::StatusOr<IpmMapping> Create(const CameraModel& camera, const IpmOptions& options);

  // Top view of channel `channel` of an 8-bit image (1 or 3 channels) of the
  // camera's size, as CV_32F with values in [0, 1]. Only the top view's
  // pixels are read, so no full-frame channel copy is made. Pixels whose
  // source falls outside the ROI are set to the mean of the others (as in the
  // reference implementation).
  // With `channel2` >= 0 the top view is of min(channel, channel2) per pixel;
  // with kGrayOfBgr (lane/geometry/channel_view.h) of the grey of a BGR image.
  cv::Mat Apply(const cv::Mat& image, int channel = 0, int channel2 = -1) const;

  // Conversions between IPM pixels, image pixels and ground metres.
  Eigen::Vector2d IpmToGround(const Eigen::Vector2d& ipm) const;
  Eigen::Vector2d GroundToIpm(const Eigen::Vector2d& ground) const;
  Eigen::Vector2d IpmToImage(const Eigen::Vector2d& ipm) const;
  Eigen::Vector2d ImageToIpm(const Eigen::Vector2d& image) const;

  // Size of the top view (for kGround, derived from the ground rectangle).
  // Ground size of one IPM pixel, metres: across the road (x) and along it (y).
  double metres_per_px_x() const { return mpp_x_; }
  double metres_per_px_y() const { return mpp_y_; }
  // Ground extent of the top view, metres.
  double x_min() const { return x_min_; }
  double x_max() const { return x_max_; }
  double y_min() const { return y_min_; }
  double y_max() const { return y_max_; }
  // The ROI after clipping to the image and the horizon.
  const Roi& roi() const { return roi_; }
  const CameraModel& camera() const { return camera_; }
  const IpmOptions& options() const { return options_; }
  int width() const { return width_; }
  int height() const { return height_; }
  // Image->top-view taps per top-view pixel, on average (4 for bilinear; more
  // where kArea averages a footprint). For the benchmark and tests.
  double mean_taps() const;
  // CV_8U, 255 where the IPM pixel's source lies inside the ROI.
  const cv::Mat& valid_mask() const { return valid_; }
  // Its complement.
  const cv::Mat& invalid_mask() const { return invalid_; }
  // The same as indices of a continuous top-view image (row * width + col):
  // filling them costs less than a masked setTo.
  const std::vector<int32_t>& invalid_pixels() const { return invalid_pixels_; }

  // The image rows the top view reads, first to last (inclusive).
  std::pair<int, int> ImageRows() const;

  // Bytes held by the precomputed mapping (grows with the top view's size).
  size_t MemoryBytes() const;

 private:
  IpmMapping() = default;
  // Create's two kinds of top view: a rectangle on the ground (its image
  // ROI derived), or an image ROI (its ground footprint derived).
  absl::Status PlaceGroundView();
  absl::Status PlaceImageRoi();
  void BuildTaps();
  void BuildSegments();
  cv::Mat ApplySegments(const cv::Mat& image, int channel, int channel2) const;
  // The detector's channel of `rect` of `image` as a CV_8UC1 image: a view
  // when `image` has one channel, else converted into `scratch`.
  static cv::Mat ChannelBand(const cv::Mat& image, const cv::Rect& rect, int channel, int channel2,
                             cv::Mat& scratch, cv::Mat& scratch2);

  CameraModel camera_;
  IpmOptions options_;
  Roi roi_;
  int width_ = 0, height_ = 0;
  double x_min_ = 0, x_max_ = 0, y_min_ = 0, y_max_ = 0;
  double mpp_x_ = 0, mpp_y_ = 0;
  // Per valid IPM pixel (`pixel`, its row-major index), the 2x2 image pixels
  // it reads and their weights (bilinear: the 4 neighbours; nearest: one of
  // them with weight 1; area: only validity, see below). (row, col) is the
  // top-left of the 2x2 in the band of the image that the quads read (rows
  // tap_row0_.., columns tap_col0_..): Apply reads it in place for one
  // channel of a colour frame, else from the band's channel, converted
  // first. The ROI lies inside the image and is at least 2 pixels each way,
  // so every 2x2 does too. Frames are at most 16384 px each way.
  struct Quad {
    int32_t pixel;
    int16_t row, col;
    float w[4];  // (x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)
  };
  std::vector<Quad> quads_;
  int tap_row0_ = 0, tap_rows_ = 0, tap_col0_ = 0, tap_cols_ = 0;
  // kArea: per IPM pixel, sub-rows seg_start_[i] .. seg_start_[i + 1] - 1.
  // A sub-row of the footprint is a box along the image between columns u0
  // and u1, at an image position between two rows: the box's average on the
  // upper row (weight w0) plus that on the lower row (w1), each read from
  // the row's prefix sums at Apply. Everything but the prefix sums is
  // precomputed: `off0` is the upper row's index into the prefix band
  // ((row - seg_row0_) * seg_cols_) plus the prefix column k0 of u0, `len`
  // the columns from k0 to u1's k1, f0 and f1 the fractions of u0 and u1
  // beyond them, and w0 and w1 already divide by the box's width and the
  // footprint's total weight. Rows seg_row0_ .. seg_row1_ and columns up to
  // seg_cols_ - 1 are read.
  struct SubRow {
    int32_t off0;
    int32_t len;
    float f0, f1;
    float w0, w1;
  };
  std::vector<int32_t> seg_start_;
  std::vector<int32_t> seg_empty_;  // the pixels without sub-rows
  std::vector<SubRow> segments_;
  int seg_row0_ = 0, seg_row1_ = -1, seg_cols_ = 0;
  cv::Mat valid_;
  cv::Mat invalid_;
  std::vector<int32_t> invalid_pixels_;
  int valid_count_ = 0;
};

}  // namespace lane

#endif  // LANE_IPM_H_
