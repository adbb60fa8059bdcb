#include "lane/postprocess/profile.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "lane/base/double_pair.h"

namespace lane {

void SampleProfile(const ChannelView& image, const Eigen::Vector2d& center,
                   const Eigen::Vector2d& normal, double half, std::vector<float>& out) {
  const int h = std::max(0, static_cast<int>(std::lround(half)));
  out.resize(2 * h + 1);
  image.SampleAlong(center, normal, h, out.data());
}

namespace {

// The Gaussian's taps -h..h for one sigma (h = 2.5 sigma, at least 1) and
// their sum in order, kept per thread (TapsFor): a spline's profiles share
// a few sigmas (the image extension's follow the rows' scale, on the grid of
// QuantizedSigma, and repeat from candidate to candidate).
struct GaussianTaps {
  std::vector<double> w;
  double sum = 0;
  // The sums a profile's end renormalises by, each added in order, lowest
  // first: from_left[k] = w[0] + ... + w[k] (the taps the last samples keep),
  // to_right[k] = w[k] + ... + w[2h], k = 1..h (those the first h keep).
  std::vector<double> from_left, to_right;
  double sigma = -1;
  int h = 0;
};

const GaussianTaps& TapsFor(double sigma) {
  // A sigma on the 1/16 px grid of QuantizedSigma below 8 px has a slot of
  // its own (the profiles along image splines ask for a few dozen of them,
  // in no order a small cache would keep); any other sigma goes to the last
  // 16 asked, round robin.
  constexpr int kGridSlots = 8 * kSigmaSteps;
  constexpr size_t kKept = 16;
  thread_local std::array<GaussianTaps, kGridSlots> grid;
  thread_local std::array<GaussianTaps, kKept> kept;
  thread_local size_t next = 0;  // the slot of `kept` to reuse next
  const double steps = sigma * kSigmaSteps;
  GaussianTaps* slot = nullptr;
  if (steps >= 0 && steps < kGridSlots && steps == std::floor(steps)) {
    slot = &grid[static_cast<int>(steps)];
    if (slot->sigma == sigma) return *slot;
  } else {
    for (const GaussianTaps& t : kept) {
      if (t.sigma == sigma) return t;
    }
    slot = &kept[next];
    next = (next + 1) % kKept;
  }
  GaussianTaps& taps = *slot;
  taps.h = std::max(1, static_cast<int>(std::ceil(2.5 * sigma)));
  const int m = 2 * taps.h + 1;
  taps.w.resize(m);
  // The kernel is symmetric: one exp per |j| (the same value for -j and j),
  // then the sum in order, lowest first.
  for (int j = 0; j <= taps.h; ++j) {
    taps.w[taps.h + j] = taps.w[taps.h - j] = std::exp(-0.5 * j * j / (sigma * sigma));
  }
  taps.from_left.resize(m);
  taps.to_right.resize(m);
  double left = 0;
  for (int k = 0; k < m; ++k) taps.from_left[k] = left += taps.w[k];
  for (int k = 1; k <= taps.h; ++k) {  // the first h samples' (k = h - i)
    double right = 0;
    for (int t = k; t < m; ++t) right += taps.w[t];
    taps.to_right[k] = right;
  }
  taps.sum = taps.from_left[m - 1];
  taps.sigma = sigma;
  return taps;
}

}  // namespace

template <typename T>
void SmoothProfile(const std::vector<T>& in, double sigma, std::vector<double>& out) {
  const int n = static_cast<int>(in.size());
  const GaussianTaps& taps = TapsFor(sigma);
  const int h = taps.h, m = 2 * h + 1;
  const double* w = taps.w.data();
  // Eight outputs at a time, their sums in registers over all the taps (the
  // k loop vectorises), instead of one pass over the outputs per tap. The
  // samples are read in double with zeros around them, h before and enough
  // after for whole blocks: a tap past an end adds w * 0 = +0, which leaves
  // a sum unchanged, so every output is the sum of its in-range taps in
  // order, lowest first, as a plain loop over those taps gives.
  constexpr int kBlock = 8;
  const int blocks = (n + kBlock - 1) / kBlock;
  // Both buffers only grow (a std::vector that shrinks and grows again
  // zero-fills what it regrows).
  thread_local std::vector<double> padded, sums;
  const size_t padded_size = blocks * kBlock + 2 * h;
  if (padded.size() < padded_size) padded.resize(padded_size);
  if (sums.size() < static_cast<size_t>(blocks * kBlock)) sums.resize(blocks * kBlock);
  std::fill(padded.begin(), padded.begin() + h, 0.0);
  for (int i = 0; i < n; ++i) padded[h + i] = in[i];
  std::fill(padded.begin() + h + n, padded.begin() + padded_size, 0.0);
  double* o = sums.data();
  const double* x = padded.data();  // x[i + j] is sample i + j - h
  for (int i = 0; i < blocks * kBlock; i += kBlock) {
    // Four pairs of sums in registers (double_pair.h; each lane adds in the
    // order written).
    using internal::DoublePair;
    using internal::LoadPair;
    DoublePair a0 = {}, a1 = {}, a2 = {}, a3 = {};
    for (int j = 0; j < m; ++j) {
      const DoublePair wj = {w[j], w[j]};
      const double* xj = x + i + j;
      a0 += wj * LoadPair(xj);
      a1 += wj * LoadPair(xj + 2);
      a2 += wj * LoadPair(xj + 4);
      a3 += wj * LoadPair(xj + 6);
    }
    const DoublePair acc[kBlock / 2] = {a0, a1, a2, a3};
    std::memcpy(o + i, acc, sizeof acc);
  }
  out.assign(sums.begin(), sums.begin() + n);
  o = out.data();
  // Each output over the weight of its in-range taps: the whole kernel's,
  // except within h of an end.
  for (int i = 0; i < n; ++i) {
    const int j0 = std::max(-h, -i), j1 = std::min(h, n - 1 - i);
    double ws = taps.sum;
    if (j0 != -h && j1 != h) {  // a profile shorter than the kernel
      ws = 0;
      for (int j = j0; j <= j1; ++j) ws += w[j + h];
    } else if (j0 != -h) {
      ws = taps.to_right[j0 + h];
    } else if (j1 != h) {
      ws = taps.from_left[j1 + h];
    }
    o[i] /= ws;
  }
}
template void SmoothProfile<float>(const std::vector<float>&, double, std::vector<double>&);
template void SmoothProfile<double>(const std::vector<double>&, double, std::vector<double>&);

namespace internal {
int FirstMaxIndex(const double* s, int n) {
  // The largest value first, in four running maxima (a maximum is exact in
  // any order), then its first index: the same index as std::max_element,
  // whose loop carried a load through a conditional move from element to
  // element (most of FindProfilePeak's time in perf).
  double m0 = s[0], m1 = s[0], m2 = s[0], m3 = s[0];
  int i = 1;
  for (; i + 4 <= n; i += 4) {
    m0 = std::max(m0, s[i]);
    m1 = std::max(m1, s[i + 1]);
    m2 = std::max(m2, s[i + 2]);
    m3 = std::max(m3, s[i + 3]);
  }
  for (; i < n; ++i) m0 = std::max(m0, s[i]);
  const double top = std::max(std::max(m0, m1), std::max(m2, m3));
  int k = 0;
  while (s[k] != top) ++k;
  return k;
}
}  // namespace internal

std::optional<ProfilePeak> FindProfilePeak(const std::vector<float>& profile, double sigma_px) {
  const int n = static_cast<int>(profile.size());
  if (n < 3) return std::nullopt;
  thread_local std::vector<double> s;
  if (sigma_px > 0) {
    SmoothProfile(profile, sigma_px, s);
  } else {
    s.assign(profile.begin(), profile.end());
  }
  const int best = internal::FirstMaxIndex(s.data(), n);
  // Contrast over the profile's mean: a marking covers a few of its samples,
  // so the mean is close to the background (and, unlike a median, costs no
  // selection; this runs a few hundred times per frame).
  double mean = 0;
  for (double v : s) mean += v;
  mean /= n;
  const double contrast = s[best] - mean;
  if (!(contrast > 0)) return std::nullopt;
  double offset = best;
  if (best > 0 && best < n - 1) {
    const double l = s[best - 1], c = s[best], r = s[best + 1];
    const double denom = l - 2 * c + r;
    if (denom < 0) offset += std::clamp(0.5 * (l - r) / denom, -0.5, 0.5);
  }
  return ProfilePeak{offset - (n - 1) / 2.0, contrast};
}

}  // namespace lane
