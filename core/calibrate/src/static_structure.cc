#include "lane/calibrate/static_structure.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"

namespace lane {

absl::Status StaticStructureOptions::Validate() const {
  const double shares[] = {min_presence, min_coherence, min_static_share};
  for (double s : shares) {
    if (!(s > 0 && s <= 1)) {
      return absl::InvalidArgumentError(
          "static structure: min_presence, min_coherence and min_static_share must lie in (0, 1]");
    }
  }
  if (!(min_contrast > 0) || !(detail_sigma_px >= 0.5 && detail_sigma_px <= 50) ||
      !(noise_levels > 0) || !(margin_px >= 0 && margin_px <= 50)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "static structure: min_contrast and noise_levels must be > 0, detail_sigma_px in "
        "[0.5, 50] and margin_px in [0, 50], got ",
        min_contrast, ", ", noise_levels, ", ", detail_sigma_px, ", ", margin_px));
  }
  if (min_frames < 2 || box_margin_px < 0 || max_boxes < 0 || max_boxes > kMaxStaticMaskBoxes ||
      min_box_area < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("static structure: min_frames must be >= 2, box_margin_px >= 0, "
                     "min_box_area >= 1 and max_boxes in [0, ",
                     kMaxStaticMaskBoxes, "]"));
  }
  return absl::OkStatus();
}

void StaticStructureFinder::Add(const cv::Mat& paint) {
  if (!options_.enabled) return;
  CV_Assert(paint.type() == CV_8UC1);
  if (frames_ == 0 || paint.size() != presence_.size()) {
    presence_ = cv::Mat::zeros(paint.size(), CV_32F);
    detail_sum_ = cv::Mat::zeros(paint.size(), CV_32F);
    detail_sum_squares_ = cv::Mat::zeros(paint.size(), CV_32F);
    frames_ = 0;
  }
  ++frames_;
  MarkingSegmentOptions bars;
  bars.fixed_widths_px = FixedBarWidths(paint.cols);
  const cv::Mat response = MarkingResponse(paint, bars);
  cv::add(presence_, cv::Scalar(1.0), presence_, response >= options_.min_contrast);
  cv::Mat detail, blur;
  paint.convertTo(detail, CV_32F);
  cv::GaussianBlur(detail, blur, cv::Size(0, 0), options_.detail_sigma_px);
  detail -= blur;
  detail_sum_ += detail;
  cv::accumulateSquare(detail, detail_sum_squares_);
}

StaticStructure StaticStructureFinder::Finish() const {
  StaticStructure out;
  out.frames = frames_;
  out.min_static_share = options_.min_static_share;
  if (!options_.enabled || frames_ < options_.min_frames) return out;
  const double n = frames_;
  const cv::Mat mean = detail_sum_ / n;
  const double noise = options_.noise_levels * options_.noise_levels;
  const cv::Mat coherence = mean.mul(mean) / (detail_sum_squares_ / n + noise);
  const cv::Mat fixed =
      (presence_ >= options_.min_presence * n) & (coherence >= options_.min_coherence);

  // The pieces, merged over box_margin_px, as rectangles.
  const int grow = options_.box_margin_px;
  cv::Mat merged = fixed;
  if (grow > 0) {
    cv::dilate(fixed, merged,
               cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * grow + 1, 2 * grow + 1)));
  }
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(merged, labels, stats, centroids, 8, CV_32S);
  std::vector<int> area(static_cast<size_t>(count), 0);  // static pixels per piece
  for (int r = 0; r < labels.rows; ++r) {
    const int* l = labels.ptr<int>(r);
    const uint8_t* f = fixed.ptr<uint8_t>(r);
    for (int c = 0; c < labels.cols; ++c) {
      if (f[c] != 0) ++area[static_cast<size_t>(l[c])];
    }
  }
  std::vector<int> pieces;
  for (int i = 1; i < count; ++i) {
    if (area[static_cast<size_t>(i)] >= options_.min_box_area) pieces.push_back(i);
  }
  std::stable_sort(pieces.begin(), pieces.end(), [&](int a, int b) {
    return area[static_cast<size_t>(a)] > area[static_cast<size_t>(b)];
  });
  if (static_cast<int>(pieces.size()) > options_.max_boxes) {
    pieces.resize(static_cast<size_t>(options_.max_boxes));
  }
  cv::Mat kept = cv::Mat::zeros(fixed.size(), CV_8U);
  for (int i : pieces) {
    // The box of the grown piece is the static pixels' box grown by `grow`.
    const int left = stats.at<int>(i, cv::CC_STAT_LEFT), top = stats.at<int>(i, cv::CC_STAT_TOP);
    Roi box;
    box.left = left;
    box.top = top;
    box.right = left + stats.at<int>(i, cv::CC_STAT_WIDTH) - 1;
    box.bottom = top + stats.at<int>(i, cv::CC_STAT_HEIGHT) - 1;
    out.boxes.push_back(box);
    kept.setTo(255, (labels == i) & fixed);
  }
  // The segments' mask: the static pixels of the kept pieces, grown.
  const int margin = static_cast<int>(std::lround(options_.margin_px));
  if (margin > 0) {
    cv::dilate(kept, out.mask,
               cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * margin + 1, 2 * margin + 1)));
  } else {
    out.mask = kept;
  }
  return out;
}

bool StaticStructure::Covers(const ImageSegment& s) const {
  if (mask.empty() || boxes.empty()) return false;
  const int samples = std::max(2, static_cast<int>(std::ceil(s.length)) + 1);
  int on = 0;
  for (int k = 0; k < samples; ++k) {
    const double t = static_cast<double>(k) / (samples - 1) - 0.5;
    const Eigen::Vector2d p = s.centre + t * s.length * s.direction;
    const int u = static_cast<int>(std::lround(p.x())), v = static_cast<int>(std::lround(p.y()));
    if (u >= 0 && v >= 0 && u < mask.cols && v < mask.rows && mask.at<uint8_t>(v, u) != 0) ++on;
  }
  return on >= min_static_share * samples;
}

std::vector<Roi> StaticStructure::BoxesInRows(double top, double bottom) const {
  std::vector<Roi> out;
  for (const Roi& b : boxes) {
    if (b.bottom > top && b.top < bottom) out.push_back(b);
  }
  return out;
}

std::vector<ImageSegment> StaticStructure::TakeCovered(std::vector<ImageSegment>& segments) const {
  std::vector<ImageSegment> covered;
  if (mask.empty()) return covered;
  const auto moved = std::stable_partition(segments.begin(), segments.end(),
                                           [&](const ImageSegment& s) { return !Covers(s); });
  covered.assign(moved, segments.end());
  segments.erase(moved, segments.end());
  return covered;
}

}  // namespace lane
