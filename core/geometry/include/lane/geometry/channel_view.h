// One channel of a frame or top view, read in place: the view every stage
// that samples pixels along a curve uses (the IPM's channel, post-processing's
// profiles, the vehicle check), and the grey weights of a BGR pixel.
#ifndef LANE_GEOMETRY_CHANNEL_VIEW_H_
#define LANE_GEOMETRY_CHANNEL_VIEW_H_

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <opencv2/core.hpp>

namespace lane {

// One channel of an image without copying it out: a CV_8UC1 or CV_32FC1
// image (channel 0), or channel `channel` of a CV_8UC3 image, or with
// `channel2` >= 0 the per-pixel minimum of two channels of a CV_8UC3 image,
// or with `channel2` == kGrayOfBgr the grey (BT.601, as cv::COLOR_BGR2GRAY)
// of a CV_8UC3 BGR image.
inline constexpr int kGrayOfBgr = -2;
inline int GrayOfBgr(const uint8_t* p) {
  return (p[0] * 1868 + p[1] * 9617 + p[2] * 4899 + 8192) >> 14;
}
//
// Only rows [top(), bottom()) are read (row_begin/row_end; the whole image
// by default): the detector sets them to the rows it needs of a frame
// (Detector::Needs), so that a frame decoded only there reads exactly as a
// whole one. Points in other rows count as outside the image.
struct ChannelView {
  ChannelView(const cv::Mat& m, int c = 0, int c2 = -1)  // NOLINT: implicit
      : image(m), channel(c), channel2(c2) {}
  cv::Mat image;
  int channel = 0;
  int channel2 = -1;
  int row_begin = 0;
  int row_end = -1;  // -1: the image's height
  int cols() const { return image.cols; }
  int rows() const { return image.rows; }
  int top() const { return row_begin; }
  int bottom() const { return row_end < 0 ? image.rows : row_end; }
  // Whether (x, y) lies inside the image and the rows read.
  bool Inside(double x, double y) const {
    return x >= 0 && y >= top() && x <= image.cols - 1 && y <= bottom() - 1;
  }
  float At(int x, int y) const {
    if (image.depth() == CV_32F) return image.ptr<float>(y)[x];
    const uint8_t* p = image.ptr<uint8_t>(y) + x * image.channels();
    if (channel2 == kGrayOfBgr) return static_cast<float>(GrayOfBgr(p));
    return channel2 >= 0 ? std::min(p[channel], p[channel2]) : p[channel];
  }
  // Bilinear sample; 0 outside the image. Inline: profile sampling calls it
  // tens of thousands of times per frame.
  float Bilinear(double x, double y) const;
  // Bilinear(x, y) at each point c + i * d, i = -h..h, into out[0 .. 2h],
  // with the channel's case decided once for the run. Returns whether every
  // point lies inside.
  bool SampleAlong(const Eigen::Vector2d& c, const Eigen::Vector2d& d, int h, float* out) const;
};

namespace internal {
// Bilinear sample of channel `channel` of `m` at (x, y) (inside the image and
// rows top..bottom - 1), reading only those rows.
template <typename T>
inline float BilinearT(const cv::Mat& m, int cn, int channel, double x, double y, int top,
                       int bottom) {
  const int x0 = std::min(static_cast<int>(x), std::max(0, m.cols - 2));
  const int y0 = std::min(static_cast<int>(y), std::max(top, bottom - 2));
  const int dx = m.cols > 1 ? cn : 0;
  const size_t dy = bottom - top > 1 ? m.step[0] : 0;
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const uint8_t* p = m.data + y0 * m.step[0] + (x0 * cn + channel) * sizeof(T);
  const T* p00 = reinterpret_cast<const T*>(p);
  const T* p01 = reinterpret_cast<const T*>(p + dx * sizeof(T));
  const T* p10 = reinterpret_cast<const T*>(p + dy);
  const T* p11 = reinterpret_cast<const T*>(p + dy + dx * sizeof(T));
  return (1 - fy) * ((1 - fx) * *p00 + fx * *p01) + fy * ((1 - fx) * *p10 + fx * *p11);
}

}  // namespace internal

inline float ChannelView::Bilinear(double x, double y) const {
  if (!Inside(x, y)) return 0.f;
  if (channel2 != -1) {
    const int x0 = std::min(static_cast<int>(x), std::max(0, image.cols - 2));
    const int y0 = std::min(static_cast<int>(y), std::max(top(), bottom() - 2));
    const int x1 = std::min(x0 + 1, image.cols - 1), y1 = std::min(y0 + 1, bottom() - 1);
    const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
    return (1 - fy) * ((1 - fx) * At(x0, y0) + fx * At(x1, y0)) +
           fy * ((1 - fx) * At(x0, y1) + fx * At(x1, y1));
  }
  if (image.depth() == CV_32F)
    return internal::BilinearT<float>(image, image.channels(), channel, x, y, top(), bottom());
  return internal::BilinearT<uint8_t>(image, image.channels(), channel, x, y, top(), bottom());
}

inline bool ChannelView::SampleAlong(const Eigen::Vector2d& c, const Eigen::Vector2d& d, int h,
                                     float* out) const {
  bool all_inside = true;
  // c + i * d rounds monotonically in i, so when both ends lie inside the
  // (convex) image every point between them does: no test per point then.
  const Eigen::Vector2d first = c + (-h) * d, last = c + h * d;
  const bool ends_inside = Inside(first.x(), first.y()) && Inside(last.x(), last.y());
  const auto run = [&](const auto& sample) {
    if (ends_inside) {
      for (int i = -h; i <= h; ++i) {
        const Eigen::Vector2d p = c + i * d;
        out[i + h] = sample(p.x(), p.y());
      }
      return;
    }
    for (int i = -h; i <= h; ++i) {
      const Eigen::Vector2d p = c + i * d;
      const bool inside = Inside(p.x(), p.y());
      all_inside = all_inside && inside;
      out[i + h] = inside ? sample(p.x(), p.y()) : 0.f;
    }
  };
  if (channel2 != -1) {
    run([this](double x, double y) { return Bilinear(x, y); });
  } else {
    const int cn = image.channels(), t = top(), b = bottom();
    if (image.depth() == CV_32F) {
      run([&](double x, double y) {
        return internal::BilinearT<float>(image, cn, channel, x, y, t, b);
      });
    } else {
      run([&](double x, double y) {
        return internal::BilinearT<uint8_t>(image, cn, channel, x, y, t, b);
      });
    }
  }
  return all_inside;
}

}  // namespace lane

#endif  // LANE_GEOMETRY_CHANNEL_VIEW_H_
