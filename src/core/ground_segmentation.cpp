#include "stereo_safety_map/core/ground_segmentation.h"

#include "stereo_safety_map/core/plane_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>

namespace stereo_safety_map {

std::string GroundSegmentationConfig::validate() const {
  if (!std::isfinite(planning_radius) || planning_radius <= 0.0 || planning_radius > 1000.0) {
    return "planning_radius must be in (0, 1000] m";
  }
  if (height_tolerance < 0 || height_tolerance > 1000) {
    return "height_tolerance must be in [0, 1000] voxels";
  }
  if (connectivity != 4 && connectivity != 8) return "connectivity must be 4 or 8";
  if (!std::isfinite(seed_radius) || seed_radius < 0.0 || seed_radius > 1000.0) {
    return "seed_radius must be in [0, 1000] m";
  }
  if (!std::isfinite(footprint_radius) || footprint_radius < 0.0 || footprint_radius > 5.0) {
    return "footprint_radius must be in [0, 5] m (0 = off)";
  }
  if (island_max_span < 0 || island_max_span > 1000) {
    return "island_max_span must be in [0, 1000] voxels";
  }
  if (!std::isfinite(split_min_step) || split_min_step <= 0.0 || split_min_step > 10.0) {
    return "split_min_step must be in (0, 10] m";
  }
  if (!std::isfinite(seed_support_max_offset) || seed_support_max_offset < 0.0 ||
      seed_support_max_offset > 1.0) {
    return "seed_support_max_offset must be in [0, 1] m";
  }
  if (split_min_cells < 1 || split_min_cells > 100000) {
    return "split_min_cells must be in [1, 100000] cells";
  }
  return "";
}

GroundSegmentation::GroundSegmentation(const GroundSegmentationConfig& config) : config_(config) {
  const std::string err = config_.validate();
  if (!err.empty()) throw std::invalid_argument("GroundSegmentationConfig: " + err);
}

namespace {

// Squared radius in cells, widened by a hair so that a radius that is a whole number of cells
// includes the cells exactly on it despite rounding of R / l_v.
// Clamped to 2^60: a radius of any size over a tiny voxel converts without overflow (beyond the
// window anyway).
long long radiusSquaredCells(double radius, double voxel_size) {
  const double r = radius / voxel_size;
  const double r2 = std::floor(r * r + 1e-6);
  constexpr double kMax = 1152921504606846976.0;  // 2^60
  return !(r2 < kMax) ? static_cast<long long>(kMax) : static_cast<long long>(r2);
}

}  // namespace

bool GroundSegmentation::segment(const HeightMap& hm, const VoxelIndex& robot, double voxel_size,
                                 GroundSegments* out, float base_z) {
  if (out == nullptr) return false;
  GroundSegments& s = *out;
  s.min_u = hm.minU();
  s.min_v = hm.minV();
  s.width = hm.width();
  s.height = hm.height();
  s.robot = robot;
  s.seed_cell = -1;
  s.robot_segment = -1;
  const int n = hm.numCells();
  s.segment_of.assign(n, -1);
  s.examined.assign(n, 0);
  s.segment_begin.assign(1, 0);
  s.segment_cells.clear();
  s.segment_height.clear();
  s.segment_island.clear();
  s.segment_split_from.clear();
  s.non_traversable.clear();
  s.footprint.assign(n, 0);
  if (!std::isfinite(voxel_size) || voxel_size <= 0.0) return false;

  // Alg. 1 step 3: cells farther than R_max from the robot's cell are "not to be examined".
  const long long r2 = radiusSquaredCells(config_.planning_radius, voxel_size);
  const long long rc = static_cast<long long>(std::floor(std::sqrt(static_cast<double>(r2))));
  {
    const long long v_lo = std::max<long long>(s.min_v, robot.v - rc);
    const long long v_hi = std::min<long long>(s.min_v + s.height - 1, robot.v + rc);
    const long long u_lo = std::max<long long>(s.min_u, robot.u - rc);
    const long long u_hi = std::min<long long>(s.min_u + s.width - 1, robot.u + rc);
    for (long long v = v_lo; v <= v_hi; ++v) {
      const long long dv = v - robot.v;
      for (long long u = u_lo; u <= u_hi; ++u) {
        const long long du = u - robot.u;
        if (du * du + dv * dv <= r2) {
          s.examined[s.index(static_cast<int>(u), static_cast<int>(v))] = 1;
        }
      }
    }
  }

  // The robot's footprint: ground at the base's height where nothing was observed
  // (GroundSegmentationConfig::footprint_radius). disk_: the examined cells within
  // footprint_radius of the robot's cell.
  disk_.clear();
  if (config_.footprint_radius > 0.0) {
    const long long f2 = radiusSquaredCells(config_.footprint_radius, voxel_size);
    const long long fc = static_cast<long long>(std::floor(std::sqrt(static_cast<double>(f2))));
    for (long long v = std::max<long long>(s.min_v, robot.v - fc);
         v <= std::min<long long>(s.min_v + s.height - 1, robot.v + fc); ++v) {
      for (long long u = std::max<long long>(s.min_u, robot.u - fc);
           u <= std::min<long long>(s.min_u + s.width - 1, robot.u + fc); ++u) {
        const long long du = u - robot.u, dv = v - robot.v;
        if (du * du + dv * dv > f2) continue;
        const int cell = s.index(static_cast<int>(u), static_cast<int>(v));
        if (s.examined[cell]) disk_.push_back(cell);
      }
    }
  }
  for (const int cell : disk_)
    if (hm.atIndex(cell) == HeightMap::kNoHeight) s.footprint[cell] = 1;
  // Heights as Alg. 1 sees them: the height map's, the base's on footprint cells.
  const std::int32_t robot_w = robot.w;
  auto heightOf = [&](int cell) { return s.footprint[cell] ? robot_w : hm.atIndex(cell); };
  auto lowestOf = [&](int cell) { return s.footprint[cell] ? robot_w : hm.lowestAtIndex(cell); };

  // Seed of the robot's segment (Alg. 1 steps 2 and 5, with the seed rule of the config):
  // least height difference to the robot's base first, then an observed cell before a footprint
  // cell, then nearest, then scan order. Observed ground at the base's height within seed_radius
  // is the robot's segment as in 000; the footprint joins it (below), and carries it alone only
  // when nothing within seed_radius was observed at that height.
  const int w_t = config_.height_tolerance;
  const long long s2 = std::min(r2, radiusSquaredCells(config_.seed_radius, voxel_size));
  const long long sc = static_cast<long long>(std::floor(std::sqrt(static_cast<double>(s2))));
  // GroundSegmentationConfig::seed_on_support: the indexed height most cells of the footprint
  // disk hold, within w_T of the base's.
  bool support_found = false;
  std::int32_t support_w = robot_w;
  if (config_.seed_on_support && !disk_.empty() && w_t >= 0) {
    support_count_.assign(2 * static_cast<std::size_t>(w_t) + 1, 0);
    for (const int cell : disk_) {
      const std::int32_t w = heightOf(cell);
      if (w == HeightMap::kNoHeight) continue;
      const long long dw = static_cast<long long>(w) - robot_w;
      if (std::llabs(dw) > w_t) continue;
      ++support_count_[static_cast<std::size_t>(dw + w_t)];
    }
    int best = 0;
    for (int i = 0; i <= 2 * w_t; ++i) {
      const int dw = i - w_t;
      const int c = support_count_[static_cast<std::size_t>(i)];
      if (c == 0) continue;
      if (c > best || (c == best && std::abs(dw) < std::abs(support_w - robot_w))) {
        best = c;
        support_w = robot_w + dw;
      }
    }
    support_found = best > 0;
    if (support_found && support_w != robot_w) {
      // Could the chair stand on it: its ground within seed_support_max_offset of the base's?
      support_z_.clear();
      for (const int cell : disk_) {
        if (s.footprint[cell] || hm.atIndex(cell) != support_w) continue;
        float z = hm.groundHeightAtIndex(cell);
        if (!std::isfinite(z)) z = hm.surfaceHeightAtIndex(cell);
        if (std::isfinite(z)) support_z_.push_back(z);
      }
      bool stands = false;
      if (!support_z_.empty() && std::isfinite(base_z)) {
        auto mid = support_z_.begin() + static_cast<std::ptrdiff_t>(support_z_.size() / 2);
        std::nth_element(support_z_.begin(), mid, support_z_.end());
        stands = std::abs(*mid - base_z) <= config_.seed_support_max_offset;
      }
      if (!stands) support_found = false;
    }
  }
  {
    long long best_dw = std::numeric_limits<long long>::max();
    long long best_d2 = std::numeric_limits<long long>::max();
    int best_fp = 2;
    const long long v_lo = std::max<long long>(s.min_v, robot.v - sc);
    const long long v_hi = std::min<long long>(s.min_v + s.height - 1, robot.v + sc);
    const long long u_lo = std::max<long long>(s.min_u, robot.u - sc);
    const long long u_hi = std::min<long long>(s.min_u + s.width - 1, robot.u + sc);
    for (long long v = v_lo; v <= v_hi; ++v) {
      for (long long u = u_lo; u <= u_hi; ++u) {
        const long long du = u - robot.u, dv = v - robot.v;
        const long long d2 = du * du + dv * dv;
        if (d2 > s2) continue;
        const int cell = s.index(static_cast<int>(u), static_cast<int>(v));
        const std::int32_t w = heightOf(cell);
        if (w == HeightMap::kNoHeight || !s.examined[cell]) continue;
        const long long dw = std::llabs(static_cast<long long>(w) - robot.w);
        if (dw > w_t || (support_found && w != support_w)) continue;
        const int fp = s.footprint[cell];
        if (dw < best_dw || (dw == best_dw && (fp < best_fp || (fp == best_fp && d2 < best_d2)))) {
          best_dw = dw;
          best_fp = fp;
          best_d2 = d2;
          s.seed_cell = cell;
        }
      }
    }
  }

  const int w_cells = s.width;
  const bool eight = config_.connectivity == 8;
  static constexpr int kDu[8] = {1, -1, 0, 0, 1, 1, -1, -1};
  static constexpr int kDv[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  const int num_nb = eight ? 8 : 4;

  compared_.assign(n, 0);
  locked_.assign(n, 0);
  const int max_span = config_.island_max_span;
  // May a column join an island segment? Not when Alg. 1 compared it and left it out, not when
  // its occupied voxels span more than island_max_span (the face of an obstacle), and not when
  // an observed neighbour differs from it by more than w_T: beside a height discontinuity (an
  // obstacle's edge, the floor under a table's edge) 000 calls a column non-traversable, and
  // an island must not overrule that.
  auto groundLike = [&](int cell) {
    if (locked_[cell]) return false;
    const std::int32_t w = heightOf(cell);
    if (static_cast<long long>(w) - lowestOf(cell) > max_span) return false;
    const int u = cell % w_cells, v = cell / w_cells;
    for (int j = 0; j < 8; ++j) {
      const int un = u + kDu[j], vn = v + kDv[j];
      if (un < 0 || vn < 0 || un >= w_cells || vn >= s.height) continue;
      const std::int32_t wn = heightOf(vn * w_cells + un);
      if (wn != HeightMap::kNoHeight && std::llabs(static_cast<long long>(wn) - w) > w_t)
        return false;
    }
    return true;
  };
  // Grows segments from cell c by Alg. 1 steps 5-21; island segments do not take columns that
  // are locked or span more than island_max_span voxels.
  // with_footprint: the first segment also holds the footprint's cells when they are at its
  // height (the robot's segment seeded on observed ground: the robot stands on it).
  auto grow = [&](int c, bool island, bool with_footprint) {
    pending_.clear();
    std::size_t pending_head = 0;
    auto admissible = [&](int cell) { return !island || groundLike(cell); };
    while (c >= 0) {
      // Step 5: new segment S_k holding cell c.
      const int k = s.numSegments();
      const std::int32_t wk = heightOf(c);
      s.segment_height.push_back(wk);
      s.segment_island.push_back(island ? 1 : 0);
      s.segment_split_from.push_back(-1);
      s.segment_of[c] = k;
      s.segment_cells.push_back(c);
      to_compare_.clear();
      to_compare_.push_back(c);
      if (with_footprint && k == 0 && wk == robot_w) {
        for (int f = 0; f < n; ++f) {
          if (!s.footprint[f] || s.segment_of[f] >= 0) continue;
          s.segment_of[f] = k;
          s.segment_cells.push_back(f);
          to_compare_.push_back(f);
        }
      }
      // Steps 6-18: compare every cell of S_k with its examined neighbours.
      while (!to_compare_.empty()) {
        const int ci = to_compare_.back();
        to_compare_.pop_back();
        const int ui = ci % w_cells, vi = ci / w_cells;
        for (int j = 0; j < num_nb; ++j) {
          const int un = ui + kDu[j], vn = vi + kDv[j];
          if (un < 0 || vn < 0 || un >= w_cells || vn >= s.height) continue;
          const int cn = vn * w_cells + un;
          if (!s.examined[cn]) continue;
          const std::int32_t wn = heightOf(cn);
          if (wn == HeightMap::kNoHeight) continue;
          compared_[cn] = 1;
          if (!admissible(cn)) continue;
          if (wn == wk) {
            // Step 12. Equal-height neighbours always end up in the same segment, so a cell
            // of this height already in a segment is in this one.
            if (s.segment_of[cn] < 0) {
              s.segment_of[cn] = k;
              s.segment_cells.push_back(cn);
              to_compare_.push_back(cn);
            }
          } else if (std::llabs(static_cast<long long>(wn) - wk) <= w_t) {
            // Step 14: close in height, may start a new segment.
            if (s.segment_of[cn] < 0) pending_.push_back(cn);
          }
        }
      }
      s.segment_begin.push_back(static_cast<int>(s.segment_cells.size()));
      // Steps 19-21: pop L_U until a cell in no segment is found.
      c = -1;
      while (pending_head < pending_.size()) {
        const int p = pending_[pending_head++];
        if (s.segment_of[p] < 0) {
          c = p;
          break;
        }
      }
    }
  };
  grow(s.seed_cell, false, true);
  if (s.seed_cell >= 0) s.robot_segment = 0;

  if (config_.segment_islands) {
    // Columns Alg. 1 compared and left out keep 000's verdict: non-traversable.
    for (int cell = 0; cell < n; ++cell)
      locked_[cell] = compared_[cell] && s.segment_of[cell] < 0;
    for (int cell = 0; cell < n; ++cell) {
      if (!s.examined[cell] || s.segment_of[cell] >= 0 || locked_[cell] || compared_[cell])
        continue;
      if (heightOf(cell) == HeightMap::kNoHeight || !groundLike(cell)) continue;
      grow(cell, true, false);
    }
  }

  if (config_.split_steps) splitSteps(hm, voxel_size, &s);

  // Non-traversable columns (000, Sec. V-A): a height, within R_max, in no segment.
  for (int cell = 0; cell < n; ++cell) {
    if (s.examined[cell] && s.segment_of[cell] < 0 && hm.atIndex(cell) != HeightMap::kNoHeight) {
      s.non_traversable.push_back(cell);
    }
  }
  return true;
}

void GroundSegmentation::splitSteps(const HeightMap& hm, double l, GroundSegments* out) {
  GroundSegments& s = *out;
  const int n = s.numCells();
  const int nseg0 = s.numSegments();
  const int min_cells = config_.split_min_cells;
  const int w_cells = s.width;
  static constexpr int kDu[8] = {1, -1, 0, 0, 1, 1, -1, -1};
  static constexpr int kDv[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  PlaneFitConfig fit_config;
  fit_config.min_points = 3;
  PlaneFitConfig local_config;  // a border cell's local planes: six columns at least
  local_config.min_points = 6;
  split_side_.assign(n, -1);
  split_part_.assign(n, -1);
  split_dist_.assign(n, kSplitFar);
  bool any = false;
  auto xOf = [&](int c) { return s.cellU(c) * l; };
  auto yOf = [&](int c) { return s.cellV(c) * l; };
  // Connected parts (8-neighbours) of the tested columns with the same side; split_part_ holds
  // each column's part, split_part_size_ the sizes, split_part_cells_ the cells part by part.
  auto findParts = [&](int k) {
    split_part_size_.clear();
    split_part_cells_.clear();
    for (const int c : split_cols_)
      split_part_[c] = -1;
    for (const int c0 : split_cols_) {
      if (split_part_[c0] >= 0) continue;
      const int id = static_cast<int>(split_part_size_.size());
      const std::int8_t side = split_side_[c0];
      split_part_[c0] = id;
      split_stack_.assign(1, c0);
      int size = 0;
      while (!split_stack_.empty()) {
        const int c = split_stack_.back();
        split_stack_.pop_back();
        split_part_cells_.push_back(c);
        ++size;
        const int u = c % w_cells, v = c / w_cells;
        for (int j = 0; j < 8; ++j) {
          const int un = u + kDu[j], vn = v + kDv[j];
          if (un < 0 || vn < 0 || un >= w_cells || vn >= s.height) continue;
          const int cn = vn * w_cells + un;
          if (s.segment_of[cn] != k || split_side_[cn] != side || split_part_[cn] >= 0) continue;
          split_part_[cn] = id;
          split_stack_.push_back(cn);
        }
      }
      split_part_size_.push_back(size);
    }
  };

  for (int k = 0; k < nseg0; ++k) {
    if (s.segmentSize(k) < 2 * min_cells) continue;
    // The segment's ground-like columns. A segment whose columns span no plane (a strip one
    // cell wide) is not tested.
    split_cols_.clear();
    PlaneFitAccumulator all;
    for (const int* it = s.cellsBegin(k); it != s.cellsEnd(k); ++it) {
      const int c = *it;
      if (s.footprint[c]) continue;
      const float g = hm.groundHeightAtIndex(c);
      const std::int32_t w = hm.atIndex(c);
      if (!std::isfinite(g) || w == HeightMap::kNoHeight ||
          static_cast<long long>(w) - hm.lowestAtIndex(c) > 1) {
        continue;
      }
      split_cols_.push_back(c);
      all.add(Eigen::Vector3d(xOf(c), yOf(c), g));
    }
    if (static_cast<int>(split_cols_.size()) < 2 * min_cells) continue;
    if (!all.fit(fit_config).valid) continue;
    // Otsu's threshold on the ground heights: the cut maximising n0 n1 (m0 - m1)^2.
    split_res_.clear();
    double total = 0.0;
    for (const int c : split_cols_) {
      const float g = hm.groundHeightAtIndex(c);
      split_res_.emplace_back(g, c);
      total += g;
    }
    std::sort(split_res_.begin(), split_res_.end());
    const int m = static_cast<int>(split_res_.size());
    double best = -1.0, prefix = 0.0;
    int cut = 0;  // the first `cut` heights are the low side
    for (int i = 1; i < m; ++i) {
      prefix += split_res_[i - 1].first;
      if (split_res_[i].first == split_res_[i - 1].first) continue;
      const double n0 = i, n1 = m - i;
      const double d = prefix / n0 - (total - prefix) / n1;
      const double between = n0 * n1 * d * d;
      if (between > best) {
        best = between;
        cut = i;
      }
    }
    if (cut == 0) continue;
    for (int i = 0; i < m; ++i)
      split_side_[split_res_[i].second] = i < cut ? 0 : 1;
    // Parts smaller than split_min_cells are noise: they join the other side. Then each column
    // goes to the side whose plane is nearer its ground height, kSplitIterations times: an
    // unreported chassis pitch tilts the map's floor by a few centimetres over R_max, so a
    // threshold on the heights alone cuts a tilted floor along a contour line, while two planes
    // follow the two levels of a step on it.
    for (int it = 0;; ++it) {
      findParts(k);
      for (const int c : split_cols_) {
        if (split_part_size_[split_part_[c]] < min_cells) split_side_[c] = 1 - split_side_[c];
      }
      if (it == kSplitIterations) break;
      PlaneFitAccumulator side_fit[2];
      for (const int c : split_cols_)
        side_fit[split_side_[c]].add(Eigen::Vector3d(xOf(c), yOf(c), hm.groundHeightAtIndex(c)));
      const GroundPlane q0 = side_fit[0].fit(fit_config), q1 = side_fit[1].fit(fit_config);
      if (!q0.valid || !q1.valid) break;
      for (const int c : split_cols_) {
        const double g = hm.groundHeightAtIndex(c);
        split_side_[c] =
            std::abs(g - q1.heightAt(xOf(c), yOf(c))) < std::abs(g - q0.heightAt(xOf(c), yOf(c)))
                ? 1
                : 0;
      }
    }
    int side_count[2] = {0, 0};
    PlaneFitAccumulator side_fit[2];
    for (const int c : split_cols_) {
      ++side_count[split_side_[c]];
      side_fit[split_side_[c]].add(Eigen::Vector3d(xOf(c), yOf(c), hm.groundHeightAtIndex(c)));
    }
    if (side_count[0] >= min_cells && side_count[1] >= min_cells) {
      // The side that stays: the robot's, else the larger.
      int keep = side_count[1] > side_count[0] ? 1 : 0;
      if (k == s.robot_segment) {
        if (s.seed_cell >= 0 && split_side_[s.seed_cell] >= 0) {
          keep = split_side_[s.seed_cell];
        } else {
          const GroundPlane q0 = side_fit[0].fit(fit_config), q1 = side_fit[1].fit(fit_config);
          const double xr = s.robot.u * l, yr = s.robot.v * l, zr = s.robot.w * l;
          if (q0.valid && q1.valid) {
            keep = std::abs(q1.heightAt(xr, yr) - zr) < std::abs(q0.heightAt(xr, yr) - zr) ? 1 : 0;
          }
        }
      }
      // Each column's distance from the sides' border (8-neighbour steps, up to kSplitBand).
      split_queue_.clear();
      for (const int c : split_cols_) {
        const int u = c % w_cells, v = c / w_cells;
        for (int j = 0; j < 8; ++j) {
          const int un = u + kDu[j], vn = v + kDv[j];
          if (un < 0 || vn < 0 || un >= w_cells || vn >= s.height) continue;
          const int cn = vn * w_cells + un;
          if (s.segment_of[cn] == k && split_side_[cn] == 1 - split_side_[c]) {
            split_dist_[c] = 0;
            split_queue_.push_back(c);
            break;
          }
        }
      }
      for (std::size_t head = 0; head < split_queue_.size(); ++head) {
        const int c = split_queue_[head];
        if (split_dist_[c] >= kSplitBand) continue;
        const int u = c % w_cells, v = c / w_cells;
        for (int j = 0; j < 8; ++j) {
          const int un = u + kDu[j], vn = v + kDv[j];
          if (un < 0 || vn < 0 || un >= w_cells || vn >= s.height) continue;
          const int cn = vn * w_cells + un;
          if (s.segment_of[cn] != k || split_side_[cn] != split_side_[c] ||
              split_dist_[cn] <= split_dist_[c] + 1)
            continue;
          split_dist_[cn] = static_cast<std::int8_t>(split_dist_[c] + 1);
          split_queue_.push_back(cn);
        }
      }
      // Each connected part of the other side leaves when it is a step: at each of its border
      // cells, the local planes of the two sides are fitted to their columns 1 to kSplitBand
      // cells from the border (the border columns mix the two levels' points) within
      // kSplitWindow cells, and the part's step is their difference at the median border cell.
      // Across a step the local planes are the two levels; across the contour line along which
      // Otsu cut a ramp they are the same plane.
      findParts(k);
      const int first_new = s.numSegments();
      std::size_t begin = 0;
      for (std::size_t part = 0; part < split_part_size_.size(); ++part) {
        const int size = split_part_size_[part];
        const int* cells = split_part_cells_.data() + begin;
        begin += size;
        if (split_side_[cells[0]] == keep) continue;
        split_diffs_.clear();
        for (int i = 0; i < size; ++i) {
          const int c = cells[i];
          if (split_dist_[c] != 0) continue;
          const int u = c % w_cells, v = c / w_cells;
          PlaneFitAccumulator local[2];  // [0] this part, [1] the side that stays
          for (int vn = std::max(0, v - kSplitWindow);
               vn <= std::min(s.height - 1, v + kSplitWindow); ++vn) {
            for (int un = std::max(0, u - kSplitWindow);
                 un <= std::min(w_cells - 1, u + kSplitWindow); ++un) {
              const int cn = vn * w_cells + un;
              if (s.segment_of[cn] != k || split_dist_[cn] < 1 || split_dist_[cn] > kSplitBand)
                continue;
              const bool mine = split_part_[cn] == static_cast<int>(part);
              if (!mine && split_side_[cn] != keep) continue;
              local[mine ? 0 : 1].add(
                  Eigen::Vector3d(xOf(cn), yOf(cn), hm.groundHeightAtIndex(cn)));
            }
          }
          const GroundPlane p0 = local[0].fit(local_config), p1 = local[1].fit(local_config);
          if (!p0.valid || !p1.valid) continue;
          split_diffs_.push_back(
              static_cast<float>(p0.heightAt(xOf(c), yOf(c)) - p1.heightAt(xOf(c), yOf(c))));
        }
        if (split_diffs_.empty()) continue;
        auto mid = split_diffs_.begin() + split_diffs_.size() / 2;
        std::nth_element(split_diffs_.begin(), mid, split_diffs_.end());
        if (!(std::abs(*mid) > config_.split_min_step)) continue;
        const int id = s.numSegments();
        s.segment_height.push_back(s.segment_height[k]);
        s.segment_island.push_back(s.segment_island[k]);
        s.segment_split_from.push_back(k);
        for (int i = 0; i < size; ++i)
          s.segment_of[cells[i]] = id;
      }
      any = any || s.numSegments() > first_new;
    }
    for (const int c : split_cols_) {
      split_side_[c] = -1;
      split_part_[c] = -1;
      split_dist_[c] = kSplitFar;
    }
  }
  if (!any) return;
  // Cells listed segment by segment again, in scan order within each.
  const int nseg = s.numSegments();
  s.segment_begin.assign(nseg + 1, 0);
  for (int c = 0; c < n; ++c)
    if (s.segment_of[c] >= 0) ++s.segment_begin[s.segment_of[c] + 1];
  for (int k = 0; k < nseg; ++k)
    s.segment_begin[k + 1] += s.segment_begin[k];
  split_stack_.assign(s.segment_begin.begin(), s.segment_begin.end() - 1);
  s.segment_cells.assign(s.segment_begin[nseg], -1);
  for (int c = 0; c < n; ++c)
    if (s.segment_of[c] >= 0) s.segment_cells[split_stack_[s.segment_of[c]]++] = c;
}

}  // namespace stereo_safety_map
