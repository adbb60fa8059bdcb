#include "lane/eval/dataset.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <system_error>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "lane/eval/caltech.h"
#include "lane/eval/culane.h"
#include "lane/eval/render_labels.h"
#include "lane/eval/tusimple.h"

namespace lane::eval {
namespace {

namespace fs = std::filesystem;

constexpr char kCcvl[] = "labels.ccvl";
constexpr char kRenderLabels[] = "labels.jsonl";
constexpr char kCulaneSuffix[] = ".lines.txt";
// How deep below the data set folder CULane clips are looked for
// (driver_161_90frame/06030819_0755.MP4/ is 2 levels).
constexpr int kMaxCulaneDepth = 4;

bool IsFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

// Sorted entries of a folder that pass `keep`.
template <class Keep>
std::vector<fs::path> List(const fs::path& dir, Keep keep) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (keep(it->path())) out.push_back(it->path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<fs::path> Subfolders(const fs::path& dir) {
  return List(dir, [](const fs::path& p) {
    std::error_code ec;
    return fs::is_directory(p, ec);
  });
}

bool IsImage(const fs::path& p) {
  const std::string ext = absl::AsciiStrToLower(p.extension().string());
  return (ext == ".jpg" || ext == ".jpeg" || ext == ".png") && IsFile(p);
}

bool HasCulaneLabels(const fs::path& dir) {
  return !List(dir, [](const fs::path& p) {
            return absl::EndsWith(p.filename().string(), kCulaneSuffix) && IsFile(p);
          }).empty();
}

void FindCulaneClips(const fs::path& dir, int depth, std::vector<fs::path>* out) {
  if (HasCulaneLabels(dir)) out->push_back(dir);
  if (depth >= kMaxCulaneDepth) return;
  for (const fs::path& sub : Subfolders(dir)) FindCulaneClips(sub, depth + 1, out);
}

bool FirstLineLooksLikeTusimple(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (!absl::StripAsciiWhitespace(line).empty()) return LooksLikeTusimple(line);
  }
  return false;
}

std::vector<fs::path> TusimpleFiles(const fs::path& dir) {
  return List(dir, [](const fs::path& p) {
    return absl::AsciiStrToLower(p.extension().string()) == ".json" && IsFile(p) &&
           FirstLineLooksLikeTusimple(p);
  });
}

// Clip folders: the root itself when it holds `file`, else its subfolders
// that do.
std::vector<fs::path> FoldersWith(const fs::path& root, const char* file) {
  if (IsFile(root / file)) return {root};
  std::vector<fs::path> out;
  for (const fs::path& sub : Subfolders(root)) {
    if (IsFile(sub / file)) out.push_back(sub);
  }
  return out;
}

// `p` relative to `root` with '/' separators; "" for the root itself.
std::string Relative(const fs::path& p, const fs::path& root) {
  const std::string rel =
      p.lexically_normal().lexically_relative(root.lexically_normal()).generic_string();
  return rel == "." ? std::string() : rel;
}

std::string Join(const std::string& folder, const std::string& file) {
  return folder.empty() ? file : absl::StrCat(folder, "/", file);
}

std::string FolderName(const fs::path& root) {
  fs::path p = fs::absolute(root).lexically_normal();
  if (p.filename().empty()) p = p.parent_path();
  const std::string name = p.filename().string();
  return name.empty() ? std::string("dataset") : name;
}

std::string ClipName(const fs::path& dir, const fs::path& root) {
  const std::string rel = Relative(dir, root);
  return rel.empty() ? FolderName(root) : rel;
}

absl::StatusOr<Clip> LoadCaltechClip(const fs::path& dir, const fs::path& root,
                                     std::vector<std::string>* warnings) {
  const std::string ccvl_path = (dir / kCcvl).string();
  absl::StatusOr<std::vector<CcvlFrame>> ccvl = ReadCcvl(ccvl_path);
  if (!ccvl.ok()) return ccvl.status();
  // Labels by the name written in the file and by its file name.
  std::map<std::string, size_t> by_name;
  std::map<std::string, std::vector<size_t>> by_file;
  for (size_t i = 0; i < ccvl->size(); ++i) {
    by_name.emplace((*ccvl)[i].frame, i);
    by_file[fs::path((*ccvl)[i].frame).filename().string()].push_back(i);
  }
  std::vector<std::string> entries;
  const fs::path list_path = dir / "list.txt";
  if (IsFile(list_path)) {
    absl::StatusOr<std::vector<std::string>> list = ReadImageList(list_path.string());
    if (!list.ok()) return list.status();
    entries = std::move(*list);
  } else {
    for (const CcvlFrame& f : *ccvl) entries.push_back(f.frame);
  }
  Clip clip;
  clip.name = ClipName(dir, root);
  std::set<size_t> used;
  int unlabelled = 0;
  std::string first_unlabelled;
  for (const std::string& entry : entries) {
    // list.txt entries are relative to the clip folder; some lists name the
    // clip folder too ("cordova1/f00000.png"), i.e. are relative to its parent.
    fs::path image = dir / entry;
    if (!IsFile(image) && IsFile(dir.parent_path() / entry)) image = dir.parent_path() / entry;
    LabelledFrame frame;
    frame.image_path = image.lexically_normal().string();
    const std::string rel = Relative(image, root);
    frame.name =
        rel.empty() || absl::StartsWith(rel, "..") ? Join(Relative(dir, root), entry) : rel;
    std::optional<size_t> index;
    if (const auto it = by_name.find(entry); it != by_name.end()) {
      index = it->second;
    } else if (const auto f = by_file.find(fs::path(entry).filename().string());
               f != by_file.end() && f->second.size() == 1) {
      index = f->second.front();
    }
    if (index) {
      frame.boundaries = (*ccvl)[*index].labels;
      used.insert(*index);
    } else {
      frame.labelled = false;
      if (unlabelled++ == 0) first_unlabelled = entry;
    }
    clip.frames.push_back(std::move(frame));
  }
  if (unlabelled > 0) {
    warnings->push_back(absl::StrCat(ccvl_path, ": no labels for ", unlabelled,
                                     " listed frame(s), e.g. ", first_unlabelled,
                                     " (run, not scored)"));
  }
  if (used.size() < ccvl->size()) {
    warnings->push_back(absl::StrCat(ccvl_path, ": ", ccvl->size() - used.size(),
                                     " labelled frame(s) are not in list.txt (ignored)"));
  }
  return clip;
}

absl::StatusOr<Clip> LoadCulaneClip(const fs::path& dir, const fs::path& root,
                                    std::vector<std::string>* warnings) {
  Clip clip;
  clip.name = ClipName(dir, root);
  const std::string folder = Relative(dir, root);
  std::set<std::string> label_files;
  for (const fs::path& p : List(dir, [](const fs::path& p) {
         return absl::EndsWith(p.filename().string(), kCulaneSuffix) && IsFile(p);
       })) {
    label_files.insert(p.filename().string());
  }
  for (const fs::path& image : List(dir, IsImage)) {
    const std::string file = image.filename().string();
    LabelledFrame frame;
    frame.name = Join(folder, file);
    frame.image_path = image.string();
    const std::string label_file = CulaneLabelName(file);
    if (label_files.erase(label_file) > 0) {
      absl::StatusOr<std::vector<Curve>> lanes = ReadCulaneLines((dir / label_file).string());
      if (!lanes.ok()) return lanes.status();
      for (Curve& c : *lanes) frame.boundaries.push_back({std::move(c), ""});
    } else {
      frame.labelled = false;
    }
    clip.frames.push_back(std::move(frame));
  }
  if (!label_files.empty()) {
    warnings->push_back(absl::StrCat(dir.string(), ": ", label_files.size(),
                                     " .lines.txt file(s) without an image, e.g. ",
                                     *label_files.begin(), " (ignored)"));
  }
  return clip;
}

absl::StatusOr<Clip> LoadTusimpleClip(const fs::path& file, const fs::path& root) {
  absl::StatusOr<std::vector<TusimpleFrame>> frames = ReadTusimpleLabels(file.string());
  if (!frames.ok()) return frames.status();
  Clip clip;
  clip.name = file.stem().string();
  for (TusimpleFrame& f : *frames) {
    LabelledFrame frame;
    frame.name = fs::path(f.raw_file).lexically_normal().generic_string();
    frame.image_path = (root / f.raw_file).lexically_normal().string();
    for (Curve& c : f.lanes) frame.boundaries.push_back({std::move(c), ""});
    clip.frames.push_back(std::move(frame));
  }
  return clip;
}

absl::StatusOr<Clip> LoadRenderClip(const fs::path& dir, const fs::path& root) {
  absl::StatusOr<std::vector<LabelledFrame>> frames =
      ReadRenderLabels((dir / kRenderLabels).string());
  if (!frames.ok()) return frames.status();
  Clip clip;
  clip.name = ClipName(dir, root);
  const std::string folder = Relative(dir, root);
  for (LabelledFrame& frame : *frames) {
    frame.image_path = (dir / frame.name).string();
    frame.name = Join(folder, frame.name);
    clip.frames.push_back(std::move(frame));
  }
  return clip;
}

}  // namespace

const char* DatasetFormatName(DatasetFormat format) {
  switch (format) {
    case DatasetFormat::kCaltech:
      return "caltech";
    case DatasetFormat::kCulane:
      return "culane";
    case DatasetFormat::kTusimple:
      return "tusimple";
    case DatasetFormat::kRender:
      return "render";
  }
  return "unknown";
}

std::optional<DatasetFormat> ParseDatasetFormat(const std::string& name) {
  for (DatasetFormat f : {DatasetFormat::kCaltech, DatasetFormat::kCulane, DatasetFormat::kTusimple,
                          DatasetFormat::kRender}) {
    if (name == DatasetFormatName(f)) return f;
  }
  return std::nullopt;
}

int Dataset::FrameCount() const {
  int n = 0;
  for (const Clip& c : clips) n += static_cast<int>(c.frames.size());
  return n;
}

absl::StatusOr<DatasetFormat> DetectDatasetFormat(const std::string& root_name) {
  const fs::path root(root_name);
  std::error_code ec;
  if (!fs::is_directory(root, ec)) {
    return absl::NotFoundError(absl::StrCat("no such folder: ", root_name));
  }
  if (!FoldersWith(root, kCcvl).empty()) return DatasetFormat::kCaltech;
  if (!FoldersWith(root, kRenderLabels).empty()) return DatasetFormat::kRender;
  std::vector<fs::path> culane;
  FindCulaneClips(root, 0, &culane);
  if (!culane.empty()) return DatasetFormat::kCulane;
  if (!TusimpleFiles(root).empty()) return DatasetFormat::kTusimple;
  return absl::InvalidArgumentError(absl::StrCat(
      "cannot tell the format of ", root_name,
      ": found no labels.ccvl (Caltech Lanes), labels.jsonl (lane render), *.lines.txt "
      "(CULane) or TuSimple .json label file, in it or in its subfolders"));
}

RepeatedLabels FindRepeatedLabels(const Clip& clip) {
  RepeatedLabels r;
  const LabelledFrame* previous = nullptr;
  for (size_t i = 0; i < clip.frames.size(); ++i) {
    const LabelledFrame& frame = clip.frames[i];
    if (!frame.labelled || frame.boundaries.empty()) continue;
    ++r.labelled;
    if (previous && previous->boundaries.size() == frame.boundaries.size() &&
        std::equal(frame.boundaries.begin(), frame.boundaries.end(), previous->boundaries.begin(),
                   [](const LabelledBoundary& a, const LabelledBoundary& b) {
                     return a.curve.kind == b.curve.kind && a.curve.points == b.curve.points;
                   })) {
      r.indices.push_back(i);
    }
    previous = &frame;
  }
  return r;
}

absl::StatusOr<Dataset> LoadDataset(const std::string& root_name,
                                    std::optional<DatasetFormat> format) {
  if (!format) {
    absl::StatusOr<DatasetFormat> detected = DetectDatasetFormat(root_name);
    if (!detected.ok()) return detected.status();
    format = *detected;
  }
  const fs::path root(root_name);
  std::error_code ec;
  if (!fs::is_directory(root, ec)) {
    return absl::NotFoundError(absl::StrCat("no such folder: ", root_name));
  }
  Dataset dataset;
  dataset.format = *format;
  dataset.root = root_name;
  const auto add = [&](absl::StatusOr<Clip> clip) -> absl::Status {
    if (!clip.ok()) return clip.status();
    dataset.clips.push_back(std::move(*clip));
    return absl::OkStatus();
  };
  switch (*format) {
    case DatasetFormat::kCaltech:
      for (const fs::path& dir : FoldersWith(root, kCcvl)) {
        if (absl::Status s = add(LoadCaltechClip(dir, root, &dataset.warnings)); !s.ok()) return s;
      }
      break;
    case DatasetFormat::kRender:
      for (const fs::path& dir : FoldersWith(root, kRenderLabels)) {
        if (absl::Status s = add(LoadRenderClip(dir, root)); !s.ok()) return s;
      }
      break;
    case DatasetFormat::kCulane: {
      std::vector<fs::path> dirs;
      FindCulaneClips(root, 0, &dirs);
      for (const fs::path& dir : dirs) {
        if (absl::Status s = add(LoadCulaneClip(dir, root, &dataset.warnings)); !s.ok()) return s;
      }
      break;
    }
    case DatasetFormat::kTusimple:
      for (const fs::path& file : TusimpleFiles(root)) {
        if (absl::Status s = add(LoadTusimpleClip(file, root)); !s.ok()) return s;
      }
      break;
  }
  if (dataset.clips.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(root_name, " holds no ", DatasetFormatName(*format), " clip"));
  }
  std::sort(dataset.clips.begin(), dataset.clips.end(),
            [](const Clip& a, const Clip& b) { return a.name < b.name; });
  for (const Clip& clip : dataset.clips) {
    const RepeatedLabels repeated = FindRepeatedLabels(clip);
    if (repeated.indices.empty()) continue;
    dataset.warnings.push_back(absl::StrCat(
        clip.name, ": ", repeated.indices.size(), " of ", repeated.labelled,
        " labelled frames repeat the labels of the frame before them to the last digit (the "
        "first: ",
        clip.frames[repeated.indices.front()].name,
        "): one annotation copied over a run of frames, which weighs the figures towards that "
        "view"));
  }
  return dataset;
}

}  // namespace lane::eval
