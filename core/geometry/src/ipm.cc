#include "lane/geometry/ipm.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "ipm_internal.h"

namespace lane {

namespace {

// The bilinear taps of image point `p` (inside the image), scaled by `w`.
template <class Add>
void BilinearTaps(const Eigen::Vector2d& p, int image_width, int image_height, float w, Add add) {
  const int x0 = std::clamp(static_cast<int>(p.x()), 0, std::max(0, image_width - 2));
  const int y0 = std::clamp(static_cast<int>(p.y()), 0, std::max(0, image_height - 2));
  const float fx = static_cast<float>(std::clamp(p.x() - x0, 0.0, 1.0));
  const float fy = static_cast<float>(std::clamp(p.y() - y0, 0.0, 1.0));
  add(x0, y0, w * (1 - fx) * (1 - fy));
  add(x0 + 1, y0, w * fx * (1 - fy));
  add(x0, y0 + 1, w * (1 - fx) * fy);
  add(x0 + 1, y0 + 1, w * fx * fy);
}

// At most this many sub-samples per axis of one top-view pixel in area
// sampling: beyond, the average is good enough and the taps only cost time.
constexpr int kMaxSubsamples = 12;

}  // namespace

absl::StatusOr<IpmMapping> IpmMapping::Create(const CameraModel& camera,
                                              const IpmOptions& options) {
  if (auto s = camera.Validate(); !s.ok()) return s;
  if (auto s = options.Validate(); !s.ok()) return s;
  IpmMapping m;
  m.camera_ = camera;
  m.options_ = options;
  const absl::Status placed =
      options.view == IpmView::kGround ? m.PlaceGroundView() : m.PlaceImageRoi();
  if (!placed.ok()) return placed;
  m.BuildTaps();
  if (m.valid_count_ == 0) return absl::InvalidArgumentError("ipm maps to no image pixel");
  return m;
}

absl::Status IpmMapping::PlaceGroundView() {
  const CameraModel& camera = camera_;
  const IpmOptions& options = options_;
  const double horizon = camera.HorizonRow();
  const double top_limit = horizon + options.horizon_margin_px;
  // The ground rectangle as given; the ROI is the bounding box of its
  // projection, clipped to the image and to below the horizon.
  const GroundView& g = options.ground;
  width_ = ipm_internal::GroundPixels(g.x_max_m - g.x_min_m, g.metres_per_px_x);
  height_ = ipm_internal::GroundPixels(g.y_max_m - g.y_min_m, g.metres_per_px_y);
  x_min_ = g.x_min_m;
  x_max_ = g.x_max_m;
  y_min_ = g.y_min_m;
  y_max_ = g.y_max_m;
  mpp_x_ = (x_max_ - x_min_) / width_;
  mpp_y_ = (y_max_ - y_min_) / height_;
  Roi box{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
          std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  for (const double x : {g.x_min_m, g.x_max_m}) {
    for (const double y : {g.y_min_m, g.y_max_m}) {
      const Eigen::Vector2d p = camera.GroundToImage({x, y});
      if (!p.allFinite() || !(p.y() > horizon)) {
        return absl::InvalidArgumentError(
            absl::StrCat("ipm.ground corner (", x, ", ", y,
                         ") m does not project below the horizon: is the camera's pitch right?"));
      }
      box.left = std::min(box.left, p.x());
      box.right = std::max(box.right, p.x());
      box.top = std::min(box.top, p.y());
      box.bottom = std::max(box.bottom, p.y());
    }
  }
  Roi roi;
  roi.left = std::max(box.left, 0.0);
  roi.right = std::min(box.right, camera.image_width - 1.0);
  roi.top = std::max(box.top, std::max(0.0, top_limit));
  roi.bottom = std::min(box.bottom, camera.image_height - 1.0);
  if (roi.right - roi.left < 2 || roi.bottom - roi.top < 2) {
    return absl::InvalidArgumentError(absl::StrCat(
        "ipm.ground (x ", g.x_min_m, "..", g.x_max_m, " m, y ", g.y_min_m, "..", g.y_max_m,
        " m) projects to image rows ", box.top, "..", box.bottom, ", columns ", box.left, "..",
        box.right, ": no usable part inside the ", camera.image_width, "x", camera.image_height,
        " image below the horizon (row ", horizon, " + margin ", options.horizon_margin_px, ")"));
  }
  roi_ = roi;
  return absl::OkStatus();
}

absl::Status IpmMapping::PlaceImageRoi() {
  const CameraModel& camera = camera_;
  const IpmOptions& options = options_;
  const double horizon = camera.HorizonRow();
  const double top_limit = horizon + options.horizon_margin_px;
  // Clip the ROI to the image and to below the horizon.
  Roi roi = options.roi;
  roi.left = std::max(roi.left, 0.0);
  roi.right = std::min(roi.right, camera.image_width - 1.0);
  roi.bottom = std::min(roi.bottom, camera.image_height - 1.0);
  roi.top = std::max(roi.top, top_limit);
  if (roi.right - roi.left < 2 || roi.bottom - roi.top < 2) {
    return absl::InvalidArgumentError(absl::StrCat(
        "ipm.roi (left=", options.roi.left, " right=", options.roi.right, " top=", options.roi.top,
        " bottom=", options.roi.bottom, ") has no usable part inside the ", camera.image_width, "x",
        camera.image_height, " image below the horizon (row ", horizon, " + margin ",
        options.horizon_margin_px, ")"));
  }
  roi_ = roi;
  width_ = options.width;
  height_ = options.height;

  // Ground footprint of the ROI: its corners and the vanishing point's column
  // on its top and bottom rows.
  const double vp_u = std::clamp(camera.VanishingPoint().x(), roi.left, roi.right);
  const Eigen::Vector2d corners[] = {{roi.left, roi.top},     {roi.right, roi.top},
                                     {vp_u, roi.top},         {roi.left, roi.bottom},
                                     {roi.right, roi.bottom}, {vp_u, roi.bottom}};
  x_min_ = y_min_ = std::numeric_limits<double>::infinity();
  x_max_ = y_max_ = -std::numeric_limits<double>::infinity();
  for (const auto& c : corners) {
    const Eigen::Vector2d g = camera.ImageToGround(c);
    if (!g.allFinite() || g.y() <= 0) {
      return absl::InvalidArgumentError("ipm.roi maps to points behind the camera");
    }
    x_min_ = std::min(x_min_, g.x());
    x_max_ = std::max(x_max_, g.x());
    y_min_ = std::min(y_min_, g.y());
    y_max_ = std::max(y_max_, g.y());
  }
  mpp_x_ = (x_max_ - x_min_) / width_;
  mpp_y_ = (y_max_ - y_min_) / height_;
  if (!(mpp_x_ > 0) || !(mpp_y_ > 0)) {
    return absl::InvalidArgumentError("ipm.roi has an empty ground footprint");
  }
  return absl::OkStatus();
}

void IpmMapping::BuildTaps() {
  // The per-pixel quads, computed once per calibration.
  const int n = width_ * height_;
  const Roi& roi = roi_;
  const int iw = camera_.image_width;
  const int ih = camera_.image_height;
  const auto inside = [this, &roi](const Eigen::Vector2d& img) {
    return img.allFinite() && img.x() >= roi.left && img.x() <= roi.right && img.y() >= roi.top &&
           img.y() <= roi.bottom && !options_.Masked(img);
  };
  struct XyQuad {
    int x = -1, y = -1;  // top-left image pixel; x < 0: invalid
    float w[4] = {0, 0, 0, 0};
  };
  std::vector<XyQuad> xy(n);
  valid_ = cv::Mat::zeros(height_, width_, CV_8U);
  valid_count_ = 0;
  int x0 = iw, x1 = -1, y0 = ih, y1 = -1;  // the band: every quad's 2x2
  for (int r = 0; r < height_; ++r) {
    for (int c = 0; c < width_; ++c) {
      const Eigen::Vector2d img = IpmToImage(Eigen::Vector2d(c, r));
      if (!inside(img)) continue;
      XyQuad& q = xy[r * width_ + c];
      if (options_.interpolation == Interpolation::kNearest) {
        const int x = std::clamp(static_cast<int>(std::lround(img.x())), 0, iw - 1);
        const int y = std::clamp(static_cast<int>(std::lround(img.y())), 0, ih - 1);
        q.x = std::min(x, std::max(0, iw - 2));
        q.y = std::min(y, std::max(0, ih - 2));
        q.w[(x - q.x) + 2 * (y - q.y)] = 1.f;
      } else {  // bilinear; area uses the quads for validity (BuildSegments samples)
        BilinearTaps(img, iw, ih, 1.f, [&q](int x, int y, float w) {
          if (q.x < 0) {
            q.x = x;
            q.y = y;
          }
          q.w[(x - q.x) + 2 * (y - q.y)] = std::max(0.f, w);
        });
      }
      if (!(q.w[0] > 0 || q.w[1] > 0 || q.w[2] > 0 || q.w[3] > 0)) {
        q.x = -1;
        continue;
      }
      valid_.at<uint8_t>(r, c) = 255;
      ++valid_count_;
      x0 = std::min(x0, q.x);
      y0 = std::min(y0, q.y);
      x1 = std::max(x1, q.x + 1);
      y1 = std::max(y1, q.y + 1);
    }
  }
  const bool any = valid_count_ > 0;
  tap_row0_ = any ? y0 : 0;
  tap_rows_ = any ? y1 - y0 + 1 : 0;
  tap_col0_ = any ? x0 : 0;
  tap_cols_ = any ? x1 - x0 + 1 : 0;
  quads_.clear();
  quads_.reserve(valid_count_);
  for (int i = 0; i < n; ++i) {
    const XyQuad& q = xy[i];
    if (q.x < 0) continue;
    quads_.push_back({i,
                      static_cast<int16_t>(q.y - tap_row0_),
                      static_cast<int16_t>(q.x - tap_col0_),
                      {q.w[0], q.w[1], q.w[2], q.w[3]}});
  }
  cv::bitwise_not(valid_, invalid_);
  invalid_pixels_.clear();
  for (int i = 0; i < n; ++i) {
    if (invalid_.data[i] != 0) invalid_pixels_.push_back(i);  // valid_ is continuous
  }
  invalid_pixels_.shrink_to_fit();
  if (options_.interpolation == Interpolation::kArea) {
    BuildSegments();
    // Area sampling reads the sub-rows alone: the quads only marked validity
    // (valid_), and a session need not hold them (0.44 MiB for the CULane
    // view).
    quads_.clear();
    quads_.shrink_to_fit();
  }
}

// Longer than 80 lines on purpose: one pass over the top view's pixels that
// keeps four running bounds (seg_row0_, seg_row1_, col1, each footprint's
// total weight) beside the boxes it emits; split, each part would take and
// return all of them.
void IpmMapping::BuildSegments() {
  // The footprint of IPM pixel (c, r) is the image of the ground cell
  // [c - 0.5, c + 0.5] x [r - 0.5, r + 0.5]. Lines of constant ground y are
  // (nearly) horizontal in the image (the camera does not roll), so the
  // footprint is cut into `nv` sub-rows of constant y, each a horizontal
  // segment of the image between the images of its left and right corners:
  // a box along the image row, and linear interpolation between the two
  // image rows around it. nv follows the footprint's height in image rows,
  // so every image row of the footprint is read.
  struct Box {
    int row;       // the upper image row
    float u0, u1;  // prefix coordinates of the box
    float w0, w1;  // weights of the upper and the lower row
  };
  const int n = width_ * height_;
  const int iw = camera_.image_width;
  const int ih = camera_.image_height;
  std::vector<Box> boxes;
  boxes.reserve(2 * n);
  seg_start_.assign(n + 1, 0);
  seg_row0_ = ih;
  seg_row1_ = -1;
  int col1 = 0;
  for (int r = 0; r < height_; ++r) {
    for (int c = 0; c < width_; ++c) {
      const int i = r * width_ + c;
      seg_start_[i] = static_cast<int32_t>(boxes.size());
      if (valid_.at<uint8_t>(r, c) == 0) continue;  // invalid
      const double v_top = IpmToImage({c, r - 0.5}).y(), v_bot = IpmToImage({c, r + 0.5}).y();
      const int nv =
          std::clamp(static_cast<int>(std::ceil(std::abs(v_bot - v_top))), 1, kMaxSubsamples);
      const size_t first = boxes.size();
      double total = 0;
      for (int b = 0; b < nv; ++b) {
        const double t = r - 0.5 + (b + 0.5) / nv;
        Eigen::Vector2d a = IpmToImage({c - 0.5, t}), z = IpmToImage({c + 0.5, t});
        if (!a.allFinite() || !z.allFinite()) continue;
        if (a.x() > z.x()) std::swap(a, z);
        const double v = 0.5 * (a.y() + z.y());
        // Clipped to the image; a segment narrower than a pixel is widened
        // around its centre to one pixel (then it reads like bilinear).
        double u0 = std::max(0.0, a.x()), u1 = std::min(iw - 1.0, z.x());
        if (u1 - u0 < 1.0) {
          const double m = std::clamp(0.5 * (u0 + u1), 0.5, iw - 1.5);
          u0 = m - 0.5;
          u1 = m + 0.5;
        }
        if (!(v >= 0 && v <= ih - 1)) continue;
        const int v0 = std::min(static_cast<int>(v), ih - 2);
        const double fv = v - v0;
        // Pixel k covers [k - 0.5, k + 0.5]: the box [u0, u1] in prefix
        // coordinates is [u0 + 0.5, u1 + 0.5]. Weights as floats, as they
        // are applied.
        Box box{v0, static_cast<float>(u0 + 0.5), static_cast<float>(u1 + 0.5),
                static_cast<float>(1 - fv), static_cast<float>(fv)};
        if (1 - fv > 0) total += 1 - fv;
        if (fv > 0) total += fv;
        seg_row0_ = std::min(seg_row0_, v0);
        seg_row1_ = std::max(seg_row1_, v0 + 1);
        col1 = std::max(col1, static_cast<int>(std::ceil(u1 + 0.5)) + 1);
        boxes.push_back(box);
      }
      for (size_t k = first; k < boxes.size(); ++k) {
        Box& bx = boxes[k];
        const double width = bx.u1 - bx.u0;
        bx.w0 = bx.w0 > 0 ? static_cast<float>(bx.w0 / total / width) : 0.f;
        bx.w1 = bx.w1 > 0 ? static_cast<float>(bx.w1 / total / width) : 0.f;
      }
    }
  }
  seg_start_[n] = static_cast<int32_t>(boxes.size());
  seg_cols_ = std::min(col1, iw) + 1;
  // The prefix lookups, resolved: column k of a prefix coordinate u and the
  // fraction beyond it, as Apply's interpolation reads them.
  const auto column = [this](float u) { return std::min(static_cast<int>(u), seg_cols_ - 2); };
  segments_.clear();
  segments_.reserve(boxes.size());
  for (const Box& bx : boxes) {
    const int k0 = column(bx.u0), k1 = column(bx.u1);
    segments_.push_back(
        {(bx.row - seg_row0_) * seg_cols_ + k0, k1 - k0, bx.u0 - k0, bx.u1 - k1, bx.w0, bx.w1});
  }
  seg_empty_.clear();
  for (int i = 0; i < n; ++i) {
    if (seg_start_[i] == seg_start_[i + 1]) seg_empty_.push_back(i);
  }
  seg_empty_.shrink_to_fit();
}

Eigen::Vector2d IpmMapping::IpmToGround(const Eigen::Vector2d& ipm) const {
  return {x_min_ + (ipm.x() + 0.5) * mpp_x_, y_max_ - (ipm.y() + 0.5) * mpp_y_};
}

Eigen::Vector2d IpmMapping::GroundToIpm(const Eigen::Vector2d& ground) const {
  return {(ground.x() - x_min_) / mpp_x_ - 0.5, (y_max_ - ground.y()) / mpp_y_ - 0.5};
}

Eigen::Vector2d IpmMapping::IpmToImage(const Eigen::Vector2d& ipm) const {
  return camera_.GroundToImage(IpmToGround(ipm));
}

Eigen::Vector2d IpmMapping::ImageToIpm(const Eigen::Vector2d& image) const {
  return GroundToIpm(camera_.ImageToGround(image));
}

std::pair<int, int> IpmMapping::ImageRows() const {
  if (options_.interpolation == Interpolation::kArea) return {seg_row0_, seg_row1_};
  return {tap_row0_, tap_row0_ + tap_rows_ - 1};
}

size_t IpmMapping::MemoryBytes() const {
  return quads_.capacity() * sizeof(Quad) + seg_start_.capacity() * sizeof(seg_start_[0]) +
         seg_empty_.capacity() * sizeof(seg_empty_[0]) + segments_.capacity() * sizeof(SubRow) +
         valid_.total() * valid_.elemSize() + invalid_.total() * invalid_.elemSize() +
         invalid_pixels_.capacity() * sizeof(invalid_pixels_[0]);
}

}  // namespace lane
