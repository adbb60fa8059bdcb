#include "lane/eval/paper_results.h"

#include <cmath>

namespace lane::eval {
namespace {

struct Row {
  const char* clip;
  int frames;
  int total;
  int detected;
  double correct_percent;
  double fp_percent;
  double fp_per_frame;
};

// Aly 2008, Table II (2-lanes mode) and Table III (all-lanes); frame counts
// from Table I.
constexpr Row kTwoLanes[] = {
    {"cordova1", 250, 466, 467, 97.21, 3.00, 0.056},
    {"cordova2", 406, 472, 631, 96.16, 38.38, 0.443},
    {"washington1", 336, 639, 645, 96.70, 4.72, 0.089},
    {"washington2", 232, 452, 440, 95.13, 2.21, 0.043},
};
constexpr Row kAllLanes[] = {
    {"cordova1", 250, 919, 842, 91.62, 5.66, 0.208},
    {"cordova2", 406, 1048, 1322, 85.50, 40.64, 1.049},
    {"washington1", 336, 1274, 1349, 92.78, 13.11, 0.497},
    {"washington2", 232, 931, 952, 93.66, 8.59, 0.345},
};

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

double PaperResult::Precision() const {
  const double correct = correct_rate * total;
  const double fp = false_positive_rate * total;
  return correct + fp > 0 ? correct / (correct + fp) : std::nan("");
}

double PaperResult::F1() const {
  const double p = Precision();
  const double r = correct_rate;
  return p + r > 0 ? 2 * p * r / (p + r) : std::nan("");
}

std::optional<PaperResult> PaperResultForClip(const std::string& clip_name, Mode mode) {
  // The last path component: "caltech/cordova1" -> "cordova1".
  const size_t slash = clip_name.find_last_of('/');
  const std::string name = slash == std::string::npos ? clip_name : clip_name.substr(slash + 1);
  for (const Row& r : mode == Mode::kTwo ? kTwoLanes : kAllLanes) {
    // "cordova1" must not match "xcordova1" glued to another word: the name
    // is the clip, or ends in "-cordova1" / "_cordova1".
    const std::string clip = r.clip;
    const bool match = name == clip || EndsWith(name, "-" + clip) || EndsWith(name, "_" + clip);
    if (!match) continue;
    PaperResult out;
    out.clip = clip;
    out.frames = r.frames;
    out.total = r.total;
    out.detected = r.detected;
    out.correct_rate = r.correct_percent / 100;
    out.false_positive_rate = r.fp_percent / 100;
    out.fp_per_frame = r.fp_per_frame;
    return out;
  }
  return std::nullopt;
}

}  // namespace lane::eval
