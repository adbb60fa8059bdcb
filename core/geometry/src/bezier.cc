#include "lane/geometry/bezier.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace lane {
namespace {

// The paper's basis matrix M: Q(t) = [t^3 t^2 t 1] M P.
const Eigen::Matrix4d& BasisMatrix() {
  static const Eigen::Matrix4d m = (Eigen::Matrix4d() << -1, 3, -3, 1,  //
                                    3, -6, 3, 0,                        //
                                    -3, 3, 0, 0,                        //
                                    1, 0, 0, 0)
                                       .finished();
  return m;
}

}  // namespace

Eigen::Vector2d Bezier::Eval(double t) const {
  const double s = 1.0 - t;
  return s * s * s * p[0] + 3 * s * s * t * p[1] + 3 * s * t * t * p[2] + t * t * t * p[3];
}

Eigen::Vector2d Bezier::Derivative(double t) const {
  const double s = 1.0 - t;
  return 3 * s * s * (p[1] - p[0]) + 6 * s * t * (p[2] - p[1]) + 3 * t * t * (p[3] - p[2]);
}

std::vector<Eigen::Vector2d> Bezier::Sample(int n) const {
  n = std::max(n, 2);
  std::vector<Eigen::Vector2d> out(n);
  for (int i = 0; i < n; ++i) out[i] = Eval(static_cast<double>(i) / (n - 1));
  return out;
}

double Bezier::Length(int n) const {
  const auto pts = Sample(n);
  double len = 0;
  for (size_t i = 1; i < pts.size(); ++i) len += (pts[i] - pts[i - 1]).norm();
  return len;
}

double Bezier::Straightness() const {
  // Mean cosine of the angles between legs P0P1/P1P2 and P1P2/P2P3. A leg of
  // zero length has no direction and does not bend the spline.
  double sum = 0;
  for (int i = 0; i < 2; ++i) {
    const Eigen::Vector2d a = p[i + 1] - p[i];
    const Eigen::Vector2d b = p[i + 2] - p[i + 1];
    const double na = a.norm();
    const double nb = b.norm();
    sum += (na < 1e-9 || nb < 1e-9) ? 1.0 : a.dot(b) / (na * nb);
  }
  return sum / 2.0;
}

Bezier Bezier::Line(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return Bezier{{a, a + (b - a) / 3.0, a + 2.0 * (b - a) / 3.0, b}};
}

std::optional<std::vector<double>> ChordLengthParams(const std::vector<Eigen::Vector2d>& pts) {
  if (pts.empty()) return std::nullopt;
  std::vector<double> t(pts.size(), 0.0);
  for (size_t i = 1; i < pts.size(); ++i) t[i] = t[i - 1] + (pts[i] - pts[i - 1]).norm();
  const double total = t.back();
  if (!(total > 1e-12)) return std::nullopt;
  for (double& v : t) v /= total;
  return t;
}

std::optional<Bezier> FitBezier(const std::vector<Eigen::Vector2d>& pts) {
  if (pts.size() < 4) return std::nullopt;
  // Chord-length parameters, computed in place (this runs once per RANSAC
  // trial; ChordLengthParams() allocates).
  thread_local std::vector<double> t_store;
  std::vector<double>& t_values = t_store;
  t_values.resize(pts.size());
  t_values[0] = 0;
  for (size_t i = 1; i < pts.size(); ++i) {
    t_values[i] = t_values[i - 1] + (pts[i] - pts[i - 1]).norm();
  }
  const double total = t_values.back();
  if (!(total > 1e-12)) return std::nullopt;
  for (double& v : t_values) v /= total;
  const std::vector<double>* t = &t_values;
  // P = (T M)^+ Q, the least-squares control points (paper, section II-D).
  Eigen::Matrix<double, 4, 2> cp;
  if (pts.size() == 4) {
    // The RANSAC case: T M is square, and when it is invertible its
    // pseudo-inverse is its inverse (4x4 closed form, no decomposition).
    Eigen::Matrix4d a;
    Eigen::Matrix<double, 4, 2> q;
    for (int i = 0; i < 4; ++i) {
      const double ti = (*t)[i];
      a.row(i) = Eigen::RowVector4d(ti * ti * ti, ti * ti, ti, 1.0) * BasisMatrix();
      q.row(i) = pts[i].transpose();
    }
    Eigen::Matrix4d inv;
    bool invertible = false;
    a.computeInverseWithCheck(inv, invertible, 1e-12);
    cp = invertible
             ? Eigen::Matrix<double, 4, 2>(inv * q)
             : Eigen::Matrix<double, 4, 2>(a.completeOrthogonalDecomposition().pseudoInverse() * q);
  } else {
    // Through the 4x4 normal matrix: pinv(A) Q = pinv(A^T A) A^T Q, which
    // keeps every matrix fixed-size.
    Eigen::Matrix4d ata = Eigen::Matrix4d::Zero();
    Eigen::Matrix<double, 4, 2> atq = Eigen::Matrix<double, 4, 2>::Zero();
    for (size_t i = 0; i < pts.size(); ++i) {
      const double ti = (*t)[i];
      const Eigen::RowVector4d a =
          Eigen::RowVector4d(ti * ti * ti, ti * ti, ti, 1.0) * BasisMatrix();
      ata.noalias() += a.transpose() * a;
      atq.noalias() += a.transpose() * pts[i].transpose();
    }
    // A^T A is symmetric positive definite when the points have at least
    // four distinct parameters: a Cholesky solve then gives the same
    // least-squares solution as the pseudo-inverse, at a twentieth of the
    // cost of the complete orthogonal decomposition (this runs a few
    // thousand times per frame, once for every refit). Cholesky's pivots
    // (the squares of L's diagonal) bound the conditioning; when the
    // smallest is below 1e-12 of the largest (L's diagonal below 1e-6), the
    // matrix is treated as singular and the pseudo-inverse gives the
    // minimum-norm solution instead.
    const Eigen::LLT<Eigen::Matrix4d> llt(ata);
    const Eigen::Vector4d l_diagonal = llt.matrixLLT().diagonal();
    if (llt.info() == Eigen::Success && l_diagonal.minCoeff() > 1e-6 * l_diagonal.maxCoeff()) {
      cp = llt.solve(atq);
    } else {
      cp = ata.completeOrthogonalDecomposition().pseudoInverse() * atq;
    }
  }
  Bezier b;
  for (int i = 0; i < 4; ++i) {
    b.p[i] = Eigen::Vector2d(cp(i, 0), cp(i, 1));
    if (!b.p[i].allFinite()) return std::nullopt;
  }
  return b;
}

std::vector<double> NearestPointDistances(const std::vector<Eigen::Vector2d>& from,
                                          const std::vector<Eigen::Vector2d>& to) {
  std::vector<double> out;
  out.reserve(from.size());
  for (const auto& p : from) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& q : to) best = std::min(best, (p - q).squaredNorm());
    out.push_back(std::sqrt(best));
  }
  return out;
}

double MeanNearestDistance(const Bezier& a, const Bezier& b) {
  const bool a_shorter = a.Length() < b.Length();
  const std::vector<double> d =
      NearestPointDistances((a_shorter ? a : b).Sample(21), (a_shorter ? b : a).Sample(101));
  double sum = 0;
  for (const double v : d) sum += v;
  return sum / d.size();
}

bool MeanNearestDistanceBelow(const Bezier& a, const Bezier& b, double limit) {
  Eigen::Vector2d a_min = a.p[0], a_max = a.p[0], b_min = b.p[0], b_max = b.p[0];
  for (int i = 1; i < 4; ++i) {
    a_min = a_min.cwiseMin(a.p[i]);
    a_max = a_max.cwiseMax(a.p[i]);
    b_min = b_min.cwiseMin(b.p[i]);
    b_max = b_max.cwiseMax(b.p[i]);
  }
  const double gap_x = std::max({0.0, a_min.x() - b_max.x(), b_min.x() - a_max.x()});
  const double gap_y = std::max({0.0, a_min.y() - b_max.y(), b_min.y() - a_max.y()});
  if (std::hypot(gap_x, gap_y) >= limit) return false;
  return MeanNearestDistance(a, b) < limit;
}

double AngleFromVerticalDeg(const Eigen::Vector2d& d) {
  constexpr double kRadToDeg = 180.0 / M_PI;
  return std::atan2(std::abs(d.x()), std::abs(d.y())) * kRadToDeg;
}

Bezier TopDown(Bezier s) {
  if (s.p[0].y() > s.p[3].y()) {
    std::swap(s.p[0], s.p[3]);
    std::swap(s.p[1], s.p[2]);
  }
  return s;
}

double CurveDistance(const Bezier& a, const Bezier& b, int n) {
  const auto pa = a.Sample(n);
  const auto pb = b.Sample(n);
  double worst = 0;
  for (const double d : NearestPointDistances(pa, pb)) worst = std::max(worst, d);
  for (const double d : NearestPointDistances(pb, pa)) worst = std::max(worst, d);
  return worst;
}

}  // namespace lane
