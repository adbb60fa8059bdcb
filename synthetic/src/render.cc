// Drawing the synthetic frame (sky, ground, markings, objects, sensor) and
// its ground truth.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "lane/geometry/bezier.h"
#include "scene.h"

namespace lane {
namespace synthetic_internal {

// ---------------------------------------------------------------------------
// Rendering.

void RenderSky(const CameraModel& cam, const Look& look, cv::Mat3f& img) {
  const int w = img.cols;
  const double horizon = cam.HorizonRow();
  const int last = std::min(img.rows - 1, static_cast<int>(std::floor(horizon + 0.5)));
  if (last < 0) return;
  const double span = std::max(1.0, 0.7 * img.rows);
  std::vector<double> top(w);
  for (int u = 0; u < w; ++u) {
    const double n = 0.6 * ValueNoise(u * look.treeline_scale, 0.5, 1.0, look.salt + 11) +
                     0.4 * ValueNoise(u * look.treeline_scale * 4.0, 0.5, 1.0, look.salt + 12);
    top[u] = horizon - look.treeline_base - look.treeline_amp * std::max(0.0, n + 0.3);
  }
  // Clouds: stretched fractal noise, evaluated on a coarse grid (it is smooth)
  // and interpolated.
  cv::Mat1f clouds;
  if (look.clouds > 0) {
    constexpr int kStep = 4;
    cv::Mat1f coarse(last / kStep + 2, w / kStep + 2);
    for (int i = 0; i < coarse.rows; ++i) {
      for (int j = 0; j < coarse.cols; ++j) {
        const double cx = j * kStep * look.cloud_scale, cy = i * kStep * look.cloud_scale * 2.5;
        const double n = 0.55 * ValueNoise(cx, cy, 1.0, look.salt + 14) +
                         0.3 * ValueNoise(cx * 2.3, cy * 2.3, 1.0, look.salt + 15) +
                         0.15 * ValueNoise(cx * 5.1, cy * 5.1, 1.0, look.salt + 16);
        coarse(i, j) = static_cast<float>(look.clouds * std::clamp((n + 0.1) * 2.5, 0.0, 1.0));
      }
    }
    cv::resize(coarse, clouds, cv::Size(coarse.cols * kStep, coarse.rows * kStep), 0, 0,
               cv::INTER_LINEAR);
  }
  for (int v = 0; v <= last; ++v) {
    const double t = std::pow(std::clamp((horizon - v) / span, 0.0, 1.0), 0.7);
    const cv::Vec3f clear = Lerp(look.haze, look.sky_top, t);
    auto* row = img.ptr<cv::Vec3f>(v);
    const float* cloud_row = clouds.empty() ? nullptr : clouds.ptr<float>(v);
    for (int u = 0; u < w; ++u) {
      cv::Vec3f sky = clear;
      if (cloud_row) sky = Lerp(sky, look.cloud, cloud_row[u] * (0.3 + 0.7 * t));
      const double cover = SoftStep(v - top[u], 1.0);
      if (cover <= 0) {
        row[u] = sky;
        continue;
      }
      // Distant trees/hills: hazy, textured.
      const double tex = 12.0 * ValueNoise(u, v, 0.25, look.salt + 13);
      cv::Vec3f c = Lerp(look.treeline, look.haze, 0.35) + cv::Vec3f::all(static_cast<float>(tex));
      row[u] = Lerp(sky, c, cover);
    }
  }
}

namespace {

// Ground point of pixel (u, v) is a(v) + b(v) * u (the homography's
// denominator depends on v only): at the row (a, b) and half a row above
// (am, bm) and below (ap, bp).
struct RowAffine {
  Eigen::Vector2d a, b, am, bm, ap, bp;
};

// One ground pixel: its ground point, footprint and place on the road.
struct GroundPixel {
  double x, y;                // ground point
  double jux, juy, jvx, jvy;  // pixel footprint on the ground: Jacobian columns
  double foot;                // the footprint's size, sqrt(area)
  double ext_x;               // the footprint's lateral extent
  double slope, inv_norm;     // road slope at y, and 1 / sqrt(1 + slope^2)
  double lane_pos;            // lateral position from the first boundary
  double gx, gy;              // texture coordinates
};

// The ground point a + b * u of row v, for the pixel at u = 0 and the step per pixel.
void RowAffineAt(const CameraModel& cam, double du, double v, Eigen::Vector2d* a,
                 Eigen::Vector2d* b) {
  *a = cam.ImageToGround({0.0, v});
  *b = (cam.ImageToGround({du, v}) - *a) / du;
}

// Row v's affine ground mapping, at the row and half a row above and below.
RowAffine RowAffineOf(const CameraModel& cam, double du, int v) {
  RowAffine r;
  RowAffineAt(cam, du, v, &r.a, &r.b);
  RowAffineAt(cam, du, v - 0.5, &r.am, &r.bm);
  RowAffineAt(cam, du, v + 0.5, &r.ap, &r.bp);
  return r;
}

// Pixel u of a row on the ground; false when it looks at no ground point ahead.
bool GroundPixelAt(const RowAffine& r, const Road& road, const Boundary& b0, int u,
                   GroundPixel* p) {
  p->x = r.a.x() + r.b.x() * u;
  p->y = r.a.y() + r.b.y() * u;
  const double x = p->x, y = p->y;
  if (!(y > 0) || !std::isfinite(x)) return false;
  p->jux = r.b.x();
  p->juy = r.b.y();
  p->jvx = (r.ap.x() - r.am.x()) + (r.bp.x() - r.bm.x()) * u;
  p->jvy = (r.ap.y() - r.am.y()) + (r.bp.y() - r.bm.y()) * u;
  const double area = std::abs(p->jux * p->jvy - p->juy * p->jvx);
  p->foot = std::sqrt(area);
  p->ext_x = std::abs(p->jux) + std::abs(p->jvx);
  p->slope = road.Slope(y);
  p->inv_norm = 1.0 / std::sqrt(1.0 + p->slope * p->slope);
  p->lane_pos = (x - road.X(b0.offset, y)) * p->inv_norm;
  p->gx = road.world_texture ? p->lane_pos : x;
  p->gy = road.world_texture ? y + road.s0 : y;
  return true;
}

// Asphalt: patches, mottling and grain (faded as the pixel's footprint grows), tyre tracks.
cv::Vec3f AsphaltColour(const Road& road, const Look& look, const GroundPixel& p) {
  const uint64_t salt = look.salt;
  const double gx = p.gx, gy = p.gy, foot = p.foot;
  double grey = look.asphalt + look.patch_amp * ValueNoise(gx, gy, 1.0 / 7.0, salt + 1);
  const double mid = look.mid_amp * std::min(1.0, 1.2 / foot);
  if (mid > 0.2) grey += mid * ValueNoise(gx, gy, 1.0 / 1.2, salt + 2);
  const double grain = look.grain_amp * std::min(1.0, 0.07 / foot);
  if (grain > 0.2) grey += grain * ValueNoise(gx, gy, 1.0 / 0.07, salt + 3);
  const double fine = look.grain_amp * std::min(1.0, 0.02 / foot);
  if (fine > 0.2) grey += fine * ValueNoise(gx, gy, 1.0 / 0.02, salt + 6);
  // Darker tyre tracks in every lane.
  const double lane_pos = p.lane_pos;
  const double in_lane = lane_pos - road.lane_width * std::floor(lane_pos / road.lane_width);
  const double track = std::min(std::abs(in_lane - 0.5 * road.lane_width + 0.85),
                                std::abs(in_lane - 0.5 * road.lane_width - 0.85));
  const double bump = std::max(0.0, 1.0 - track * track / 0.3);
  grey -= look.track_dark * bump * bump;
  if (look.seam_every > 0) {
    grey -= SeamDarkening(road, look, lane_pos, gy, p.ext_x, std::abs(p.juy) + std::abs(p.jvy));
  }
  return look.asphalt_tint * static_cast<float>(grey);
}

// Blends in the verge beyond the asphalt edges.
void BlendVerge(const Road& road, const Look& look, const GroundPixel& p, cv::Vec3f& colour) {
  const uint64_t salt = look.salt;
  const double x = p.x, y = p.y, inv_norm = p.inv_norm;
  const double fd0 = std::max(1e-4, p.ext_x * inv_norm + 1e-3);
  const double el = (x - road.X(road.edge_left, y)) * inv_norm;
  const double er = (road.X(road.edge_right, y) - x) * inv_norm;
  const double on_road = SoftStep(el, fd0) * SoftStep(er, fd0);
  if (on_road < 1.0) {
    const double vt = look.verge_amp * (0.6 * ValueNoise(p.gx, p.gy, 1.0 / 0.8, salt + 4) +
                                        0.4 * std::min(1.0, 0.1 / p.foot) *
                                            ValueNoise(p.gx, p.gy, 1.0 / 0.1, salt + 5));
    const cv::Vec3f verge = look.verge + cv::Vec3f::all(static_cast<float>(vt));
    colour = Lerp(verge, colour, on_road);
  }
}

// A marking's box-filtered coverage of the pixel across (lateral) and along (dashes).
double MarkingCover(const Road& road, const Boundary& m, const GroundPixel& p) {
  const double slope = p.slope, inv_norm = p.inv_norm, y = p.y;
  const double jux = p.jux, juy = p.juy, jvx = p.jvx, jvy = p.jvy;
  const double d = (p.x - road.X(m.offset, y)) * inv_norm;
  const double nx = inv_norm, ny = -slope * inv_norm;  // unit normal
  const double fd = std::max(1e-4, std::abs(nx * jux + ny * juy) + std::abs(nx * jvx + ny * jvy));
  if (m.dots) {
    const double tx = slope * inv_norm, ty = inv_norm;  // unit tangent
    return DotsCover(m, d, fd, y, std::abs(tx * jux + ty * juy) + std::abs(tx * jvx + ty * jvy));
  }
  const double half = 0.5 * m.width;
  // A line of the marking centred `c` metres across from its offset.
  auto strip = [&](double c) {
    const double lo = std::max(d - c - 0.5 * fd, -half);
    const double hi = std::min(d - c + 0.5 * fd, half);
    return std::max(0.0, hi - lo) / fd;
  };
  double cover = 0;
  if (m.double_gap > 0) {
    const double c = 0.5 * (m.double_gap + m.width);
    if (std::abs(d) >= c + half + 0.5 * fd) return 0.0;
    cover = std::min(1.0, strip(-c) + strip(c));
  } else {
    if (std::abs(d) >= half + 0.5 * fd) return 0.0;
    cover = strip(0);
  }
  if (m.dashed) {
    const double tx = slope * inv_norm, ty = inv_norm;  // unit tangent
    const double fa = std::abs(tx * jux + ty * juy) + std::abs(tx * jvx + ty * jvy);
    if (fa < 1e-6) {
      cover *= (PaintedUpTo(m, y + 1e-6) - PaintedUpTo(m, y)) > 0 ? 1.0 : 0.0;
    } else {
      cover *= (PaintedUpTo(m, y + 0.5 * fa) - PaintedUpTo(m, y - 0.5 * fa)) / fa;
    }
  }
  return cover;
}

// Blends in the visible markings, worn where they are.
void BlendMarkings(const Road& road, const std::vector<const Boundary*>& visible,
                   const GroundPixel& p, cv::Vec3f& colour) {
  for (const Boundary* m : visible) {
    const double cover = MarkingCover(road, *m, p);
    if (cover <= 0) continue;
    double alpha = m->alpha;
    if (m->wear > 0) {
      alpha *= 1.0 - m->wear * std::max(0.0, ValueNoise(p.gx, p.gy, 1.0 / 0.4, m->salt));
    }
    colour = Lerp(colour, m->colour, alpha * cover);
  }
}

}  // namespace

void RenderGround(const CameraModel& cam, const Road& road, const Look& look,
                  const std::vector<Shadow>& shadows, cv::Mat3f& img) {
  const int w = img.cols;
  const int h = img.rows;
  const double horizon = cam.HorizonRow();
  const int first = std::max(0, static_cast<int>(std::floor(horizon + 0.5)) + 1);
  const double du = w > 1 ? w - 1 : 1;
  std::vector<const Boundary*> visible;
  for (const Boundary& m : road.boundaries) {
    if (m.visible) visible.push_back(&m);
  }
  const Boundary& b0 = road.boundaries.front();
  for (int v = first; v < h; ++v) {
    const RowAffine r = RowAffineOf(cam, du, v);
    auto* row = img.ptr<cv::Vec3f>(v);
    // Atmospheric haze exp(-y / haze_dist); y is affine in u along the row.
    double clear = std::exp(-r.a.y() / look.haze_dist);
    const double clear_step = std::exp(-r.b.y() / look.haze_dist);
    // Rows at the horizon span huge distances: evaluate those directly.
    const bool recur = clear > 1e-200 && clear_step < 1e10 && clear_step > 1e-10;
    for (int u = 0; u < w; ++u, clear *= clear_step) {
      GroundPixel p;
      if (!GroundPixelAt(r, road, b0, u, &p)) continue;
      cv::Vec3f colour = AsphaltColour(road, look, p);
      BlendVerge(road, look, p, colour);
      BlendMarkings(road, visible, p, colour);
      colour *= static_cast<float>(ShadowFactor(shadows, p.x, p.y, p.foot));
      const double haze = 1.0 - (recur ? clear : std::exp(-p.y / look.haze_dist));
      row[u] = Lerp(colour, look.haze, haze);
    }
  }
}

void DrawVehicle(const CameraModel& cam, const Object& o, cv::Mat& img) {
  const Eigen::Vector2d bl = cam.GroundToImage({o.x - 0.5 * o.size, o.y});
  const Eigen::Vector2d br = cam.GroundToImage({o.x + 0.5 * o.size, o.y});
  const Eigen::Vector2d top = Project(cam, o.x, o.y, o.height);
  const double u0 = bl.x(), u1 = br.x();
  const double vb = 0.5 * (bl.y() + br.y());
  const double vt = top.y();
  const double w = u1 - u0;
  const double hh = vb - vt;
  if (w < 1.0 || hh < 1.0) return;
  const double uc = 0.5 * (u0 + u1);
  // Contact shadow on the road.
  cv::ellipse(img, Fp(uc, vb),
              cv::Size(cvRound(0.6 * w * 16), cvRound(std::max(1.0, 0.05 * hh) * 16)), 0, 0, 360,
              cv::Scalar(18, 18, 18), cv::FILLED, cv::LINE_AA, kShift);
  // Wheels, body, rear window, lights, plate.
  const cv::Scalar tyre(12, 12, 12);
  FillRect(img, u0 + 0.05 * w, vb - 0.25 * hh, u0 + 0.22 * w, vb, tyre);
  FillRect(img, u1 - 0.22 * w, vb - 0.25 * hh, u1 - 0.05 * w, vb, tyre);
  FillRoundedRect(img, u0, vt, u1, vb - 0.12 * hh, 0.12 * w, o.colour);
  FillRoundedRect(img, u0 + 0.12 * w, vt + 0.08 * hh, u1 - 0.12 * w, vt + 0.40 * hh, 0.06 * w,
                  o.colour2);
  const cv::Scalar red(35, 35, 175);
  FillRect(img, u0 + 0.04 * w, vt + 0.48 * hh, u0 + 0.2 * w, vt + 0.58 * hh, red);
  FillRect(img, u1 - 0.2 * w, vt + 0.48 * hh, u1 - 0.04 * w, vt + 0.58 * hh, red);
  FillRect(img, uc - 0.11 * w, vt + 0.62 * hh, uc + 0.11 * w, vt + 0.71 * hh,
           cv::Scalar(170, 170, 170));
  FillRect(img, u0 + 0.02 * w, vt + 0.76 * hh, u1 - 0.02 * w, vt + 0.82 * hh, o.colour * 0.6);
}

void DrawTree(const CameraModel& cam, const Object& o, cv::Mat& img) {
  const double trunk = 0.18;
  const double crown_z = o.height - o.size;
  FillPoly(img,
           {Project(cam, o.x - trunk, o.y, 0), Project(cam, o.x + trunk, o.y, 0),
            Project(cam, o.x + trunk, o.y, crown_z), Project(cam, o.x - trunk, o.y, crown_z)},
           o.colour2);
  const Eigen::Vector2d c = Project(cam, o.x, o.y, crown_z);
  const double r = (Project(cam, o.x + o.size, o.y, crown_z) - c).norm();
  if (r < 0.5) return;
  // A few overlapping blobs of slightly different greens.
  for (int k = 0; k < 4; ++k) {
    const double a = 1.7 * k + o.x;
    const Eigen::Vector2d p = c + 0.35 * r * Eigen::Vector2d(std::cos(a), std::sin(a) - 0.3);
    const double shade = 0.85 + 0.1 * k;
    cv::circle(img, Fp(p.x(), p.y()), cvRound(0.75 * r * 16), o.colour * shade, cv::FILLED,
               cv::LINE_AA, kShift);
  }
}

void DrawBuilding(const CameraModel& cam, const Object& o, cv::Mat& img) {
  const double y0 = o.y, y1 = o.y + o.size, x0 = o.x, x1 = o.x + o.extra, z = o.height;
  if (Depth(cam, x0, y0, z) < 1.0 || Depth(cam, x1, y0, z) < 1.0) return;
  // Face towards the camera (perpendicular to the road) and the side facade.
  FillPoly(img,
           {Project(cam, x0, y0, 0), Project(cam, x1, y0, 0), Project(cam, x1, y0, z),
            Project(cam, x0, y0, z)},
           o.colour);
  FillPoly(img,
           {Project(cam, x0, y0, 0), Project(cam, x0, y1, 0), Project(cam, x0, y1, z),
            Project(cam, x0, y0, z)},
           o.colour2);
  // Windows on the side facade.
  const cv::Scalar glass = o.colour2 * 0.45;
  for (double wz = 1.5; wz + 1.2 < z; wz += 3.0) {
    for (double wy = y0 + 1.0; wy + 1.5 < y1; wy += 3.0) {
      FillPoly(img,
               {Project(cam, x0, wy, wz), Project(cam, x0, wy + 1.5, wz),
                Project(cam, x0, wy + 1.5, wz + 1.2), Project(cam, x0, wy, wz + 1.2)},
               glass);
    }
  }
}

void DrawPole(const CameraModel& cam, const Object& o, cv::Mat& img) {
  FillPoly(img,
           {Project(cam, o.x - o.size, o.y, 0), Project(cam, o.x + o.size, o.y, 0),
            Project(cam, o.x + o.size, o.y, o.height), Project(cam, o.x - o.size, o.y, o.height)},
           o.colour);
}

void DrawSign(const CameraModel& cam, const Object& o, cv::Mat& img) {
  const double x0 = o.x, x1 = o.x + o.extra, z0 = o.height - o.size, z1 = o.height;
  const double post = 0.05;
  for (const double px : {x0 + 0.2 * o.extra, x1 - 0.2 * o.extra}) {
    FillPoly(img,
             {Project(cam, px - post, o.y, 0), Project(cam, px + post, o.y, 0),
              Project(cam, px + post, o.y, z0), Project(cam, px - post, o.y, z0)},
             cv::Scalar(120, 120, 120));
  }
  FillPoly(img,
           {Project(cam, x0, o.y, z0), Project(cam, x1, o.y, z0), Project(cam, x1, o.y, z1),
            Project(cam, x0, o.y, z1)},
           o.colour2);
  const double b = 0.08;
  FillPoly(img,
           {Project(cam, x0 + b, o.y, z0 + b), Project(cam, x1 - b, o.y, z0 + b),
            Project(cam, x1 - b, o.y, z1 - b), Project(cam, x0 + b, o.y, z1 - b)},
           o.colour);
}

// A strip along the road at `offset`, from o.y for o.extra metres, with a
// dark post every 4 m.
void DrawGuardrail(const CameraModel& cam, const Road& road, const Object& o, cv::Mat& img) {
  constexpr double kStep = 1.0, kLow = 0.45;
  for (double y = o.y; y < o.y + o.extra; y += kStep) {
    const double y1 = y + kStep;
    const double xa = road.X(o.offset, y), xb = road.X(o.offset, y1);
    if (Depth(cam, xa, y, 0) < 1.0 || Depth(cam, xb, y1, 0) < 1.0) continue;
    if (std::fmod(y - o.y, 4.0) < kStep) {
      FillPoly(img,
               {Project(cam, xa - 0.06, y, 0), Project(cam, xa + 0.06, y, 0),
                Project(cam, xa + 0.06, y, kLow), Project(cam, xa - 0.06, y, kLow)},
               o.colour2);
    }
    FillPoly(img,
             {Project(cam, xa, y, kLow), Project(cam, xb, y1, kLow), Project(cam, xb, y1, o.height),
              Project(cam, xa, y, o.height)},
             o.colour);
  }
}

void DrawObjects(const CameraModel& cam, const Road& road, std::vector<Object> objects,
                 cv::Mat& img) {
  std::stable_sort(objects.begin(), objects.end(),
                   [](const Object& a, const Object& b) { return a.y > b.y; });
  for (const Object& o : objects) {
    if (Depth(cam, o.x, o.y, 0) < 1.0 || Depth(cam, o.x, o.y, o.height) < 1.0) continue;
    switch (o.kind) {
      case Object::kVehicle:
        DrawVehicle(cam, o, img);
        break;
      case Object::kTree:
        DrawTree(cam, o, img);
        break;
      case Object::kBuilding:
        DrawBuilding(cam, o, img);
        break;
      case Object::kPole:
        DrawPole(cam, o, img);
        break;
      case Object::kSign:
        DrawSign(cam, o, img);
        break;
      case Object::kGuardrail:
        DrawGuardrail(cam, road, o, img);
        break;
    }
  }
}

void DrawHood(const CameraModel& cam, const SyntheticOptions& options, cv::Mat& img) {
  if (!(options.hood_top_row > 0)) return;
  const int w = img.cols, h = img.rows;
  // Dark paint that mirrors the bright sky at grazing angles near its edge,
  // with a soft highlight across it: smooth, and the same in every frame.
  const double depth = std::max(1.0, h - options.hood_top_row);
  for (int u = 0; u < w; ++u) {
    const double edge = HoodRow(cam, options, u);
    for (int v = std::max(0, static_cast<int>(std::floor(edge))); v < h; ++v) {
      const double cover = std::clamp(v + 0.5 - edge, 0.0, 1.0);
      if (cover <= 0) continue;
      const double d = (v - edge) / depth;
      const double grey = 34.0 + 50.0 * std::exp(-d / 0.12) +
                          22.0 * std::exp(-std::pow((d - 0.45) / 0.1, 2)) +
                          6.0 * std::abs(u - cam.cu) / std::max(1.0, 0.5 * w);
      const cv::Vec3f paint(static_cast<float>(grey * 1.04), static_cast<float>(grey),
                            static_cast<float>(grey * 0.96));
      cv::Vec3b& px = img.at<cv::Vec3b>(v, u);
      for (int c = 0; c < 3; ++c) {
        px[c] = cv::saturate_cast<uchar>((1.0 - cover) * px[c] + cover * paint[c]);
      }
    }
  }
}

double BottomDistance(const CameraModel& cam) {
  const int w = cam.image_width;
  const int h = cam.image_height;
  if (!(h - 1 > cam.HorizonRow() + 0.5)) return 0.5;
  const double yb = cam.ImageToGround({0.5 * (w - 1), h - 1.0}).y();
  return std::isfinite(yb) && yb > 0 ? yb : 0.5;
}

SyntheticFrame RenderScene(const CameraModel& camera, const SyntheticOptions& options,
                           Scene& scene) {
  const int w = camera.image_width;
  const int h = camera.image_height;
  Road& road = scene.road;
  const Look& look = scene.look;
  const bool ground_visible = h - 1 > camera.HorizonRow() + 0.5;
  const double y_bottom = BottomDistance(camera);

  // Ground truth decides which boundaries exist in the frame.
  SyntheticFrame frame;
  const double y_near = std::max({options.truth_near_m, y_bottom, 0.1});
  const double y_far = options.truth_far_m;
  for (int i = 0; i < static_cast<int>(road.boundaries.size()); ++i) {
    Boundary& m = road.boundaries[i];
    m.visible =
        ground_visible && y_near < y_far && FitTruth(camera, road, y_near, y_far, options, &m);
    if (!m.visible) continue;
    if (i == road.ego_left) frame.ego_left = static_cast<int>(frame.boundaries.size());
    if (i == road.ego_right) frame.ego_right = static_cast<int>(frame.boundaries.size());
    SyntheticBoundary out;
    out.image = m.truth.p;
    out.dashed = m.dashed;
    out.double_line = m.double_gap > 0;
    out.dots = m.dots;
    out.yellow = m.yellow;
    out.lateral_offset_m = m.offset;
    out.id = i;
    frame.boundaries.push_back(out);
  }
  for (const double edge : {road.edge_left, road.edge_right}) {
    Boundary e;
    e.offset = edge;
    if (ground_visible && y_near < y_far && FitTruth(camera, road, y_near, y_far, options, &e)) {
      frame.road_edges.push_back(e.truth.p);
    }
  }

  cv::Mat3f canvas(h, w, cv::Vec3f(look.haze));
  RenderSky(camera, look, canvas);
  // At night the air scatters no daylight onto the far road (the measured
  // light, Night, already holds what the air takes): no haze on the ground.
  Look ground_look = look;
  if (scene.night.on) ground_look.haze_dist = std::numeric_limits<double>::infinity();
  RenderGround(camera, road, ground_look, scene.shadows, canvas);
  cv::Mat img;
  canvas.convertTo(img, CV_8UC3);
  DrawObjects(camera, road, scene.objects, img);
  DrawHood(camera, options, img);
  if (scene.night.on) ApplyNight(camera, options, scene.night, look, img);
  if (options.static_overlay) DrawStaticOverlay(img);
  cv::GaussianBlur(img, img, cv::Size(3, 3), look.blur_sigma);

  // Exposure and sensor noise.
  cv::Mat f;
  // (At night the measured grey levels are the exposure: glare stays
  // saturated.)
  img.convertTo(f, CV_32FC3, scene.night.on ? 1.0 : look.gain);
  if (options.noise_sigma > 0) {
    cv::Mat noise(f.size(), CV_32FC3);
    cv::RNG cvrng(scene.noise_seed);
    if (scene.night.on) {
      // kNightNoiseGain times the noise at mid grey, as the square root of
      // the level elsewhere.
      cvrng.fill(noise, cv::RNG::NORMAL, 0.0, options.noise_sigma * kNightNoiseGain);
      cv::Mat level;
      cv::max(f, 1.0, level);
      cv::sqrt(level / 128.0, level);
      noise = noise.mul(level);
    } else {
      cvrng.fill(noise, cv::RNG::NORMAL, 0.0, options.noise_sigma);
    }
    f += noise;
  }
  f.convertTo(img, CV_8UC3);
  if (options.jpeg_quality > 0) {
    std::vector<uchar> buf;
    cv::imencode(".jpg", img, buf, {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality});
    img = cv::imdecode(buf, cv::IMREAD_COLOR);
  }
  frame.bgr = img;
  return frame;
}

}  // namespace synthetic_internal

using namespace synthetic_internal;  // NOLINT: this file's own helpers

double HoodRow(const CameraModel& camera, const SyntheticOptions& options, double u) {
  if (!(options.hood_top_row > 0)) return HUGE_VAL;
  const double side = options.hood_side_row > 0 ? options.hood_side_row : camera.image_height;
  const double half = u < camera.cu ? camera.cu : camera.image_width - 1.0 - camera.cu;
  const double t = (u - camera.cu) / std::max(1.0, half);
  return options.hood_top_row + (side - options.hood_top_row) * t * t;
}

absl::StatusOr<HoodRows> HoodRowsAtDistance(const CameraModel& camera, double edge_m) {
  if (absl::Status s = camera.Validate(); !s.ok()) return s;
  if (!(edge_m > 0 && edge_m <= 100)) {
    return absl::InvalidArgumentError(
        absl::StrCat("the hood's edge must be in (0, 100] metres ahead, not ", edge_m));
  }
  const double top = camera.GroundToImage({0.0, edge_m}).y();
  if (!std::isfinite(top) || !(top > camera.HorizonRow())) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the hood's edge ", edge_m, " m ahead is not on the camera's road (below its horizon)"));
  }
  // Nearer than the image's bottom row the hood is out of view: its rows
  // then lie just below the image.
  HoodRows rows;
  rows.top_row = std::clamp(top, 1.0, static_cast<double>(camera.image_height));
  rows.side_row = rows.top_row + 0.05 * camera.image_height;
  return rows;
}

absl::StatusOr<SyntheticFrame> RenderSyntheticFrame(const CameraModel& camera,
                                                    const SyntheticOptions& options,
                                                    uint64_t seed) {
  if (absl::Status s = camera.Validate(); !s.ok()) return s;
  if (absl::Status s = ValidateOptions(options); !s.ok()) return s;
  Rng rng(seed);
  Scene scene;
  scene.road = SampleRoad(options, rng);
  scene.look = SampleLook(rng, camera.image_height);
  const double y_bottom = BottomDistance(camera);
  scene.shadows = SampleShadows(options, scene.road, y_bottom, rng);
  scene.objects = SampleObjects(options, scene.road, y_bottom, rng);
  scene.noise_seed = rng();
  Rng clutter(seed ^ 0x9e3779b97f4a7c15ULL);
  AddClutter(options, y_bottom, clutter, &scene.road, &scene.objects);
  if (options.concrete || options.botts_dots_probability > 0) {
    Rng dots(seed ^ 0xb0775d075ULL);
    AddBottsDots(options, camera.height_m, dots, &scene.road, &scene.look);
  }
  if (options.night) {
    scene.night = SampleNight(camera, scene.road, clutter);
    scene.shadows.clear();  // no sun
  }
  return RenderScene(camera, options, scene);
}

}  // namespace lane
