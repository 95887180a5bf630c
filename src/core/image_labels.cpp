#include "stereo_safety_map/core/image_labels.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <unordered_map>

namespace stereo_safety_map {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kMaxImageSide = 100000;

double ratio(int num, int den) {
  return den == 0 ? kNaN : static_cast<double>(num) / static_cast<double>(den);
}

std::string lineError(int line, const std::string& what) {
  return "line " + std::to_string(line) + ": " + what;
}

// A decimal integer spanning the whole token.
bool parseInt(const std::string& s, long* v) {
  if (s.empty()) return false;
  errno = 0;
  char* end = nullptr;
  const long x = std::strtol(s.c_str(), &end, 10);
  if (errno != 0 || end != s.c_str() + s.size()) return false;
  *v = x;
  return true;
}

// The hand-label classes that vote for a cell's truth (ignore and none do not).
bool votes(ImageLabel l) {
  return l == ImageLabel::kFloor || l == ImageLabel::kObstacle || l == ImageLabel::kOverhang ||
         l == ImageLabel::kDropOff;
}

// Whether the map's label is what a truth cell of class `l` requires (LabelClassScore::recall).
bool isHit(ImageLabel l, SafetyLabel m) {
  switch (l) {
    case ImageLabel::kFloor:
      return isSafe(m);
    case ImageLabel::kObstacle:
    case ImageLabel::kOverhang:
      return m == SafetyLabel::kNonGround;
    case ImageLabel::kDropOff:
      return m == SafetyLabel::kNonGround || m == SafetyLabel::kUnknown;
    default:
      return false;
  }
}

std::int64_t cellKey(int u, int v) {
  return static_cast<std::int64_t>(
      (static_cast<std::uint64_t>(static_cast<std::uint32_t>(u)) << 32) |
      static_cast<std::uint32_t>(v));
}

struct Votes {
  int u = 0;
  int v = 0;
  std::array<int, kNumImageLabels> n{};
};

}  // namespace

const char* toString(ImageLabel label) {
  switch (label) {
    case ImageLabel::kNone:
      return "none";
    case ImageLabel::kFloor:
      return "floor";
    case ImageLabel::kObstacle:
      return "obstacle";
    case ImageLabel::kOverhang:
      return "overhang";
    case ImageLabel::kDropOff:
      return "drop_off";
    case ImageLabel::kIgnore:
      return "ignore";
  }
  return "invalid";
}

bool imageLabelFromString(const std::string& name, ImageLabel* label) {
  for (int k = 1; k < kNumImageLabels; ++k) {
    const ImageLabel l = static_cast<ImageLabel>(k);
    if (name == toString(l)) {
      if (label != nullptr) *label = l;
      return true;
    }
  }
  return false;
}

SafetyClass safetyClassOf(ImageLabel label) {
  switch (label) {
    case ImageLabel::kFloor:
      return SafetyClass::kSafe;
    case ImageLabel::kObstacle:
    case ImageLabel::kOverhang:
    case ImageLabel::kDropOff:
      return SafetyClass::kUnsafe;
    default:
      return SafetyClass::kUnclassified;
  }
}

std::string parseImageLabels(const std::string& text, ImageLabels* out) {
  if (out == nullptr) return "output must not be null";
  ImageLabels r;
  bool have_size = false;
  std::istringstream in(text);
  std::string raw;
  int line = 0;
  while (std::getline(in, raw)) {
    ++line;
    const std::size_t hash = raw.find('#');
    std::istringstream ls(hash == std::string::npos ? raw : raw.substr(0, hash));
    std::string head;
    if (!(ls >> head)) continue;  // blank or comment-only
    if (head == "size") {
      if (have_size) return lineError(line, "repeated size line");
      std::string ws, hs, extra;
      long w = 0, h = 0;
      if (!(ls >> ws >> hs) || !parseInt(ws, &w) || !parseInt(hs, &h) || (ls >> extra))
        return lineError(line, "expected 'size <width> <height>'");
      if (w < 1 || h < 1 || w > kMaxImageSide || h > kMaxImageSide)
        return lineError(line, "image size " + ws + " x " + hs + " must be in [1, " +
                                   std::to_string(kMaxImageSide) + "]");
      r.width = static_cast<int>(w);
      r.height = static_cast<int>(h);
      have_size = true;
      continue;
    }
    LabelPolygon poly;
    poly.line = line;
    if (!imageLabelFromString(head, &poly.label))
      return lineError(line,
                       "unknown class '" + head +
                           "' (expected floor, obstacle, overhang, drop_off, ignore or size)");
    if (!have_size) return lineError(line, "polygon before the 'size <width> <height>' line");
    std::string tok;
    while (ls >> tok) {
      const std::size_t comma = tok.find(',');
      long x = 0, y = 0;
      if (comma == std::string::npos || !parseInt(tok.substr(0, comma), &x) ||
          !parseInt(tok.substr(comma + 1), &y))
        return lineError(line, "bad vertex '" + tok + "' (expected x,y in integer pixels)");
      if (x < 0 || y < 0 || x > r.width || y > r.height)
        return lineError(line, "vertex " + tok + " outside the " + std::to_string(r.width) + "x" +
                                   std::to_string(r.height) + " image");
      poly.vertices.emplace_back(static_cast<int>(x), static_cast<int>(y));
    }
    if (poly.vertices.size() < 3)
      return lineError(line, head + " polygon has " + std::to_string(poly.vertices.size()) +
                                 " vertices, needs at least 3");
    r.polygons.push_back(std::move(poly));
  }
  if (!have_size) return "no 'size <width> <height>' line";
  *out = std::move(r);
  return "";
}

std::string loadImageLabels(const std::string& path, ImageLabels* out) {
  std::ifstream f(path);
  if (!f) return "cannot read " + path;
  std::ostringstream ss;
  ss << f.rdbuf();
  const std::string err = parseImageLabels(ss.str(), out);
  return err.empty() ? "" : path + ": " + err;
}

std::string rasteriseImageLabels(const ImageLabels& labels, cv::Mat* image) {
  if (image == nullptr) return "output must not be null";
  if (labels.width < 1 || labels.height < 1) return "labels have no image size";
  cv::Mat img(labels.height, labels.width, CV_8U, cv::Scalar(0));
  for (const LabelPolygon& p : labels.polygons) {
    if (p.vertices.size() < 3) continue;
    const cv::Point* pts = p.vertices.data();
    const int n = static_cast<int>(p.vertices.size());
    // 8-connected edges, boundary pixels included: a polygon covers the pixels it outlines.
    cv::fillPoly(img, &pts, &n, 1, cv::Scalar(static_cast<int>(p.label)), cv::LINE_8);
  }
  *image = img;
  return "";
}

LabelScoringConfig LabelScoringConfig::forGrid(double min_range, double max_range) {
  LabelScoringConfig c;
  c.min_depth = min_range;
  c.max_depth = max_range;
  return c;
}

std::string LabelScoringConfig::validate() const {
  std::ostringstream os;
  if (min_pixels < 1 || min_pixels > 1000000) {
    os << "min_pixels = " << min_pixels << " must be in [1, 1000000]";
  } else if (tolerance_cells < 0 || tolerance_cells > 10) {
    os << "tolerance_cells = " << tolerance_cells << " must be in [0, 10]";
  } else if (!(std::isfinite(min_depth) && min_depth >= 0.0)) {
    os << "min_depth = " << min_depth << " must be finite and >= 0";
  } else if (!(std::isfinite(max_depth) && max_depth > min_depth)) {
    os << "max_depth = " << max_depth << " must be finite and > min_depth";
  }
  return os.str();
}

double LabelClassScore::recall() const {
  return ratio(hits, cells);
}
double LabelClassScore::recallTolerant() const {
  return ratio(hits_tolerant, cells);
}
double ImageLabelScore::coverage() const {
  return ratio(covered_cells, truth_cells);
}

std::string scoreAgainstImageLabels(const cv::Mat& label_image, const cv::Mat& disparity,
                                    const StereoCameraModel& camera,
                                    const Eigen::Isometry3d& T_fixed_camera, const SafetyMap& map,
                                    const LabelScoringConfig& config, ImageLabelScore* score) {
  if (score == nullptr) return "score must not be null";
  std::string err = config.validate();
  if (!err.empty()) return "invalid scoring configuration: " + err;
  err = camera.validate();
  if (!err.empty()) return "bad camera model: " + err;
  if (label_image.empty() || label_image.type() != CV_8UC1) return "label image must be CV_8UC1";
  if (disparity.empty() || disparity.type() != CV_32FC1) return "disparity must be CV_32FC1";
  if (label_image.size() != disparity.size() || disparity.cols != camera.width ||
      disparity.rows != camera.height)
    return "label image, disparity and camera model must have the same size";
  const std::size_t n_cells = static_cast<std::size_t>(std::max(0, map.width)) *
                              static_cast<std::size_t>(std::max(0, map.height));
  if (map.width < 0 || map.height < 0 || map.labels.size() != n_cells)
    return "safety map's labels do not match its size";
  if (!(std::isfinite(map.resolution) && map.resolution > 0.0))
    return "safety map resolution must be finite and > 0";
  if (!T_fixed_camera.matrix().allFinite()) return "camera pose must be finite";

  ImageLabelScore s;
  s.exact.maps = s.tolerant.maps = 1;
  // Votes: pixel -> 3D point (left optical frame, 002 Sec. 3.2 through StereoCameraModel) -> fixed
  // frame -> cell of Eq. (1) (000 Sec. IV). The height is not looked at.
  std::unordered_map<std::int64_t, Votes> cells;
  const double inv_res = 1.0 / map.resolution;
  for (int y = 0; y < disparity.rows; ++y) {
    const float* drow = disparity.ptr<float>(y);
    const std::uint8_t* lrow = label_image.ptr<std::uint8_t>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (lrow[x] >= kNumImageLabels) return "label image has a value outside ImageLabel";
      const ImageLabel l = static_cast<ImageLabel>(lrow[x]);
      LabelClassScore& cs = s.classes[lrow[x]];
      ++cs.pixels;
      const float d = drow[x];
      if (!(d > 0.0f && std::isfinite(d))) continue;
      const double z = camera.depthFromDisparity(d);
      if (!(z > 0.0) || !std::isfinite(z)) continue;  // at or beyond infinity
      ++cs.pixels_with_disparity;
      if (z < config.min_depth || z > config.max_depth || !votes(l)) continue;
      ++cs.pixels_voting;
      const Eigen::Vector3d p = T_fixed_camera * camera.reproject(x, y, d).cast<double>();
      const double fu = std::floor(p.x() * inv_res + 0.5), fv = std::floor(p.y() * inv_res + 0.5);
      if (!(std::abs(fu) < 1e8 && std::abs(fv) < 1e8)) continue;
      const int u = static_cast<int>(fu), v = static_cast<int>(fv);
      Votes& cell = cells[cellKey(u, v)];
      cell.u = u;
      cell.v = v;
      ++cell.n[lrow[x]];
    }
  }

  // Truth per cell: the majority of its votes, min_pixels votes at least, no truth on a tie.
  s.truth.assign(n_cells, ImageLabel::kNone);
  s.outcomes.assign(n_cells, CellOutcome::kUnclassified);
  struct Truth {
    int u, v;
    ImageLabel label;
    bool examined;
  };
  std::vector<Truth> truths;
  for (const auto& kv : cells) {
    const Votes& cell = kv.second;
    int total = 0, best = 0, best_n = 0;
    bool tie = false;
    for (int k = 0; k < kNumImageLabels; ++k) {
      total += cell.n[k];
      if (cell.n[k] > best_n) {
        best = k;
        best_n = cell.n[k];
        tie = false;
      } else if (cell.n[k] == best_n && best_n > 0) {
        tie = true;
      }
    }
    if (total < config.min_pixels) {
      ++s.cells_too_few_votes;
      continue;
    }
    if (tie) {
      ++s.cells_tied;
      continue;
    }
    const ImageLabel l = static_cast<ImageLabel>(best);
    const bool inside = map.inside(cell.u, cell.v);
    const bool examined = inside && map.labelAt(cell.u, cell.v) != SafetyLabel::kUnexamined;
    if (inside) s.truth[map.index(cell.u, cell.v)] = l;
    truths.push_back({cell.u, cell.v, l, examined});
  }

  // Whether a truth cell within the tolerance (Chebyshev) of (u, v) has safety class `c`. Cells off
  // the grid are never examined and lie at least R_max away from the examined ones: not needed.
  const int r = config.tolerance_cells;
  auto nearbyTruthIs = [&](int u, int v, SafetyClass c) {
    for (int dv = -r; dv <= r; ++dv)
      for (int du = -r; du <= r; ++du) {
        if (!map.inside(u + du, v + dv)) continue;
        const ImageLabel t = s.truth[map.index(u + du, v + dv)];
        if (t != ImageLabel::kNone && safetyClassOf(t) == c) return true;
      }
    return false;
  };

  for (const Truth& t : truths) {
    LabelClassScore& cs = s.classes[static_cast<int>(t.label)];
    if (!t.examined) {
      ++cs.cells_beyond;
      ++s.truth_cells_beyond;
      continue;
    }
    ++cs.cells;
    ++s.truth_cells;
    const SafetyLabel m = map.labelAt(t.u, t.v);
    const SafetyClass mc = safetyClassOf(m);
    cs.map_safe += mc == SafetyClass::kSafe ? 1 : 0;
    cs.map_non_ground += mc == SafetyClass::kUnsafe ? 1 : 0;
    cs.map_unknown += mc == SafetyClass::kUnclassified ? 1 : 0;
    const bool hit = isHit(t.label, m);
    const bool tolerated = !hit && mc != SafetyClass::kUnclassified && nearbyTruthIs(t.u, t.v, mc);
    cs.hits += hit ? 1 : 0;
    cs.hits_tolerant += hit || tolerated ? 1 : 0;

    if (mc == SafetyClass::kUnclassified) {
      ++s.exact.unclassified_in_map;
      ++s.tolerant.unclassified_in_map;
      continue;
    }
    ++s.covered_cells;
    const bool truth_unsafe = safetyClassOf(t.label) == SafetyClass::kUnsafe;
    const bool map_unsafe = mc == SafetyClass::kUnsafe;
    std::uint64_t* exact = truth_unsafe ? (map_unsafe ? &s.exact.tp : &s.exact.fn)
                                        : (map_unsafe ? &s.exact.fp : &s.exact.tn);
    ++*exact;
    s.outcomes[map.index(t.u, t.v)] =
        truth_unsafe ? (map_unsafe ? CellOutcome::kTruePositive : CellOutcome::kFalseNegative)
                     : (map_unsafe ? CellOutcome::kFalsePositive : CellOutcome::kTrueNegative);
    const bool error = truth_unsafe != map_unsafe;
    const bool forgiven = error && nearbyTruthIs(t.u, t.v, mc);
    std::uint64_t* tol = nullptr;
    if (truth_unsafe)
      tol = map_unsafe || forgiven ? &s.tolerant.tp : &s.tolerant.fn;
    else
      tol = !map_unsafe || forgiven ? &s.tolerant.tn : &s.tolerant.fp;
    ++*tol;
  }
  // Map-classified cells that got no truth.
  for (std::size_t k = 0; k < n_cells; ++k) {
    if (s.truth[k] != ImageLabel::kNone) continue;
    if (safetyClassOf(map.labels[k]) == SafetyClass::kUnclassified) continue;
    ++s.exact.unclassified_in_gt;
    ++s.tolerant.unclassified_in_gt;
  }
  *score = std::move(s);
  return "";
}

LabelGrid truthLabelGrid(const SafetyMap& map, const std::vector<ImageLabel>& truth) {
  LabelGrid g;
  g.min_u = map.min_u;
  g.min_v = map.min_v;
  g.width = map.width;
  g.height = map.height;
  g.resolution = map.resolution;
  g.labels.assign(map.labels.size(), SafetyLabel::kUnknown);
  for (std::size_t k = 0; k < g.labels.size() && k < truth.size(); ++k) {
    const SafetyClass c = safetyClassOf(truth[k]);
    if (c == SafetyClass::kSafe) g.labels[k] = SafetyLabel::kLevel;
    if (c == SafetyClass::kUnsafe) g.labels[k] = SafetyLabel::kNonGround;
  }
  return g;
}

}  // namespace stereo_safety_map
