#include "lane/track/ego_lane.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace lane {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

}  // namespace

std::optional<EgoLane> ComputeEgoLane(const std::vector<Lane>& lanes, const CameraModel& camera,
                                      const EgoOptions& options) {
  std::vector<std::optional<GroundCurve>> curves;
  for (const Lane& lane : lanes) curves.push_back(FitGroundCurve(lane));
  return EgoLaneOfCurves(curves, /*ids=*/{}, camera, options);
}

std::optional<EgoLane> EgoLaneOfCurves(const std::vector<std::optional<GroundCurve>>& given,
                                       const std::vector<int>& ids, const CameraModel& camera,
                                       const EgoOptions& options,
                                       const std::vector<Eigen::Matrix3d>* covariances) {
  std::vector<std::optional<GroundCurve>> curves = given;
  if (covariances != nullptr && covariances->size() == curves.size()) {
    // Shared heading and curvature: the information-weighted mean of the
    // lanes' (heading, curvature) ...
    Eigen::Matrix2d info = Eigen::Matrix2d::Zero();
    Eigen::Vector2d weighted = Eigen::Vector2d::Zero();
    for (size_t i = 0; i < curves.size(); ++i) {
      if (!curves[i]) continue;
      const Eigen::Matrix2d p = (*covariances)[i].bottomRightCorner<2, 2>();
      if (std::abs(p.determinant()) < 1e-30) continue;
      const Eigen::Matrix2d w = p.inverse();
      info += w;
      weighted += w * curves[i]->coefficients.tail<2>();
    }
    if (std::abs(info.determinant()) > 1e-30) {
      const Eigen::Vector2d shared = info.inverse() * weighted;
      // ... and each offset given them (Gaussian conditioning).
      for (size_t i = 0; i < curves.size(); ++i) {
        if (!curves[i]) continue;
        const Eigen::Matrix3d& p = (*covariances)[i];
        const Eigen::Matrix2d pss = p.bottomRightCorner<2, 2>();
        if (std::abs(pss.determinant()) < 1e-30) continue;
        const Eigen::Vector2d delta = shared - curves[i]->coefficients.tail<2>();
        curves[i]->coefficients(0) += (p.block<1, 2>(0, 1) * pss.inverse() * delta)(0);
        curves[i]->coefficients.tail<2>() = shared;
      }
    }
  }
  int left = -1, right = -1;
  double xl = -1e9, xr = 1e9;
  for (size_t i = 0; i < curves.size(); ++i) {
    if (!curves[i]) continue;
    const double x0 = curves[i]->X(0.0);
    if (x0 < 0 && x0 > xl) {
      xl = x0;
      left = static_cast<int>(i);
    }
    if (x0 >= 0 && x0 < xr) {
      xr = x0;
      right = static_cast<int>(i);
    }
  }
  if (left < 0 || right < 0) return std::nullopt;
  const double width = xr - xl;
  if (width < options.min_width_m || width > options.max_width_m) return std::nullopt;
  const GroundCurve& l = *curves[static_cast<size_t>(left)];
  const GroundCurve& r = *curves[static_cast<size_t>(right)];
  EgoLane ego;
  ego.width_m = width;
  ego.offset_m = -0.5 * (xl + xr);
  ego.heading_deg =
      std::atan(0.5 * (l.coefficients(1) + r.coefficients(1))) * kRadToDeg - camera.yaw_deg;
  ego.curvature_per_m = 0.5 * (l.coefficients(2) + r.coefficients(2));
  ego.left_index = left;
  ego.right_index = right;
  ego.left_id = static_cast<size_t>(left) < ids.size() ? ids[static_cast<size_t>(left)] : -1;
  ego.right_id = static_cast<size_t>(right) < ids.size() ? ids[static_cast<size_t>(right)] : -1;
  ego.left_distance_m = -xl;
  ego.right_distance_m = xr;
  return ego;
}

void EgoTracker::Reset() { history_.clear(); }

std::optional<EgoLane> EgoTracker::Update(std::optional<EgoLane> ego, double time_s) {
  // A frame without the ego lane keeps the history: the window drops what
  // is too old.
  if (!ego) return ego;
  if (!history_.empty() && time_s <= history_.back().first) history_.clear();
  if (!history_.empty()) {
    // A lane change: the new lane's left boundary is the old one's right
    // (moving right), or its right the old left (moving left). The offset
    // jumps by the width; the history shifts with it, so that the rate
    // goes on. Other pairs of boundaries (or, without ids, a jump of half a
    // lane) start the rate again.
    const bool ids = ego->left_id >= 0 && ego->right_id >= 0;
    double shift = 0;
    bool keep = true;
    if (ids) {
      if (ego->left_id == right_id_ && ego->left_id != left_id_) {
        shift = -ego->width_m;
      } else if (ego->right_id == left_id_ && ego->right_id != right_id_) {
        shift = ego->width_m;
      } else {
        keep = ego->left_id == left_id_ && ego->right_id == right_id_;
      }
    } else {
      keep = std::abs(ego->offset_m - history_.back().second) < 0.5 * ego->width_m;
    }
    if (!keep) history_.clear();
    for (auto& entry : history_) entry.second += shift;
  }
  history_.emplace_back(time_s, ego->offset_m);
  while (history_.front().first < time_s - options_.rate_window_s) history_.pop_front();
  left_id_ = ego->left_id;
  right_id_ = ego->right_id;
  // Least-squares slope of the offset over the window, in time from this
  // frame: capture times are Unix seconds (1.7e9), whose squares hold no
  // fraction of a second in a double.
  double rate = 0;
  const double span = history_.back().first - history_.front().first;
  if (history_.size() >= 4 && span >= 0.2) {
    double st = 0, so = 0, stt = 0, sto = 0;
    for (const auto& [at, o] : history_) {
      const double t = at - time_s;
      st += t;
      so += o;
      stt += t * t;
      sto += t * o;
    }
    const double n = static_cast<double>(history_.size());
    const double var = stt / n - (st / n) * (st / n);
    if (var > 0) rate = (sto / n - (st / n) * (so / n)) / var;
  }
  ego->offset_rate_mps = rate;
  const double min_rate = options_.departure_min_rate_mps;
  ego->departing = (rate > min_rate && ego->right_distance_m / rate < options_.departure_tlc_s) ||
                   (rate < -min_rate && ego->left_distance_m / -rate < options_.departure_tlc_s);
  return ego;
}

}  // namespace lane
