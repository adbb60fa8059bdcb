// The top view of each frame (IpmMapping::Apply): bilinear from the quads
// fixed at calibration, or area-sampled from the segments' row prefix sums.
// The calibration-time half of IpmMapping is ipm.cc.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "lane/base/four_sums.h"
#include "lane/geometry/channel_view.h"
#include "lane/geometry/ipm.h"

namespace lane {

namespace {

// p[0] = 0, p[k + 1] = v(0) + ... + v(k) for k < n: exact integers, 16
// pixels at a time where the CPU has 128-bit vectors (a running sum is a
// chain of dependent adds, and at 1640x100 pixels a frame it was a third of
// the area top view's time). `load16(k)` gives v(k .. k + 15) as a vector,
// `at(k)` gives v(k): the channel is read from the frame's pixels here, in
// the same pass (a separate extraction cost another pass over the band).
template <typename Load16, typename At>
void RowPrefixSums(int n, int32_t* p, const Load16& load16, const At& at) {
  p[0] = 0;
  int k = 0;
  int32_t acc = 0;
#if CV_SIMD128
  using namespace cv;  // NOLINT: OpenCV's universal intrinsics (v_*)
  v_uint32x4 carry = v_setzero_u32();
  for (; k + 16 <= n; k += 16) {
    v_uint16x8 lo, hi;
    v_expand(load16(k), lo, hi);
    // Prefix sums within each half (at most 16 * 255: no overflow in u16).
    lo += v_rotate_left<1>(lo);
    lo += v_rotate_left<2>(lo);
    lo += v_rotate_left<4>(lo);
    hi += v_rotate_left<1>(hi);
    hi += v_rotate_left<2>(hi);
    hi += v_rotate_left<4>(hi);
    hi += v_setall_u16(v_extract_n<7>(lo));
    v_uint32x4 a, b, c, d;
    v_expand(lo, a, b);
    v_expand(hi, c, d);
    a += carry;
    b += carry;
    c += carry;
    d += carry;
    v_store(reinterpret_cast<unsigned*>(p + k + 1), a);
    v_store(reinterpret_cast<unsigned*>(p + k + 5), b);
    v_store(reinterpret_cast<unsigned*>(p + k + 9), c);
    v_store(reinterpret_cast<unsigned*>(p + k + 13), d);
    carry = v_broadcast_element<3>(d);
  }
  acc = p[k];
#else
  (void)load16;
#endif
  for (; k < n; ++k) p[k + 1] = acc += at(k);
}

// The prefix sums of one row of a single-channel image, of channel `c` of a
// BGR row, or of the minimum of channels `c` and `c2` of a BGR row.
void RowPrefixSums(const uint8_t* px, int n, int32_t* p) {
#if CV_SIMD128
  const auto load16 = [px](int k) { return cv::v_load(px + k); };
#else
  const auto load16 = [](int) { return 0; };
#endif
  RowPrefixSums(n, p, load16, [px](int k) { return px[k]; });
}
void RowPrefixSumsBgr(const uint8_t* px, int n, int c, int c2, int32_t* p) {
#if CV_SIMD128
  const auto load16 = [px, c, c2](int k) {
    cv::v_uint8x16 ch[3];
    cv::v_load_deinterleave(px + 3 * k, ch[0], ch[1], ch[2]);
    return c2 >= 0 ? cv::v_min(ch[c], ch[c2]) : ch[c];
  };
#else
  const auto load16 = [](int) { return 0; };
#endif
  if (c2 >= 0) {
    RowPrefixSums(n, p, load16,
                  [px, c, c2](int k) { return std::min(px[3 * k + c], px[3 * k + c2]); });
  } else {
    RowPrefixSums(n, p, load16, [px, c](int k) { return px[3 * k + c]; });
  }
}

}  // namespace

cv::Mat IpmMapping::ApplySegments(const cv::Mat& image, int channel, int channel2) const {
  // The channel over the rows and columns read, then the prefix sums of each
  // of its rows: P[k] = sum of pixels 0 .. k - 1 (exact in int32: at most
  // 16384 * 255).
  const int cols = seg_cols_;
  const int rows = seg_row1_ - seg_row0_ + 1;
  thread_local std::vector<int32_t> prefix;
  prefix.resize(static_cast<size_t>(rows) * cols);
  if (image.channels() == 3 && channel2 != kGrayOfBgr) {
    // Red (or min(red, green)) straight from the BGR rows.
    for (int v = 0; v < rows; ++v) {
      RowPrefixSumsBgr(image.ptr<uint8_t>(seg_row0_ + v), cols - 1, channel, channel2,
                       prefix.data() + static_cast<size_t>(v) * cols);
    }
  } else {
    thread_local cv::Mat scratch, scratch2;
    const cv::Mat band = ChannelBand(image, cv::Rect(0, seg_row0_, cols - 1, rows), channel,
                                     channel2, scratch, scratch2);
    for (int v = 0; v < rows; ++v) {
      RowPrefixSums(band.ptr<uint8_t>(v), cols - 1, prefix.data() + static_cast<size_t>(v) * cols);
    }
  }
  // The box average of one row: prefix difference between the two
  // interpolated prefix positions.
  const auto box = [](const int32_t* p, int len, float f0, float f1) {
    const float at1 = p[len] + f1 * static_cast<float>(p[len + 1] - p[len]);
    const float at0 = p[0] + f0 * static_cast<float>(p[1] - p[0]);
    return at1 - at0;
  };
  cv::Mat out(height_, width_, CV_32F);
  float* dst = out.ptr<float>(0);
  const int n = width_ * height_;
  const int32_t* base = prefix.data();
  // The mean for the empty pixels in four partial sums (the additions do
  // not wait on each other; the mean, rounded to float, is the same).
  double part[4] = {0, 0, 0, 0};
  for (int i = 0; i < n; ++i) {
    const int a = seg_start_[i], b = seg_start_[i + 1];
    if (a == b) continue;
    float value = 0;
    for (int k = a; k < b; ++k) {
      const SubRow& sr = segments_[k];
      const int32_t* p = base + sr.off0;
      value += sr.w0 * box(p, sr.len, sr.f0, sr.f1);
      value += sr.w1 * box(p + cols, sr.len, sr.f0, sr.f1);
    }
    value *= 1.f / 255.f;
    dst[i] = value;
    part[i & 3] += value;
  }
  const double sum = (part[0] + part[1]) + (part[2] + part[3]);
  const float mean = static_cast<float>(sum / valid_count_);
  for (const int32_t i : seg_empty_) dst[i] = mean;
  return out;
}

double IpmMapping::mean_taps() const {
  if (valid_count_ == 0) return 0.0;
  if (options_.interpolation == Interpolation::kArea) {
    double rows = 0;  // each sub-row reads two image rows
    for (const SubRow& sr : segments_) rows += (sr.w0 > 0) + (sr.w1 > 0);
    return rows / valid_count_;
  }
  double taps = 0;
  for (const Quad& q : quads_) taps += (q.w[0] > 0) + (q.w[1] > 0) + (q.w[2] > 0) + (q.w[3] > 0);
  return taps / valid_count_;
}

cv::Mat IpmMapping::ChannelBand(const cv::Mat& image, const cv::Rect& rect, int channel,
                                int channel2, cv::Mat& scratch, cv::Mat& scratch2) {
  const cv::Mat src = image(rect);
  if (src.channels() == 1) return src;
  if (channel2 == kGrayOfBgr) {
    cv::cvtColor(src, scratch, cv::COLOR_BGR2GRAY);  // BT.601 in fixed point, as GrayOfBgr
  } else if (channel2 >= 0) {
    cv::extractChannel(src, scratch, channel);
    cv::extractChannel(src, scratch2, channel2);
    cv::min(scratch, scratch2, scratch);
  } else {
    cv::extractChannel(src, scratch, channel);
  }
  return scratch;
}

cv::Mat IpmMapping::Apply(const cv::Mat& image, int channel, int channel2) const {
  CV_Assert(image.depth() == CV_8U && image.cols == camera_.image_width &&
            image.rows == camera_.image_height && channel >= 0 && channel < image.channels() &&
            channel2 < image.channels() && (channel2 != kGrayOfBgr || image.channels() == 3));
  if (options_.interpolation == Interpolation::kArea)
    return ApplySegments(image, channel, channel2);
  // Every pixel is written below: a valid one from its quad, an invalid one
  // (outside the ROI) with the valid ones' mean.
  cv::Mat out(height_, width_, CV_32F);
  float* dst = out.ptr<float>(0);  // continuous: freshly allocated
  // Each quad's 2x2 from `base` (the band's top-left), `dx` bytes to the next
  // column and `dy` to the next row. A quad's zero weights add an exact 0:
  // the sum equals that of its non-zero taps alone. The mean for the invalid
  // pixels is added in four partial sums (four_sums.h; the mean, rounded to
  // float, is the same).
  const auto gather = [&](const uint8_t* base, int dx, size_t dy) {
    const auto pixel = [&](const Quad& q) {
      const uint8_t* p = base + q.row * dy + q.col * dx;
      float v = 0.f;
      v += q.w[0] * p[0];
      v += q.w[1] * p[dx];
      v += q.w[2] * p[dy];
      v += q.w[3] * p[dy + dx];
      v *= 1.f / 255.f;
      dst[q.pixel] = v;
      return static_cast<double>(v);
    };
    return internal::SumInFourParts(quads_.size(), [&](size_t k) { return pixel(quads_[k]); });
  };
  double sum = 0;
  if (channel2 == -1 && image.channels() > 1) {
    // One channel of a colour frame: read in place (no extracted band).
    const int cn = image.channels();
    sum = gather(image.ptr<uint8_t>(tap_row0_) + tap_col0_ * cn + channel, cn, image.step[0]);
  } else {
    thread_local cv::Mat scratch, scratch2;
    const cv::Mat band = ChannelBand(image, cv::Rect(tap_col0_, tap_row0_, tap_cols_, tap_rows_),
                                     channel, channel2, scratch, scratch2);
    sum = gather(band.ptr<uint8_t>(0), 1, band.step[0]);
  }
  const float mean = static_cast<float>(sum / valid_count_);
  for (const int32_t i : invalid_pixels_) dst[i] = mean;
  return out;
}

}  // namespace lane
