#include "stereo_safety_map/core/evaluation_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace stereo_safety_map {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double ratio(std::uint64_t num, std::uint64_t den) {
  return den == 0 ? kNaN : static_cast<double>(num) / static_cast<double>(den);
}

std::string mapProblem(const SafetyMap& map) {
  if (map.width < 0 || map.height < 0) return "safety map has a negative size";
  const std::size_t n = static_cast<std::size_t>(map.width) * static_cast<std::size_t>(map.height);
  if (map.labels.size() != n) {
    std::ostringstream os;
    os << "safety map has " << map.labels.size() << " labels for " << map.width << " x "
       << map.height << " cells";
    return os.str();
  }
  if (!std::isfinite(map.resolution) || map.resolution <= 0.0)
    return "safety map resolution must be finite and > 0";
  return "";
}

}  // namespace

SafetyClass safetyClassOf(SafetyLabel label) {
  // 000 Sec. VII-A: Level and Inclined are safe, only Non-ground is unsafe.
  switch (label) {
    case SafetyLabel::kLevel:
    case SafetyLabel::kInclined:
      return SafetyClass::kSafe;
    case SafetyLabel::kNonGround:
      return SafetyClass::kUnsafe;
    default:
      return SafetyClass::kUnclassified;
  }
}

CellOutcome cellOutcome(SafetyLabel mapped, SafetyLabel truth) {
  const SafetyClass m = safetyClassOf(mapped);
  const SafetyClass t = safetyClassOf(truth);
  if (m == SafetyClass::kUnclassified || t == SafetyClass::kUnclassified)
    return CellOutcome::kUnclassified;
  if (m == SafetyClass::kUnsafe)
    return t == SafetyClass::kUnsafe ? CellOutcome::kTruePositive : CellOutcome::kFalsePositive;
  return t == SafetyClass::kUnsafe ? CellOutcome::kFalseNegative : CellOutcome::kTrueNegative;
}

const char* toString(CellOutcome outcome) {
  switch (outcome) {
    case CellOutcome::kUnclassified:
      return "unclassified";
    case CellOutcome::kTruePositive:
      return "TP";
    case CellOutcome::kFalsePositive:
      return "FP";
    case CellOutcome::kFalseNegative:
      return "FN";
    case CellOutcome::kTrueNegative:
      return "TN";
  }
  return "invalid";
}

std::string LabelGrid::validate() const {
  if (width < 0 || height < 0) return "label grid has a negative size";
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (labels.size() != n) {
    std::ostringstream os;
    os << "label grid has " << labels.size() << " labels for " << width << " x " << height
       << " cells";
    return os.str();
  }
  if (!std::isfinite(resolution) || resolution <= 0.0)
    return "label grid resolution must be finite and > 0";
  return "";
}

ConfusionCounts& ConfusionCounts::operator+=(const ConfusionCounts& o) {
  tp += o.tp;
  fp += o.fp;
  fn += o.fn;
  tn += o.tn;
  unclassified_in_map += o.unclassified_in_map;
  unclassified_in_gt += o.unclassified_in_gt;
  maps += o.maps;
  return *this;
}

ErrorRates errorRates(const ConfusionCounts& c) {
  ErrorRates r;
  r.fn = ratio(c.fn, c.tp + c.fn);
  r.tp = ratio(c.tp, c.tp + c.fn);
  r.fp = ratio(c.fp, c.fp + c.tn);
  r.tn = ratio(c.tn, c.fp + c.tn);
  return r;
}

SafeClassScores safeClassScores(const ConfusionCounts& c) {
  // 001 Sec. 5 with A = TN, B = FN, C = FP of 000's convention (see the header).
  SafeClassScores s;
  s.precision = ratio(c.tn, c.tn + c.fn);
  s.recall = ratio(c.tn, c.tn + c.fp);
  s.f1 = ratio(2 * c.tn, 2 * c.tn + c.fn + c.fp);
  return s;
}

std::string countConfusion(const SafetyMap& map, const LabelGrid& truth, ConfusionCounts* counts,
                           std::vector<CellOutcome>* outcomes) {
  if (counts == nullptr) return "counts must not be null";
  std::string err = mapProblem(map);
  if (err.empty()) err = truth.validate();
  if (!err.empty()) return err;
  if (std::abs(map.resolution - truth.resolution) > 1e-6 * truth.resolution) {
    std::ostringstream os;
    os << "resolutions differ: map " << map.resolution << " m, ground truth " << truth.resolution
       << " m";
    return os.str();
  }
  if (outcomes != nullptr) outcomes->assign(map.labels.size(), CellOutcome::kUnclassified);

  ConfusionCounts c;
  c.maps = 1;
  for (int r = 0; r < map.height; ++r) {
    const int v = map.min_v + r;
    const std::size_t row = static_cast<std::size_t>(r) * map.width;
    for (int col = 0; col < map.width; ++col) {
      const SafetyLabel m = map.labels[row + col];
      const SafetyLabel t = truth.at(map.min_u + col, v);
      const SafetyClass mc = safetyClassOf(m);
      const SafetyClass tc = safetyClassOf(t);
      if (mc == SafetyClass::kUnclassified || tc == SafetyClass::kUnclassified) {
        if (mc != SafetyClass::kUnclassified) ++c.unclassified_in_gt;
        if (tc != SafetyClass::kUnclassified) ++c.unclassified_in_map;
        continue;
      }
      const CellOutcome o = cellOutcome(m, t);
      switch (o) {
        case CellOutcome::kTruePositive:
          ++c.tp;
          break;
        case CellOutcome::kFalsePositive:
          ++c.fp;
          break;
        case CellOutcome::kFalseNegative:
          ++c.fn;
          break;
        case CellOutcome::kTrueNegative:
          ++c.tn;
          break;
        default:
          break;
      }
      if (outcomes != nullptr) (*outcomes)[row + col] = o;
    }
  }
  *counts += c;
  return "";
}

MeanStd meanStd(const std::vector<double>& values) {
  MeanStd r;
  double sum = 0.0;
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    sum += v;
    ++r.n;
  }
  if (r.n == 0) {
    r.mean = r.stddev = kNaN;
    return r;
  }
  r.mean = sum / r.n;
  if (r.n == 1) return r;
  double ss = 0.0;
  for (double v : values) {
    if (std::isfinite(v)) ss += (v - r.mean) * (v - r.mean);
  }
  r.stddev = std::sqrt(ss / (r.n - 1));
  return r;
}

// ---------------------------------------------------------------------------------------------

bool ReferencePlane::contains(double x, double y, double eps) const {
  const std::size_t n = footprint.size();
  if (n < 3 || !std::isfinite(x) || !std::isfinite(y)) return false;
  // Convex polygon of either orientation: inside when on one side of every edge.
  bool pos = false, neg = false;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& p = footprint[i];
    const Eigen::Vector2d& q = footprint[(i + 1) % n];
    const Eigen::Vector2d e = q - p;
    const double len = e.norm();
    if (len <= 0.0) continue;
    const double side = (e.x() * (y - p.y()) - e.y() * (x - p.x())) / len;  // signed distance
    if (side > eps) pos = true;
    if (side < -eps) neg = true;
    if (pos && neg) return false;
  }
  return true;
}

int topReferencePlane(const std::vector<ReferencePlane>& planes, double x, double y) {
  int best = -1;
  double best_z = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < planes.size(); ++i) {
    if (!planes[i].contains(x, y)) continue;
    const double z = planes[i].heightAt(x, y);
    if (z > best_z) {
      best_z = z;
      best = static_cast<int>(i);
    }
  }
  return best;
}

PlaneAccuracy comparePlane(const GroundPlane& detected, const std::vector<int>& footprint_cells,
                           const SafetyMap& map, const std::vector<ReferencePlane>& references) {
  PlaneAccuracy r;
  if (!detected.valid || footprint_cells.empty() || references.empty() || map.width <= 0 ||
      map.height <= 0)
    return r;
  const int n_cells = map.width * map.height;
  std::vector<int> votes(references.size(), 0);
  std::vector<Eigen::Vector2d> centres;
  centres.reserve(footprint_cells.size());
  for (int k : footprint_cells) {
    if (k < 0 || k >= n_cells) continue;
    const int u = map.min_u + k % map.width;
    const int v = map.min_v + k / map.width;
    const Eigen::Vector2d xy = map.cellCenter(u, v);
    centres.push_back(xy);
    const int top = topReferencePlane(references, xy.x(), xy.y());
    if (top >= 0) ++votes[top];
  }
  r.cells = static_cast<int>(centres.size());
  const auto best = std::max_element(votes.begin(), votes.end());
  if (r.cells == 0 || *best == 0) return r;
  r.matched = true;
  r.reference = static_cast<int>(best - votes.begin());
  r.cells_on_reference = *best;

  const ReferencePlane& ref = references[r.reference];
  const Eigen::Vector3d n_ref = ref.normal();
  Eigen::Vector3d n_det = Eigen::Vector3d(-detected.a, -detected.b, 1.0).normalized();
  r.angle_deg = std::acos(std::clamp(n_det.dot(n_ref), -1.0, 1.0)) * 180.0 / M_PI;
  // Perpendicular distance to the reference of the detected plane's point above each cell
  // centre: (z_det - z_ref) times the cosine of the reference's slope.
  double sum = 0.0;
  for (const Eigen::Vector2d& xy : centres) {
    const double d =
        std::abs(detected.heightAt(xy.x(), xy.y()) - ref.heightAt(xy.x(), xy.y())) * n_ref.z();
    sum += d;
    r.max_distance = std::max(r.max_distance, d);
  }
  r.mean_distance = sum / static_cast<double>(centres.size());
  return r;
}

// ---------------------------------------------------------------------------------------------

BoardAxes boardAxes(const BoardBox& board) {
  BoardAxes a;
  a.height = 0;
  for (int k = 1; k < 3; ++k) {
    if (std::abs(board.rotation(2, k)) > std::abs(board.rotation(2, a.height))) a.height = k;
  }
  const int a0 = (a.height + 1) % 3, a1 = (a.height + 2) % 3;
  a.width = board.half_size[a0] >= board.half_size[a1] ? a0 : a1;
  a.thickness = a.width == a0 ? a1 : a0;
  return a;
}

BoardCoverage boardWidthCoverage(const VoxelGrid& grid, const BoardBox& board,
                                 std::vector<std::uint8_t>* covered_bins) {
  if (covered_bins != nullptr) covered_bins->clear();
  BoardCoverage cov;
  const double lv = grid.config().voxel_size;
  if (!board.valid()) return cov;
  const BoardAxes axes = boardAxes(board);
  const int h_axis = axes.height, w_axis = axes.width;
  const double half_width = board.half_size[w_axis];
  cov.bins = std::max(1, static_cast<int>(std::ceil(2.0 * half_width / lv - 1e-9)));
  const double bin = 2.0 * half_width / cov.bins;

  // Half extent of an axis-aligned voxel projected on each box axis, plus, across the board's
  // thickness, one voxel of slack for stereo's depth error (about 0.1 m at 5 m).
  Eigen::Vector3d voxel_half, slack;
  for (int k = 0; k < 3; ++k) {
    voxel_half[k] = 0.5 * lv * board.rotation.col(k).cwiseAbs().sum();
    slack[k] = voxel_half[k] + (k != w_axis && k != h_axis ? lv : 0.0);
  }
  constexpr double kEps = 1e-5;  // samples on a voxel's border count (float centres)

  // Corners of the box give the voxel index range to scan.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (int corner = 0; corner < 8; ++corner) {
    Eigen::Vector3d s;
    for (int k = 0; k < 3; ++k)
      s[k] = (corner >> k) & 1 ? 1.0 : -1.0;
    const Eigen::Vector3d p = board.center + board.rotation * s.cwiseProduct(board.half_size);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double min_z = lo.z() + lv;  // above the floor the board stands on
  const VoxelIndex gmin = grid.minIndex();
  auto clampIdx = [](double x, int lo_i, int hi_i) {
    if (!(x > lo_i)) return lo_i;
    if (!(x < hi_i)) return hi_i;
    return static_cast<int>(x);
  };
  const int u0 = clampIdx(std::floor(lo.x() / lv) - 1, gmin.u, gmin.u + grid.sizeU() - 1);
  const int u1 = clampIdx(std::ceil(hi.x() / lv) + 1, gmin.u, gmin.u + grid.sizeU() - 1);
  const int v0 = clampIdx(std::floor(lo.y() / lv) - 1, gmin.v, gmin.v + grid.sizeV() - 1);
  const int v1 = clampIdx(std::ceil(hi.y() / lv) + 1, gmin.v, gmin.v + grid.sizeV() - 1);
  const int w0 = clampIdx(std::floor(lo.z() / lv) - 1, gmin.w, gmin.w + grid.sizeW() - 1);
  const int w1 = clampIdx(std::ceil(hi.z() / lv) + 1, gmin.w, gmin.w + grid.sizeW() - 1);
  if (u0 > u1 || v0 > v1 || w0 > w1) return cov;

  std::vector<char> hit(cov.bins, 0);
  const Eigen::Matrix3d Rt = board.rotation.transpose();
  for (int w = w0; w <= w1; ++w) {
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {
        const VoxelIndex i{u, v, w};
        if (!grid.contains(i) || !grid.isOccupied(i)) continue;
        const Eigen::Vector3d c = grid.centerOf(i).cast<double>();
        if (c.z() <= min_z) continue;
        const Eigen::Vector3d t = Rt * (c - board.center);
        bool overlaps = true;
        for (int k = 0; k < 3 && overlaps; ++k)
          overlaps = std::abs(t[k]) <= board.half_size[k] + slack[k] + kEps;
        if (!overlaps) continue;
        // Samples at bin centres within the voxel's projected extent along the width.
        const double s_lo = t[w_axis] - voxel_half[w_axis] + half_width - kEps;
        const double s_hi = t[w_axis] + voxel_half[w_axis] + half_width + kEps;
        const int b0 = std::max(0, static_cast<int>(std::ceil(s_lo / bin - 0.5)));
        const int b1 = std::min(cov.bins - 1, static_cast<int>(std::floor(s_hi / bin - 0.5)));
        for (int b = b0; b <= b1; ++b)
          hit[b] = 1;
      }
    }
  }
  for (char h : hit)
    cov.covered += h ? 1 : 0;
  if (covered_bins != nullptr) covered_bins->assign(hit.begin(), hit.end());
  return cov;
}

BoardCoverage boardWidthCoverageOfCells(const SafetyMap& map,
                                        const std::vector<std::uint8_t>& marked,
                                        const BoardBox& board,
                                        std::vector<std::uint8_t>* covered_bins) {
  BoardCoverage cov;
  const double lv = map.resolution;
  const std::size_t cells = static_cast<std::size_t>(std::max(0, map.width)) *
                            static_cast<std::size_t>(std::max(0, map.height));
  if (!(lv > 0.0) || marked.size() != cells || !board.valid()) return cov;
  // The same axes and bins as boardWidthCoverage().
  const BoardAxes axes = boardAxes(board);
  const int h_axis = axes.height, w_axis = axes.width, t_axis = axes.thickness;
  const double half_width = board.half_size[w_axis];
  cov.bins = std::max(1, static_cast<int>(std::ceil(2.0 * half_width / lv - 1e-9)));
  const double bin = 2.0 * half_width / cov.bins;
  if (covered_bins != nullptr && covered_bins->size() != static_cast<std::size_t>(cov.bins))
    covered_bins->assign(static_cast<std::size_t>(cov.bins), 0);

  // The footprint at a sample: the board's section across its thickness (with one cell of
  // slack) and its height, sampled every quarter cell.
  const double ht = board.half_size[t_axis] + lv, hh = board.half_size[h_axis];
  const double step = 0.25 * lv;
  const int nt = static_cast<int>(std::ceil(2.0 * ht / step)),
            nh = static_cast<int>(std::ceil(2.0 * hh / step));
  for (int b = 0; b < cov.bins; ++b) {
    const double tw = (b + 0.5) * bin - half_width;
    bool hit = false;
    for (int i = 0; i <= nt && !hit; ++i) {
      for (int j = 0; j <= nh && !hit; ++j) {
        const Eigen::Vector3d p =
            board.center + board.rotation.col(w_axis) * tw +
            board.rotation.col(t_axis) * (-ht + 2.0 * ht * i / std::max(1, nt)) +
            board.rotation.col(h_axis) * (-hh + 2.0 * hh * j / std::max(1, nh));
        const int u = static_cast<int>(std::floor(p.x() / lv + 0.5));
        const int v = static_cast<int>(std::floor(p.y() / lv + 0.5));
        if (map.inside(u, v) && marked[static_cast<std::size_t>(map.index(u, v))] != 0) hit = true;
      }
    }
    if (!hit) continue;
    ++cov.covered;
    if (covered_bins != nullptr) (*covered_bins)[static_cast<std::size_t>(b)] = 1;
  }
  return cov;
}

int framesUntilCoverage(const std::vector<double>& coverage, double fraction) {
  for (std::size_t i = 0; i < coverage.size(); ++i) {
    if (coverage[i] >= fraction - 1e-12) return static_cast<int>(i) + 1;
  }
  return -1;
}

}  // namespace stereo_safety_map
