// The road model's second search (all-lanes mode, steps 7b-8): where the
// boundaries found put a boundary that is missing (half-way across a
// two-lane gap, one lane width outside the outermost), the stage
// "postprocess" searches again inside a window around it; boundaries the
// road model infers as hidden are added, marked `inferred`
// (lane/detector/road_model.h).
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "pipeline.h"

namespace lane::pipeline {
namespace {

// Windows (DetectionPrior form) for a second search, around where the road
// model puts a boundary that `lanes` lack: half-way across a two-lane gap
// (search_hidden) and one lane width outside the outermost (search_outer).
DetectionPrior RoadModelWindows(const StageEnv& env, const std::vector<Lane>& lanes) {
  DetectionPrior windows;
  RoadModelOptions model = env.options.road_model;
  if (env.options.mode != Mode::kAll || (!model.search_hidden && !model.search_outer) ||
      lanes.empty()) {
    return windows;
  }
  std::vector<Bezier> ground;
  ground.reserve(lanes.size());
  for (const Lane& lane : lanes) ground.push_back(Bezier{lane.ground});
  model.infer_hidden = true;  // where to search, whether or not inferred lanes are reported
  std::vector<Bezier> places;
  if (model.search_hidden) {
    for (const InferredBoundary& h : InferHiddenBoundaries(ground, model)) {
      places.push_back(h.ground);
    }
  }
  if (model.search_outer) {
    for (const Bezier& b : OuterBoundaryGuesses(ground, model)) places.push_back(b);
  }
  for (const Bezier& place : places) {
    const std::optional<LateralProfile> profile = LateralProfile::FromGround(place);
    if (!profile) continue;
    const double y0 = std::max(profile->y_near(), env.ipm.y_min());
    const double y1 = std::min(profile->y_far(), env.ipm.y_max());
    if (y1 - y0 < 1.0) continue;
    const Eigen::Vector2d a = env.ipm.GroundToIpm({profile->XAt(y0), y0});
    const Eigen::Vector2d b = env.ipm.GroundToIpm({profile->XAt(y1), y1});
    if (!a.allFinite() || !b.allFinite() || std::abs(a.y() - b.y()) < 1.0) continue;
    const std::optional<IpmLine> line = MakeIpmLine(a, b - a, env.ipm.height());
    if (!line) continue;
    DetectionPrior::Window w;
    w.line = *line;
    w.half_width_m = model.search_half_width_m;
    windows.windows.push_back(w);
  }
  return windows;
}

// `filtered` thresholded inside each window at the window's own quantile
// (and zero outside): a faint line between strong ones stands out there.
cv::Mat ThresholdInWindows(const StageEnv& env, const cv::Mat& filtered,
                           const DetectionPrior& windows, float frame_threshold) {
  cv::Mat out = cv::Mat::zeros(filtered.size(), CV_32F);
  const cv::Mat& valid = env.ipm.valid_mask();
  const double mpp_x = env.ipm.metres_per_px_x();
  std::vector<float> values;
  for (const DetectionPrior::Window& w : windows.windows) {
    const double half_px = w.half_width_m / mpp_x;
    auto span = [&](int r) {
      const double x = w.line.XAt(r);
      return std::pair<int, int>{std::max(0, static_cast<int>(std::ceil(x - half_px))),
                                 std::min(filtered.cols - 1, static_cast<int>(x + half_px))};
    };
    values.clear();
    for (int r = 0; r < filtered.rows; ++r) {
      const auto [c0, c1] = span(r);
      const float* f = filtered.ptr<float>(r);
      const uchar* v = valid.ptr<uchar>(r);
      for (int c = c0; c <= c1; ++c) {
        if (v[c] != 0) values.push_back(f[c]);
      }
    }
    if (values.size() < 16) continue;
    const float local =
        std::max(Quantile(values, env.options.road_model.search_quantile),
                 static_cast<float>(env.options.road_model.search_min_fraction * frame_threshold));
    for (int r = 0; r < filtered.rows; ++r) {
      const auto [c0, c1] = span(r);
      const float* f = filtered.ptr<float>(r);
      const uchar* v = valid.ptr<uchar>(r);
      float* o = out.ptr<float>(r);
      for (int c = c0; c <= c1; ++c) {
        if (v[c] != 0 && f[c] > local && f[c] > 0) o[c] = f[c];
      }
    }
  }
  return out;
}

}  // namespace

void SearchRoadModelWindows(const StageEnv& env, FrameContext& f, const PostprocessFrame& images,
                            std::vector<Lane>& lanes) {
  const DetectorOptions& opt = env.options;
  const DetectionPrior hidden = RoadModelWindows(env, lanes);
  if (hidden.windows.empty()) return;
  const cv::Mat local = ThresholdInWindows(env, f.filtered, hidden, f.threshold);
  const PriorLines more = FindPriorLines(env, local, hidden, f.lines, f.rng);
  if (more.lines.empty()) return;
  const std::vector<SplineCandidate> extra =
      FitSplines(env, local, more.lines, more.half_widths_px, f.rng);
  const std::vector<Lane> seen =
      ToLanes(env, PostprocessCandidates(extra, images, opt.postprocess, opt.filter.marking_width_m,
                                         opt.spline_ransac.merge_distance_px));
  // What survives the same post-processing is kept where it fits the road.
  std::vector<Bezier> found;
  for (const Lane& lane : lanes) found.push_back(Bezier{lane.ground});
  const size_t first = lanes.size();
  for (const Lane& lane : seen) {
    if (!FitsRoadModel(Bezier{lane.ground}, found, env.ipm.y_min(), env.ipm.y_max(),
                       opt.road_model)) {
      continue;
    }
    lanes.push_back(lane);
    found.push_back(Bezier{lane.ground});
  }
  if (lanes.size() > first) SortLeftToRight(lanes);
}

void AddInferredLanes(const StageEnv& env, std::vector<Lane>& lanes) {
  // Off (the default) or 2-lanes: nothing to do on this frame's path.
  if (env.options.mode != Mode::kAll || !env.options.road_model.infer_hidden) return;
  std::vector<Bezier> ground;
  ground.reserve(lanes.size());
  for (const Lane& lane : lanes) ground.push_back(Bezier{lane.ground});
  const std::vector<InferredBoundary> hidden =
      InferHiddenBoundaries(ground, env.options.road_model);
  if (hidden.empty()) return;
  const CameraModel& cam = env.ipm.camera();
  const IpmMapping& ipm = env.ipm;
  for (const InferredBoundary& h : hidden) {
    const auto image_fit =
        MapSpline(h.ground, 21, [&cam](const Eigen::Vector2d& p) { return cam.GroundToImage(p); });
    if (!image_fit) continue;
    const auto ipm_fit =
        MapSpline(*image_fit, 21, [&ipm](const Eigen::Vector2d& p) { return ipm.ImageToIpm(p); });
    if (!ipm_fit) continue;
    Lane lane;
    lane.image = image_fit->p;
    lane.ipm = ipm_fit->p;
    lane.ground = h.ground.p;
    lane.score = std::min(lanes[static_cast<size_t>(h.left)].score,
                          lanes[static_cast<size_t>(h.right)].score);
    lane.inferred = true;
    lanes.push_back(lane);
  }
  SortLeftToRight(lanes);
}

}  // namespace lane::pipeline
